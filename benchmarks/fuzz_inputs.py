"""Bounded fuzz run over the file readers and the command line (issue 8).

Hypothesis generates (1) byte strings and mutated valid files fed to every ``fileio.read_*``,
``read_calibration`` and ``datasets.load_pair`` on generated folders, which must return or
raise a :class:`~stereo_obstacles.errors.StereoObstaclesError`; and (2) argument lists drawn
from a grammar of the real options, run in-process with ``cli.main``, which must exit 0, 1 or 2
with no traceback on stderr. Prints the cases tried and the failures.

Usage: ``python benchmarks/fuzz_inputs.py [--seconds 150]`` (split between the two parts).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import sys
import tempfile
import time
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stereo_obstacles import cli
from stereo_obstacles.calibration_files import read_calibration
from stereo_obstacles.datasets import load_pair
from stereo_obstacles.errors import StereoObstaclesError
from stereo_obstacles.fileio import (read_depth, read_disparity, read_image, read_kitti_disparity, read_labels,
                                     read_npy, read_pfm, write_image, write_npy, write_pfm)

READERS = {".png": (read_image, read_kitti_disparity, read_labels, read_disparity, read_depth),
           ".pfm": (read_pfm, read_disparity, read_depth), ".npy": (read_npy, read_disparity, read_depth),
           ".txt": (read_calibration,), ".json": (read_calibration,), ".yaml": (read_calibration,)}


def make_seed_files(folder: Path) -> dict[str, bytes]:
    """Valid example files whose bytes the fuzzer mutates, by suffix."""
    from stereo_obstacles.synthetic import default_scene, render_pair, write_scene_folder

    pair = render_pair(default_scene(48, 32))
    write_scene_folder(folder / "scene", pair)
    write_image(folder / "seed.png", pair.left)
    write_pfm(folder / "seed.pfm", pair.disparity)
    write_npy(folder / "seed.npy", pair.disparity)
    (folder / "seed.txt").write_text("cam0=[40 0 24; 0 40 16; 0 0 1]\ncam1=[40 0 24; 0 40 16; 0 0 1]\n"
                                     "doffs=0\nbaseline=120\nwidth=48\nheight=32\n")
    (folder / "seed.yaml").write_text("%YAML:1.0\n---\nP1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n"
                                      "   data: [ 40., 0., 24., 0., 0., 40., 16., 0., 0., 0., 1., 0. ]\n"
                                      "P2: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n"
                                      "   data: [ 40., 0., 24., -4.8, 0., 40., 16., 0., 0., 0., 1., 0. ]\n")
    return {suffix: (folder / f"seed{suffix}").read_bytes() for suffix in (".png", ".pfm", ".npy", ".txt",
                                                                           ".yaml")} | {
        ".json": (folder / "scene" / "calibration.json").read_bytes()}


def mutated(seed: bytes):
    """Strategy: ``seed`` truncated, with bytes overwritten, inserted or appended, or random bytes."""
    def mutate(data: bytes, cut: int, edits: list[tuple[int, int]], extra: bytes) -> bytes:
        out = bytearray(data[: max(cut, 0)] if cut < len(data) else data)
        for position, value in edits:
            if out:
                out[position % len(out)] = value
        return bytes(out) + extra
    return st.one_of(st.binary(max_size=512),
                     st.builds(mutate, st.just(seed), st.integers(0, len(seed) + 1),
                               st.lists(st.tuples(st.integers(0, 1 << 20), st.integers(0, 255)), max_size=8),
                               st.binary(max_size=16)))


def check_reader(reader, path: Path) -> None:
    """Call ``reader(path)``: a result or a StereoObstaclesError; anything else is a failure."""
    try:
        reader(path)
    except StereoObstaclesError:
        pass


def option_grammar(files: dict[str, str]):
    """Strategy: argument lists of real commands with real, odd and broken option values."""
    numbers = st.sampled_from(["0", "-1", "1", "3", "0.5", "nan", "inf", "-inf", "1e300", "abc", "", "64", "1e-9"])
    sizes = st.sampled_from(["32x24", "0x0", "16x16", "4x4", "x", "99999999x9", "48x32", "-5x8"])
    image = st.sampled_from([files[k] for k in ("left", "right", "bad", "missing", "folder", "grey", "text")])
    out_dir = st.sampled_from([files["out"], files["under_file"], files["file"]])
    out_file = st.sampled_from([files["out"] + "/d.npy", files["out"] + "/d.pfm", files["out"] + "/d.png",
                                files["out"] + "/d.txt", files["under_file"] + "/d.npy"])
    calib = st.sampled_from([files["calib"], files["bad"], files["missing"], files["text"]])

    def flags(*pairs):
        return st.lists(st.sampled_from(pairs), max_size=4).flatmap(
            lambda chosen: st.tuples(*[value.map(lambda v, flag=flag: [flag, v]) if value is not None
                                       else st.just([flag]) for flag, value in chosen]))

    detection = flags(("--max-disparity", numbers), ("--seeds", st.sampled_from(["canny", "sobel", "random", "x"])),
                      ("--reference", st.sampled_from(["0,0,1,1", "1,1,0,0", "nan,0,1,1", "0,0.8,1,1", "a"])),
                      ("--corridor-width", numbers), ("--max-distance", numbers), ("--focal", numbers),
                      ("--baseline", numbers), ("--doffs", numbers), ("--calib", calib), ("--uncalibrated", None))
    matching = flags(("--max-disparity", numbers), ("--min-disparity", numbers), ("--tau", numbers),
                     ("--mu", numbers), ("--max-candidates", st.sampled_from(["0", "1", "10", "x"])),
                     ("--seeds", st.sampled_from(["canny", "random", files["bad"], files["seeds"]])),
                     ("--variant", st.sampled_from(["stable", "greedy", "x"])), ("--rng-seed", numbers),
                     ("--json", None), ("--calib", calib))
    commands = st.one_of(
        st.tuples(st.just(["detect"]), image, image, out_dir.map(lambda o: ["--out", o]), detection),
        st.tuples(st.just(["disparity"]), image, image, out_file.map(lambda o: ["-o", o]), matching),
        st.tuples(st.just(["segment"]), image, out_file.map(lambda o: ["-o", o.rsplit(".", 1)[0] + ".png"]),
                  flags(("--reference", st.sampled_from(["0,0,1,1", "2,2,1,1", "x"])), ("--no-shadow-rule", None))),
        st.tuples(st.just(["scene"]), out_dir.map(lambda o: ["--out", o]),
                  flags(("--size", sizes), ("--seed", numbers), ("--noise", numbers), ("--frames", numbers),
                        ("--supersample", numbers), ("--gain-diff", numbers))),
        st.tuples(st.just(["evaluate"]), st.sampled_from([files["dataset"], files["folder"], files["missing"]]),
                  flags(("--methods", st.sampled_from(["bm", "x", ""])), ("--repeat", numbers),
                        ("--max-frames", numbers))),
        st.tuples(st.just(["rectify"]), image, image, st.just(["--uncalibrated"]),
                  out_dir.map(lambda o: ["--out", o])),
        st.tuples(st.just(["video", "--kind"]), st.sampled_from(["images", "auto", "videos", "side-by-side"]),
                  st.sampled_from([[files["seq_left"], files["seq_right"]], [files["left"], files["right"]],
                                   [files["folder"], files["folder"]], [files["text"]], [files["missing"]]]),
                  flags(("--fps", numbers), ("--max-frames", numbers), ("--seed-step", numbers),
                        ("--refresh-every", numbers), ("--jsonl", out_file), ("--focal", numbers),
                        ("--baseline", numbers), ("--no-temporal-seeds", None), ("--reference", st.just("x")))),
        st.tuples(st.just(["batch"]), st.sampled_from([files["batch"], files["folder"], files["missing"]]),
                  out_dir.map(lambda o: ["--out", o]), st.just(["--workers", "1"]),
                  flags(("--task", st.sampled_from(["detect", "disparity"])), ("--max-disparity", numbers),
                        ("--calib", calib))),
        st.tuples(st.just(["evaluate-segmentation", "--scenes", "0"]),
                  flags(("--dataset", st.sampled_from([files["dataset"], files["folder"], files["missing"]])),
                        ("--json", out_file), ("--first-seed", numbers))),
        st.tuples(st.just(["evaluate-detection", "--scenes", "0"]),
                  flags(("--dataset", st.sampled_from([files["dataset"], files["folder"], files["missing"]])),
                        ("--json", out_file), ("--min-height", numbers), ("--max-distance", numbers))),
        st.tuples(st.just(["calibrate", "--folder"]), st.sampled_from([files["folder"], files["missing"]]),
                  flags(("--square", numbers), ("--board", st.sampled_from(["9x6", "0x0", "x"]))),
                  st.just(["--out", files["out"] + "/c.json"])),
    )

    def flatten(parts):
        args = []
        for part in parts:
            if isinstance(part, str):
                args.append(part)
            elif part and isinstance(part[0], list):
                for item in part:
                    args.extend(item)
            else:
                args.extend(part)
        return args
    return commands.map(flatten)


def run_command(args: list[str]) -> tuple[int, str]:
    """Run ``stereo-obstacles ARGS`` in-process; return the exit code and stderr."""
    for handler in list(logging.root.handlers):
        logging.root.removeHandler(handler)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = cli.main(args)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
    return code, err.getvalue()


def make_cli_files(folder: Path, seeds_folder: Path) -> dict[str, str]:
    """The files the command grammar refers to."""
    import shutil

    scene = seeds_folder / "scene"
    (folder / "a_file").write_text("x")
    (folder / "folder").mkdir(exist_ok=True)
    grey = read_image(scene / "left.png", mode="gray")
    write_image(folder / "grey.png", grey)
    (folder / "text.png").write_text("hello")
    (folder / "bad.png").write_bytes((scene / "left.png").read_bytes()[:100])
    (folder / "seeds.txt").write_text("10 10 2\n20 12 3\n")
    shutil.copytree(scene, folder / "dataset", dirs_exist_ok=True)
    shutil.copytree(scene, folder / "batch" / "pair", dirs_exist_ok=True)
    for side in ("left", "right"):
        (folder / f"seq_{side}").mkdir(exist_ok=True)
        for k in range(2):
            shutil.copy(scene / f"{side}.png", folder / f"seq_{side}" / f"{k}.png")
    return {"left": str(scene / "left.png"), "right": str(scene / "right.png"), "bad": str(folder / "bad.png"),
            "missing": str(folder / "missing.png"), "folder": str(folder / "folder"), "grey": str(folder / "grey.png"),
            "text": str(folder / "text.png"), "out": str(folder / "out"), "under_file": str(folder / "a_file" / "o"),
            "file": str(folder / "a_file"), "calib": str(scene / "calibration.json"), "seeds": str(folder / "seeds.txt"),
            "dataset": str(folder / "dataset"), "batch": str(folder / "batch"),
            "seq_left": str(folder / "seq_left"), "seq_right": str(folder / "seq_right")}


def fuzz(seconds: float, *, batch: int = 25, seed: int | None = None) -> dict:
    """Fuzz readers then the command line for about ``seconds``; return counts and failures.

    Each part runs rounds of ``batch`` Hypothesis examples until its share of the time is spent.
    """
    failures: list[str] = []
    counts = {"readers": 0, "load_pair": 0, "cli": 0}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        seeds = make_seed_files(root)
        common = dict(max_examples=batch, deadline=None, derandomize=seed is not None, database=None,
                      suppress_health_check=list(HealthCheck))

        @settings(**common)
        @given(st.sampled_from(sorted(READERS)).flatmap(lambda s: st.tuples(st.just(s), mutated(seeds[s]))))
        def readers(case):
            if time.monotonic() > stop:
                return
            suffix, data = case
            path = root / f"fuzz{suffix}"
            path.write_bytes(data)
            for reader in READERS[suffix]:
                counts["readers"] += 1
                try:
                    check_reader(reader, path)
                except Exception as exc:  # noqa: BLE001 - recorded as a finding
                    failures.append(f"{reader.__name__}({suffix}, {len(data)} bytes): {type(exc).__name__}: {exc}")

        names = sorted(p.name for p in (root / "scene").iterdir())

        @settings(**common)
        @given(st.lists(st.sampled_from(names), unique=True, min_size=1),
               st.sampled_from(names).flatmap(lambda n: st.tuples(st.just(n), mutated(seeds[".png"]))))
        def folders(keep, broken):
            if time.monotonic() > stop:
                return
            folder = root / f"pair{counts['load_pair']}"
            folder.mkdir()
            for name in keep:
                (folder / name).write_bytes((root / "scene" / name).read_bytes())
            (folder / broken[0]).write_bytes(broken[1])
            counts["load_pair"] += 1
            try:
                check_reader(load_pair, folder)
            except Exception as exc:  # noqa: BLE001
                failures.append(f"load_pair({sorted(keep)}, broken {broken[0]}): {type(exc).__name__}: {exc}")

        files = make_cli_files(root, root)

        @settings(**common)
        @given(option_grammar(files))
        def command_line(args):
            if time.monotonic() > stop:
                return
            counts["cli"] += 1
            code, err = run_command(args)
            if code not in (0, 1, 2) or "Traceback" in err:
                failures.append(f"{' '.join(args)} -> exit {code}: {err.strip().splitlines()[-1:] }")

        start = time.monotonic()
        for part, share in ((readers, 0.35), (folders, 0.15), (command_line, 0.5)):
            stop = time.monotonic() + share * seconds
            part()
            while time.monotonic() < stop and seed is None:
                part()
        elapsed = time.monotonic() - start
    return {"seconds": elapsed, **counts, "failures": failures}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=150.0, help="time budget (default 150 s)")
    args = parser.parse_args()
    import cv2

    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # OpenCV's own warnings about broken files would bury the summary
    result = fuzz(args.seconds)
    print(f"fuzz: {result['readers']} reader calls, {result['load_pair']} generated folders, {result['cli']} command "
          f"lines in {result['seconds']:.0f} s; {len(result['failures'])} failures")
    for failure in result["failures"]:
        print("  FAIL", failure)
    return 1 if result["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
