"""NaN, zero, negative and absurd calibration values, from files and from --focal/--baseline."""

from __future__ import annotations

import pytest

from robustness._inputs import error_line

MIDDLEBURY = "cam0=[{f} 0 80; 0 {f} 60; 0 0 1]\ncam1=[{f} 0 80; 0 {f} 60; 0 0 1]\ndoffs={doffs}\nbaseline={b}\n" \
             "width=160\nheight=120\n"


@pytest.mark.parametrize("options, message", [
    (["--focal", "nan", "--baseline", "0.12"], "focal_px must be a finite number, got nan"),
    (["--focal", "0", "--baseline", "0.12"], "focal_px must be > 0"),
    (["--focal", "-5", "--baseline", "0.12"], "focal_px must be > 0"),
    (["--focal", "1e300", "--baseline", "0.12"], "focal_px = 1e+300 px is implausible"),
    (["--focal", "138", "--baseline", "inf"], "baseline_m must be a finite number, got inf"),
    (["--focal", "138", "--baseline", "0"], "baseline_m must be > 0"),
    (["--focal", "138", "--baseline", "120"], "millimetres given as metres?"),
    (["--focal", "138", "--baseline", "0.12", "--cx", "nan"], "cx_px must be a finite number"),
    (["--focal", "138", "--baseline", "0.12", "--doffs", "1e9"], "doffs_px = 1e+09 px is implausible"),
    (["--focal", "138", "--baseline", "0.12", "--doffs", "-1000"], "doffs_px = -1000 px is implausible"),
    (["--focal", "138"], "--focal and --baseline must be given together"),
    (["--cx", "80"], "--focal and --baseline must be given together (--cx given)"),          # was ignored
    (["--doffs", "3", "--cy", "60"], "--focal and --baseline must be given together (--cy, --doffs given)"),
    (["--calib", "scene/calibration.json", "--cx", "80"], "give either --calib FILE or --focal and --baseline, "
                                                          "not both (--cx given with --calib)"),     # was ignored
])
def test_bad_manual_calibration_is_one_line(inputs, run_cli, tmp_path, options, message):
    options = [str(inputs / o) if o.endswith(".json") else o for o in options]
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o", *options)
    assert code == 1 and message in error_line(err)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("content, message", [
    (MIDDLEBURY.format(f="nan", doffs=0, b=120), "focal_px must be a finite number"),
    (MIDDLEBURY.format(f="138", doffs=0, b=-120), "baseline_m must be > 0"),
    (MIDDLEBURY.format(f="0", doffs=0, b=120), "focal_px must be > 0"),
    (MIDDLEBURY.format(f="138", doffs=500, b=120), "doffs_px = 500 px is implausible"),
    ("", "is not a calibration format this tool reads"),
    ("[1, 2", "is not a calibration format this tool reads"),
    ('{"format": "stereo-obstacles/calibration", "version": 1, "focal_px": "x", "cx_px": 1, "cy_px": 1, '
     '"baseline_m": 0.1}', "focal_px must be a finite number, got 'x'"),
    ("%YAML:1.0\n---\nfoo: [1\n", "OpenCV cannot parse this file"),
    ("%YAML:1.0\n---\nfoo: 1\n", "has no rectified projection matrices P1 and P2"),
])
def test_bad_calibration_file_is_one_line(inputs, run_cli, tmp_path, content, message):
    calib = tmp_path / ("calib.yaml" if content.startswith("%YAML") else "calib.txt")
    calib.write_text(content)
    for command in (["detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o"],
                    ["disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.npy"]):
        code, _, err, _ = run_cli(*command, "--calib", calib)
        if command[0] == "disparity" and "P1 and P2" in message:
            continue  # disparity takes a rectified calibration file as optional metadata only
        assert code == 1 and message in error_line(err), command


def test_a_binary_or_missing_calibration_file_is_named(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              "--calib", inputs / "left.png")
    assert code == 1 and f"calibration file {inputs / 'left.png'} is not a text file" in error_line(err)
    code, _, err, _ = run_cli("detect", inputs / "left.png", inputs / "right.png", "--out", tmp_path / "o",
                              "--calib", tmp_path / "none.txt")
    assert code == 1 and "does not exist" in error_line(err)


def test_a_calibration_for_another_size_is_refused(inputs, run_cli, tmp_path):
    code, _, err, _ = run_cli("detect", inputs / "tiny5_left.png", inputs / "tiny5_right.png", "--out",
                              tmp_path / "o", "--calib", inputs / "scene" / "calibration.json")
    assert code == 1 and "calibration is for 160x120 images, the images are 5x5" in error_line(err)
