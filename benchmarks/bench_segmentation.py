"""Phase 1 speed: segmentation of a 640x480 image after warm-up, against an OpenCV floor.

Measures, on this machine:

* the first call in a fresh process (numba loads its cached kernels or compiles them);
* the steady-state median of ``--repeat`` calls of :func:`stereo_obstacles.segmentation.segment`
  on the synthetic default scene at 640x480 and on a KITTI frame (1242x375) when the shared
  data is present, by colour alone and with the right image (the stereo ground check, run
  beside the colour labels on the second core), the two calls alternating;
* :func:`stereo_obstacles.colour.rgb_to_hsi` of the whole image (not part of ``segment``,
  which converts only the reference area and tests colours without an arctangent);
* a floor: OpenCV ``cvtColor(RGB2HSV)`` plus ``medianBlur(7)`` of the hue plane, the least
  any HSV-and-median segmentation must do; times are also given as ratios to it.

Usage: ``python benchmarks/bench_segmentation.py [--repeat N] [--out FILE.md]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from stereo_obstacles.colour import rgb_to_hsi
from stereo_obstacles.segmentation import segment
from stereo_obstacles.synthetic import default_scene, render_pair

SHARED = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA",
                             Path(__file__).resolve().parents[1].parent / "shared" / "data"))


def _median_ms(function, repeat: int) -> float:
    return _interleaved_medians_ms([function], repeat)[0]


def _interleaved_medians_ms(functions: list, repeat: int) -> list[float]:
    """Median wall time of each function over ``repeat`` rounds that call them in turn, ms."""
    times: list[list[float]] = [[] for _ in functions]
    for _ in range(repeat):
        for function, record in zip(functions, times):
            start = time.perf_counter()
            function()
            record.append(time.perf_counter() - start)
    return [1000.0 * statistics.median(record) for record in times]


def _opencv_floor(rgb: np.ndarray) -> None:
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    cv2.medianBlur(np.ascontiguousarray(hsv[..., 0]), 7)


def _first_call_ms() -> float:
    code = ("import time, numpy as np; from stereo_obstacles.segmentation import segment; "
            "rgb = np.full((480, 640, 3), (90, 140, 60), np.uint8); t = time.perf_counter(); "
            "segment(rgb); print(1000 * (time.perf_counter() - t))")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30, help="timed calls per figure (default 30)")
    parser.add_argument("--out", default=None, help="also write the Markdown report here")
    args = parser.parse_args()
    # The KITTI frame's varied reference area warns on every call; timing wants a quiet terminal.
    logging.getLogger("stereo_obstacles").setLevel(logging.ERROR)

    pair = render_pair(default_scene(640, 480))
    images = {"synthetic default scene 640x480": (pair.left, pair.right)}
    kitti = [SHARED / "kitti2015_000045" / f"000045_10_{side}.png" for side in ("left", "right")]
    if all(path.is_file() for path in kitti):
        images["KITTI 000045 1242x375"] = tuple(cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2RGB)
                                                for path in kitti)
    first = _first_call_ms()
    lines = [
        "## Phase 1 segmentation speed", "",
        f"Machine: {platform.machine()}, {os.cpu_count()} logical CPUs, Python "
        f"{platform.python_version()}, OpenCV {cv2.__version__}, load average "
        f"{', '.join(f'{v:.2f}' for v in os.getloadavg())} at start. Median of {args.repeat} calls "
        "after one warm-up call.", "",
        f"First call in a fresh process (numba kernels loaded from the on-disk cache, or compiled "
        f"when the cache is empty): {first:.0f} ms.", "",
        "| image | segment (colour) | segment with the right image | rgb_to_hsi (whole image) | "
        "OpenCV floor: HSV + 7x7 median of hue | colour / floor |",
        "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for name, (rgb, right) in images.items():
        segment(rgb)
        segment(rgb, right=right)
        rgb_to_hsi(rgb)
        seg, stereo = _interleaved_medians_ms([lambda rgb=rgb: segment(rgb),
                                               lambda rgb=rgb, right=right: segment(rgb, right=right)], args.repeat)
        hsi = _median_ms(lambda rgb=rgb: rgb_to_hsi(rgb), args.repeat)
        floor = _median_ms(lambda rgb=rgb: _opencv_floor(rgb), args.repeat)
        lines.append(f"| {name} | {seg:.2f} ms | {stereo:.2f} ms | {hsi:.2f} ms | {floor:.2f} ms | "
                     f"{seg / floor:.1f} |")
    report = "\n".join(lines) + "\n"
    print(report)
    if args.out:
        Path(args.out).write_text(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
