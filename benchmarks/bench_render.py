"""Time the synthetic renderer: a 640x480 stereo pair of the default scene with ground truth.

Run: ``python benchmarks/bench_render.py [--runs N] [--size WxH]``. Prints the machine, the
first call (which also builds the procedural textures, once per process) and the median of
the following runs, for 1 and 2x2 rays per pixel, and for a random scene.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time

import numpy as np

from stereo_obstacles.synthetic import RenderOptions, default_scene, random_scene, render_pair


def _time(fn, runs: int) -> tuple[float, float]:
    start = time.perf_counter()
    fn()
    first = time.perf_counter() - start
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return first, statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--size", default="640x480")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {sys.version.split()[0]}, NumPy {np.__version__}")
    scene = default_scene(width, height)
    cases = [
        ("default scene, 1 ray/pixel", lambda: render_pair(scene)),
        ("default scene, 2x2 rays/pixel", lambda: render_pair(scene, RenderOptions(supersample=2))),
        ("random scene 7, 1 ray/pixel", lambda: render_pair(random_scene(7, width_px=width, height_px=height))),
    ]
    for name, fn in cases:
        first, median = _time(fn, args.runs)
        print(f"{width}x{height} pair, {name}: first call {first:.3f} s, median of {args.runs} {median:.3f} s")


if __name__ == "__main__":
    main()
