"""The evaluation registry, its timing and report, and the ``evaluate`` command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stereo_obstacles.cli import main
from stereo_obstacles.datasets import load_pair
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.evaluation import (METHODS, Method, available_methods, evaluate_pair,
                                         format_table, report_dict, resolve_methods)
from stereo_obstacles.fileio import write_image, write_pfm

SHIFT = 6


@pytest.fixture()
def shifted_scene(tmp_path):
    """A synthetic-layout folder: random texture seen with a constant disparity of SHIFT px."""
    rng = np.random.default_rng(0)
    h, w = 48, 96
    base = rng.integers(0, 256, (h, w + SHIFT, 3), dtype=np.uint8)
    folder = tmp_path / "scene"
    folder.mkdir()
    write_image(folder / "left.png", np.ascontiguousarray(base[:, :w]))
    write_image(folder / "right.png", np.ascontiguousarray(base[:, SHIFT:]))
    gt = np.full((h, w), float(SHIFT), np.float32)
    gt[:, :SHIFT] = np.nan  # no match in the right image
    write_pfm(folder / "disparity.pfm", gt)
    return folder


def _fake_method(disparity_value, calls):
    def run(left, right, max_disparity):
        calls.append(max_disparity)
        return np.full(left.shape[:2], disparity_value, np.float32), {"calls": len(calls)}
    return Method("fake", "a constant", run, "stereo_obstacles.peers")


def test_registry_names_and_availability():
    assert list(METHODS) == ["gcs", "sgbm", "bm", "ncc-wta"]
    assert {"sgbm", "bm", "ncc-wta"} <= set(available_methods())
    assert [m.name for m in resolve_methods(["bm", "sgbm", "bm"])] == ["bm", "sgbm"]
    assert Method("x", "", lambda *a: None, "stereo_obstacles.no_such_module").available is False


@pytest.mark.parametrize(("names", "match"), [(["nope"], "unknown method 'nope'"),
                                              ([], "at least one"),
                                              ("gcs", "got the string 'gcs' \\(write \\['gcs'\\]\\)")])
def test_resolve_methods_errors(names, match):
    with pytest.raises(InvalidInputError, match=match):
        resolve_methods(names)


def test_evaluate_pair_wants_methods_not_their_names(shifted_scene):
    pair = load_pair(shifted_scene)
    with pytest.raises(InvalidInputError, match="expected Method objects"):
        evaluate_pair(pair, ["gcs"])
    [result] = evaluate_pair(pair, (m for m in resolve_methods(["gcs"])), repeat=1)   # any iterable of methods
    assert result.method == "gcs"


def test_evaluate_pair_times_a_first_call_and_repeat_runs(shifted_scene):
    pair = load_pair(shifted_scene)
    calls = []
    [result] = evaluate_pair(pair, [_fake_method(SHIFT + 0.5, calls)], repeat=4)
    assert calls == [SHIFT] * 5  # first call + 4 timed runs, range from the ground truth
    assert result.runs == 4 and result.method_stats == {"calls": 5}
    assert result.metrics.density_pct == 100.0 and result.metrics.bad1_matched_pct == 0.0
    assert result.max_disparity_px == SHIFT and not result.kitti
    assert result.first_call_seconds >= 0 and result.median_seconds >= 0
    d = result.to_dict()
    assert d["metrics"]["epe_px"] == pytest.approx(0.5)


def test_evaluate_pair_errors(shifted_scene, tmp_path):
    pair = load_pair(shifted_scene)
    with pytest.raises(InvalidInputError, match="repeat"):
        evaluate_pair(pair, resolve_methods(["bm"]), repeat=0)
    (shifted_scene / "disparity.pfm").unlink()
    with pytest.raises(InvalidInputError, match="no ground-truth"):
        evaluate_pair(load_pair(shifted_scene), resolve_methods(["bm"]))


def test_table_and_report(shifted_scene):
    pair = load_pair(shifted_scene)
    results = evaluate_pair(pair, [_fake_method(np.nan, [])], repeat=1)
    table = format_table(results)
    assert "scene" in table and "fake" in table
    row = table.splitlines()[2].split()
    assert row[2] == "0.0" and row[3] == "-"  # density 0, bad-1 over matched undefined
    report = json.loads(json.dumps(report_dict(results, repeat=1), allow_nan=False))
    assert report["format"] == "stereo-obstacles/evaluation"
    assert report["machine"]["logical_cpus"] >= 1
    assert report["results"][0]["metrics"]["bad1_matched_pct"] is None


def test_evaluate_command_on_a_known_shift(shifted_scene, tmp_path, capsys):
    out = tmp_path / "out" / "eval.json"
    code = main(["evaluate", str(shifted_scene), "--methods", "sgbm,bm,ncc-wta", "--repeat", "1",
                 "--json", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "ncc-wta" in captured.out and "wrote" in captured.out
    report = json.loads(out.read_text())
    by_method = {r["method"]: r for r in report["results"]}
    assert set(by_method) == {"sgbm", "bm", "ncc-wta"}
    for r in by_method.values():
        assert r["metrics"]["density_pct"] > 50
        assert r["metrics"]["bad1_matched_pct"] < 5
        assert r["median_seconds"] >= 0 and r["runs"] == 1
    assert not list(out.parent.glob(".*part*"))  # written atomically, nothing left over


@pytest.mark.parametrize(("argv", "message"), [
    (["--methods", "sgbm,nope"], "unknown method 'nope'"),
    (["MISSING", "--methods", "bm"], "does not exist"),
])
def test_evaluate_command_errors_are_one_line(shifted_scene, tmp_path, capsys, argv, message):
    argv = [a if a != "MISSING" else str(tmp_path / "missing") for a in argv]
    code = main(["evaluate", str(shifted_scene), *argv, "--repeat", "1"])
    err = capsys.readouterr().err
    assert code == 1
    assert message in err and len(err.strip().splitlines()) == 1


def test_evaluate_command_without_ground_truth(shifted_scene, capsys):
    (shifted_scene / "disparity.pfm").unlink()
    assert main(["evaluate", str(shifted_scene), "--methods", "bm"]) == 1
    assert "no ground-truth" in capsys.readouterr().err


def test_the_matchers_are_evaluated_beside_a_calibration_that_does_not_parse(shifted_scene, capsys):
    # the matchers use no calibration; the folder's broken one failed the evaluation (review, session 23)
    (shifted_scene / "calibration.json").write_text("{bad")
    assert main(["evaluate", str(shifted_scene), "--methods", "bm", "--repeat", "1"]) == 0, capsys.readouterr().err


def test_evaluate_command_rejects_a_zero_repeat(shifted_scene, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", str(shifted_scene), "--repeat", "0"])
    assert exc.value.code == 2
    assert "positive integer" in capsys.readouterr().err


@pytest.mark.shared_data
def test_evaluate_command_on_tsukuba(shared_dataset, tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = main(["evaluate", str(shared_dataset("middlebury2001_tsukuba")), "--methods", "sgbm",
                 "--repeat", "1", "--json", str(out)])
    assert code == 0, capsys.readouterr().err
    [result] = json.loads(out.read_text())["results"]
    m = result["metrics"]
    # OpenCV SGBM on Tsukuba, non-occluded: dense and a few percent bad-1
    assert m["density_pct"] > 90 and m["bad1_matched_pct"] < 8
    assert result["max_disparity_px"] == 14 and math.isfinite(m["epe_px"])


def test_gcs_plugs_into_the_registry(shifted_scene):
    if "gcs" not in available_methods():
        pytest.skip("the GCS matcher (stereo_obstacles.matching) is not installed")
    pair = load_pair(shifted_scene)
    [result] = evaluate_pair(pair, resolve_methods(["gcs"]), repeat=1)
    assert result.method == "gcs"
    assert result.metrics.density_pct > 50 and result.metrics.bad1_matched_pct < 5
    assert "match_seconds" in result.method_stats
