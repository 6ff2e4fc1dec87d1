"""Batch throughput: pairs per second with 1 and 2 local workers and through a local Dask cluster.

Run: ``python benchmarks/bench_batch.py [--pairs N] [--size WxH] [--task detect|disparity]``
(Dask part needs the ``[dask]`` extra).

Writes ``--pairs`` rendered pairs (random synthetic scenes, ``<name>_left.png`` /
``<name>_right.png``) into a temporary folder, then runs :func:`stereo_obstacles.batch.run_batch`
on them into a fresh output folder per configuration: in this process (1 worker), in a pool
of 2 spawned processes, and on a local Dask cluster of 2 single-threaded worker processes
(started before the clock, as an existing cluster would be). Times are wall clock from the
first submitted pair to the last outcome, so worker start-up (imports, numba cache loads)
counts for the process pool.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from stereo_obstacles.batch import BatchJob, find_pairs, run_batch
from stereo_obstacles.matching import warm_up
from stereo_obstacles.pipeline import DetectionConfig
from stereo_obstacles.synthetic import random_scene, render_pair


def _jobs(input_dir: Path, out_dir: Path, task: str) -> list[BatchJob]:
    return [BatchJob(p, str(out_dir / p.name), task, DetectionConfig()) for p in find_pairs(input_dir)]


def _timed(label: str, jobs: list[BatchJob], **kwargs) -> None:
    start = time.perf_counter()
    outcomes = run_batch(jobs, **kwargs)
    seconds = time.perf_counter() - start
    done = sum(o.status == "done" for o in outcomes)
    print(f"{label:<34} {done:3d} pairs in {seconds:6.1f} s  {done / seconds:5.2f} pairs/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=16)
    parser.add_argument("--size", default="640x480")
    parser.add_argument("--task", choices=("detect", "disparity"), default="detect")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
          f"{sys.version.split()[0]}, NumPy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    warm_up()
    root = Path(tempfile.mkdtemp(prefix="bench_batch_"))
    try:
        inputs = root / "in"
        inputs.mkdir()
        for k in range(args.pairs):
            pair = render_pair(random_scene(k, width_px=width, height_px=height))
            cv2.imwrite(str(inputs / f"{k:04d}_left.png"), cv2.cvtColor(pair.left, cv2.COLOR_RGB2BGR))
            cv2.imwrite(str(inputs / f"{k:04d}_right.png"), cv2.cvtColor(pair.right, cv2.COLOR_RGB2BGR))
        print(f"{args.pairs} pairs of {width}x{height}, task {args.task}")
        _timed("local, 1 worker (in process)", _jobs(inputs, root / "out1", args.task), workers=1)
        _timed("local, 2 worker processes", _jobs(inputs, root / "out2", args.task), workers=2)
        try:
            from distributed import LocalCluster
        except ImportError:
            print("Dask: skipped (pip install 'stereo-obstacles[dask]')")
            return
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            _timed("Dask LocalCluster, 2 processes", _jobs(inputs, root / "out3", args.task),
                   scheduler=cluster.scheduler_address)
            _timed("Dask, again (workers warm)", _jobs(inputs, root / "out4", args.task),
                   scheduler=cluster.scheduler_address)
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
