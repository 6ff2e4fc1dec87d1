"""Whole-pipeline speed: seconds per stage and pairs per second on a 640x480 colour pair.

Runs ``stereo_obstacles.pipeline.detect`` on the built-in synthetic scene (and, when present, on
the shared KITTI frame 000005 and on the central 640 columns of three KITTI frames, real road
scenes near the target's size: ``REAL_CROP_FRAMES``) after a warm-up, takes the median of ``--repeat`` runs per stage,
reports the first call (numba compilation, cached on disk after the first process) apart, and
puts OpenCV StereoSGBM on the same pair in the same run beside it for scale. Prints a Markdown
table; ``--json FILE`` writes the raw figures.

    python benchmarks/bench_pipeline.py [--repeat 9] [--json pipeline.json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from stereo_obstacles.calibration import StereoCalibration

HERE = Path(__file__).resolve()
SHARED_DATA = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA", HERE.parents[1].parent / "shared" / "data"))


@contextlib.contextmanager
def _warnings_held_back():
    """The package's warnings are left out while the block runs (the timed runs repeat the first
    call's, one per run: the KITTI frame's reference-area warning came 17 times)."""
    package = logging.getLogger("stereo_obstacles")
    level = package.level
    package.setLevel(logging.ERROR)
    try:
        yield
    finally:
        package.setLevel(level)


REAL_CROP_FRAMES = ("000005", "000045", "000046")
"""KITTI 2015 frames timed on their central 640 columns: real road scenes at about the 640 x 480 of
the speed target (the synthetic scene holds six objects; a road scene dozens). 000045 and 000046
ship no calibration: 000005's is taken for them (the same rig by their README, not verified). It
sets every test in metres, so their obstacles may differ from what their own calibration would
give; their timings are of a real scene all the same."""

CROP_WIDTH_PX = 640


def _central_columns(left: np.ndarray, right: np.ndarray, calibration: StereoCalibration
                     ) -> tuple[np.ndarray, np.ndarray, StereoCalibration]:
    """The central ``CROP_WIDTH_PX`` columns of an ``(H, W, 3)`` pair, ``(H, CROP_WIDTH_PX, 3)``
    each, with ``calibration`` moved to them (its principal point shifted left by the columns
    cut off)."""
    first = (left.shape[1] - CROP_WIDTH_PX) // 2
    columns = slice(first, first + CROP_WIDTH_PX)
    return (left[:, columns].copy(), right[:, columns].copy(),
            replace(calibration, cx_px=calibration.cx_px - first, width_px=CROP_WIDTH_PX))


def _time_pipeline(left, right, calibration, config, repeat: int) -> dict:
    from stereo_obstacles.pipeline import detect

    started = time.perf_counter()
    detect(left, right, calibration, config=config)
    first = time.perf_counter() - started
    with _warnings_held_back():
        runs = [detect(left, right, calibration, config=config).timings_s for _ in range(repeat)]
    medians = {stage: statistics.median(r[stage] for r in runs) for stage in runs[0]}
    return {"first_call_s": first, "median_s": medians, "pairs_per_second": 1.0 / medians["total"]}


def _time_sgbm(left, right, max_disparity: int, repeat: int) -> float:
    from stereo_obstacles.peers import sgbm_disparity

    sgbm_disparity(left, right, max_disparity=max_disparity)
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        sgbm_disparity(left, right, max_disparity=max_disparity)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=9)
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args(argv)

    from stereo_obstacles.evaluation import machine_info
    from stereo_obstacles.pipeline import DetectionConfig, warm_up
    from stereo_obstacles.synthetic import default_scene, render_pair

    compile_s = warm_up()
    cases = {}
    pair = render_pair(default_scene(640, 480))
    cases["synthetic default scene 640x480"] = (pair.left, pair.right, pair.calibration, 64, DetectionConfig())
    cases["the same, matching scale 1 (growth at full size)"] = (pair.left, pair.right, pair.calibration, 64,
                                                                 DetectionConfig(matching_scale=1.0))
    kitti = SHARED_DATA / "kitti2015_000005"
    if kitti.is_dir():
        from stereo_obstacles.datasets import load_pair

        k = load_pair(kitti)
        cases["KITTI 2015 000005 1242x375"] = (k.left, k.right, k.calibration, 128, DetectionConfig())
        for frame in REAL_CROP_FRAMES:
            folder = SHARED_DATA / f"kitti2015_{frame}"
            if not folder.is_dir():
                print(f"Skipped the crop of KITTI {frame}: {folder} not found")
                continue
            whole = k if frame == "000005" else load_pair(folder)
            crop = _central_columns(whole.left, whole.right, k.calibration)
            cases[f"KITTI 2015 {frame}, central 640x375"] = (*crop, 128, DetectionConfig())
    else:
        print(f"Skipped the KITTI pairs: {kitti} not found (the crops need its calibration)")
    results = {"machine": machine_info(), "warm_up_s": compile_s, "cases": {}}
    print(f"Machine: {results['machine']['cpu']}, {results['machine']['logical_cpus']} logical CPUs; "
          f"median of {args.repeat} runs after a warm-up; warm_up() {compile_s:.2f} s\n")
    print("| pair | first call [s] | segmentation [ms] | rectification check [ms] | matching [ms] | obstacles [ms] "
          "| total [ms] | pairs/s | SGBM alone [ms] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (left, right, calibration, max_disparity, config) in cases.items():
        figures = _time_pipeline(left, right, calibration, config, args.repeat)
        figures["sgbm_s"] = _time_sgbm(left, right, max_disparity, args.repeat)
        results["cases"][name] = figures
        m = {k: 1000 * v for k, v in figures["median_s"].items()}
        print(f"| {name} | {figures['first_call_s']:.2f} | {m['segmentation']:.0f} | "
              f"{m.get('rectification_check', 0):.0f} | {m['matching']:.0f} | {m['obstacles']:.0f} | "
              f"{m['total']:.0f} | {figures['pairs_per_second']:.1f} | {1000 * figures['sgbm_s']:.0f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
