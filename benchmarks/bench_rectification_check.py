"""The rectification check of ``detect`` against the function's full settings: verdicts and time.

``stereo_obstacles.pipeline.detect`` checks every pair with ORB at most
``RECTIFICATION_CHECK_FEATURES`` keypoints per image and ``RECTIFICATION_CHECK_ORB_LEVELS``
pyramid levels; ``check_rectification``'s defaults are 4000 keypoints and 8 levels. This runs
both on pairs whose answer is known and prints, per pair, the verdict, the median vertical
offset, the consistent matches and the time (median of ``--repeat`` calls) of each:

* synthetic scenes (seeds 0..``--scenes``-1, 640x480, sensor noise 2) with a vertical offset of
  0, 1.25, 1.5 and 3 px between the cameras (rectified only at 0: the check's limit is a median
  offset of 1 px, and 1.25 px shows how it reads offsets just above it);
* the shared Middlebury 2003 and KITTI 2015 pairs (rectified) when ``../shared/data`` is there,
  and each with its right image moved down 2 rows (not rectified).

    python benchmarks/bench_rectification_check.py [--scenes 6] [--repeat 5]
"""

from __future__ import annotations

import argparse
import logging
import os
import platform
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

SHARED_DATA = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA",
                                  Path(__file__).resolve().parents[1].parent / "shared" / "data"))
REAL_PAIRS = ("middlebury2003_teddy", "middlebury2003_cones", "kitti2015_000005", "kitti2015_000045")


def _cases(n_scenes: int):
    """``(name, left, right, rectified)`` of every test pair."""
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.synthetic import RenderOptions, RightCameraError, random_scene, render_pair

    for seed in range(n_scenes):
        for offset in (0.0, 1.25, 1.5, 3.0):
            options = RenderOptions(noise_sigma=2.0, right_error=RightCameraError(vertical_offset_px=offset))
            pair = render_pair(random_scene(seed, width_px=640, height_px=480), options)
            yield f"synthetic {seed}, offset {offset} px", pair.left, pair.right, offset == 0.0
    for name in REAL_PAIRS:
        folder = SHARED_DATA / name
        if not folder.is_dir():
            print(f"({name} skipped: {folder} not found)")
            continue
        pair = load_pair(folder)
        yield name, pair.left, pair.right, True
        yield f"{name}, right 2 rows down", pair.left, np.roll(pair.right, 2, axis=0), False


def _run(left, right, repeat: int, **settings):
    from stereo_obstacles.rectification_check import check_rectification

    times, check = [], None
    for _ in range(repeat):
        started = time.perf_counter()
        check = check_rectification(left, right, method="orb", warn=False, **settings)
        times.append(time.perf_counter() - started)
    return check, 1000.0 * statistics.median(times)


def main() -> None:
    from stereo_obstacles.pipeline import (RECTIFICATION_CHECK_FEATURES, RECTIFICATION_CHECK_ORB_LEVELS,
                                           RECTIFICATION_CHECK_SIDE_PX)

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=6)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    print(f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, Python "
          f"{platform.python_version()}, OpenCV {cv2.__version__}, load average {os.getloadavg()[0]:.2f}; "
          f"median of {args.repeat} calls per pair.\n")
    settings = {"full (4000 keypoints, 8 levels)": {"max_side_px": RECTIFICATION_CHECK_SIDE_PX},
                f"detect ({RECTIFICATION_CHECK_FEATURES} keypoints, {RECTIFICATION_CHECK_ORB_LEVELS} levels)": {
                    "max_side_px": RECTIFICATION_CHECK_SIDE_PX, "max_features": RECTIFICATION_CHECK_FEATURES,
                    "orb_levels": RECTIFICATION_CHECK_ORB_LEVELS}}
    print("| pair | truth | " + " | ".join(f"{name}: verdict / median offset px / matches / ms" for name in settings)
          + " |")
    print("|---|---|" + "---|" * len(settings))
    wrong = {name: 0 for name in settings}
    for case, left, right, rectified in _cases(args.scenes):
        cells = []
        for name, kwargs in settings.items():
            check, ms = _run(left, right, args.repeat, **kwargs)
            wrong[name] += check.rectified is not rectified
            cells.append(f"{check.rectified} / {check.offsets.median_px:.2f} / {check.offsets.n_points} / {ms:.1f}")
        print(f"| {case} | {rectified} | " + " | ".join(cells) + " |")
    print()
    print("wrong verdicts: " + ", ".join(f"{name} {n}" for name, n in wrong.items()))


if __name__ == "__main__":
    main()
