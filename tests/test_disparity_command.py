"""The ``stereo-obstacles disparity`` command end to end."""

from __future__ import annotations

import json

import numpy as np

from stereo_obstacles.cli import main
from stereo_obstacles.fileio import read_disparity, read_image, write_image


def _write_pair(tmp_path, shift=4):
    rng = np.random.default_rng(0)
    base = rng.integers(0, 256, (40, 70), dtype=np.uint8)
    left, right = base[:, :64], base[:, shift:shift + 64]
    write_image(tmp_path / "l.png", np.ascontiguousarray(left))
    write_image(tmp_path / "r.png", np.ascontiguousarray(right))
    return tmp_path / "l.png", tmp_path / "r.png"


def test_disparity_command_writes_maps_picture_and_json(tmp_path, capsys):
    left, right = _write_pair(tmp_path)
    for suffix in (".npy", ".pfm", ".png"):
        out = tmp_path / f"d{suffix}"
        rc = main(["disparity", str(left), str(right), "-o", str(out), "--max-disparity", "10", "--json",
                   "--picture", str(tmp_path / "p.png")])
        assert rc == 0
        d = read_disparity(out)
        assert abs(np.nanmedian(d) - 4) < 0.05
        stats = json.loads(capsys.readouterr().out.strip())
        assert stats["match_seconds"] > 0 and 0 < stats["density"] <= 1
    assert read_image(tmp_path / "p.png").shape == (40, 64, 3)


def test_disparity_command_seed_file_and_errors(tmp_path, capsys):
    left, right = _write_pair(tmp_path)
    seeds = tmp_path / "seeds.txt"
    seeds.write_text("# x y d\n30 20 4\n")
    assert main(["disparity", str(left), str(right), "-o", str(tmp_path / "d.npy"), "--seeds", str(seeds),
                 "--max-disparity", "10"]) == 0
    assert main(["disparity", str(left), str(right), "-o", str(tmp_path / "d.txt")]) == 1
    assert "disparity can be written" in capsys.readouterr().err
    assert main(["disparity", str(left), str(right), "-o", str(tmp_path / "d.npy"), "--seeds", "nope"]) == 1
    assert main(["disparity", str(left), str(tmp_path / "missing.png"), "-o", str(tmp_path / "e.npy")]) == 1
    assert not (tmp_path / "e.npy").exists()


def test_disparity_command_defaults_are_the_matchers(tmp_path, capsys):
    import inspect

    from stereo_obstacles.cli import build_parser
    from stereo_obstacles.matching import match

    args = build_parser().parse_args(["disparity", "l.png", "r.png", "-o", "d.npy"])
    defaults = inspect.signature(match).parameters
    for name in ("seeds", "max_disparity", "min_disparity", "tau", "mu", "max_candidates", "final_margin",
                 "variant", "similarity", "rng_seed", "bands", "shifted_windows", "speckle_size", "speckle_range"):
        assert getattr(args, name) == defaults[name].default, name
    left, right = _write_pair(tmp_path)
    assert main(["disparity", str(left), str(right), "-o", str(tmp_path / "d.npy"), "--max-disparity", "10"]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {tmp_path / 'd.npy'}: ")
