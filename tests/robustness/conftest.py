"""Fixtures of the robustness suite: one rendered pair and its broken variants, made once."""

from __future__ import annotations

import logging

import cv2
import numpy as np
import pytest

from stereo_obstacles import cli
from robustness._inputs import PAIR_SIZE, palette_png, write_png_chunks, write_rgb


@pytest.fixture(scope="session")
def inputs(tmp_path_factory):
    """A folder of input files: the synthetic pair ``left.png``/``right.png`` and odd variants."""
    from stereo_obstacles.synthetic import default_scene, render_pair, write_scene_folder

    folder = tmp_path_factory.mktemp("robustness_inputs")
    pair = render_pair(default_scene(*PAIR_SIZE))
    write_scene_folder(folder / "scene", pair)
    left, right = pair.left, pair.right
    write_rgb(folder / "left.png", left)
    write_rgb(folder / "right.png", right)
    (folder / "empty.png").write_bytes(b"")
    data = (folder / "left.png").read_bytes()
    (folder / "truncated.png").write_bytes(data[: len(data) // 2])
    (folder / "text.png").write_text("not an image\n")
    write_rgb(folder / "smaller.png", left[:100, :150].copy())
    write_rgb(folder / "grey_left.png", cv2.cvtColor(left, cv2.COLOR_RGB2GRAY))
    write_rgb(folder / "grey_right.png", cv2.cvtColor(right, cv2.COLOR_RGB2GRAY))
    write_rgb(folder / "left16.png", left.astype(np.uint16) * 257)
    write_rgb(folder / "right16.png", right.astype(np.uint16) * 257)
    cv2.imwrite(str(folder / "left_rgba.png"), cv2.cvtColor(left, cv2.COLOR_RGB2BGRA))
    cv2.imwrite(str(folder / "right_rgba.png"), cv2.cvtColor(right, cv2.COLOR_RGB2BGRA))
    palette_png(folder / "palette_left.png", left)
    palette_png(folder / "palette_right.png", right)
    for side in (1, 4, 5):
        write_rgb(folder / f"tiny{side}_left.png", left[60:60 + side, 60:60 + side].copy())
        write_rgb(folder / f"tiny{side}_right.png", right[60:60 + side, 60:60 + side].copy())
    uniform = np.zeros((120, 160, 3), np.uint8)
    uniform[:] = (200, 120, 40)
    write_rgb(folder / "uniform.png", uniform)
    smooth = np.zeros((120, 160, 3), np.uint8)
    smooth[..., 0] = np.linspace(30, 200, 160).astype(np.uint8)[None]
    smooth[..., 1], smooth[..., 2] = 90, 150
    write_rgb(folder / "smooth.png", smooth)
    write_png_chunks(folder / "huge_header.png", 60000, 60000, 2, b"\x00" * 100)
    (folder / "a_file").write_text("x\n")
    return folder


@pytest.fixture
def run_cli(capsys, caplog):
    """Run ``stereo-obstacles ARGS`` in this process: returns ``(exit code, stdout, stderr, log text)``.

    Asserts the rules every run must keep: exit 0, 1 or 2 (never 3, an internal error) and no
    traceback on stderr.
    """
    def run(*args: str) -> tuple[int, str, str, str]:
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            try:
                code = cli.main([str(a) for a in args])
            except SystemExit as exc:  # argparse usage errors
                code = exc.code
        out, err = capsys.readouterr()
        assert code in (0, 1, 2), f"exit {code} for {args}: {err}"
        assert "Traceback" not in err, err
        return code, out, err, caplog.text
    return run

