"""Video speed and accuracy: temporal seeds against edge seeds on a synthetic forward walk; memory over a long run.

Run: ``python benchmarks/bench_video.py [--frames N] [--size WxH] [--memory-frames M]
[--memory-size WxH] [--matching-scale S] [--in-flight N] [--json FILE]``.

1. Renders ``--frames`` pairs of the default scene with the rig walking forward 0.05 m per
   frame (1.4 m/s at ~30 fps), with exact ground truth.
2. Runs the whole per-frame pipeline (:func:`stereo_obstacles.stream_detection.detect_stream`:
   detection, tracking; ``--in-flight`` frames at once) over the frames with edge seeds, with
   temporal seeds, with temporal seeds moved by the known forward motion, and with temporal
   seeds and 1, 2 or 3 refined frames after each grown one (``refine_frames``; 1 is what the
   ``video`` command does by default), twice each in alternation. Reports per mode the frames delivered per second of wall time after two
   warm-up frames (median of the two runs), the median over those frames of one frame's
   detection time (latency) and of its matching stage, and per frame the bad-1 rate
   (|d - gt| > 1 px over matched non-occluded pixels with ground truth) and density (matched
   share of those pixels). Freed memory is kept for reuse, as the ``video`` command does
   (:mod:`stereo_obstacles.allocator`).
3. Memory: ``--memory-frames`` frames (the rendered walk cycled, timestamps increasing) of
   the ``video`` command's loop — detection, tracking, JSON record, annotated frame — with
   temporal seeds; RSS (``/proc/self/statm``) at frame 10 and at the end.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import numpy as np

from stereo_obstacles.allocator import keep_freed_memory
from stereo_obstacles.matching import warm_up
from stereo_obstacles.pipeline import DetectionConfig
from stereo_obstacles.stream_detection import IN_FLIGHT, annotate_frame, detect_stream, frame_record
from stereo_obstacles.streams import StereoFrame
from stereo_obstacles.synthetic import default_scene, render_sequence
from stereo_obstacles.temporal_seeds import TemporalSeedParameters

SPEED_M_PER_FRAME = 0.05
FPS = 30.0
WARM_UP_FRAMES = 2


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def _size(text: str) -> tuple[int, int]:
    w, h = (int(v) for v in text.lower().split("x"))
    return w, h


def _frames(pairs, n: int):
    for k in range(n):
        pair = pairs[k % len(pairs)]
        yield StereoFrame(k, k / FPS, pair.left, pair.right, f"frame_{k:06d}")


def _accuracy(disparity: np.ndarray, pair) -> tuple[float, float]:
    known = np.isfinite(pair.disparity) & pair.nonocc
    matched = known & np.isfinite(disparity)
    bad = float(np.mean(np.abs(disparity[matched] - pair.disparity[matched]) > 1.0)) if matched.any() else float("nan")
    return bad, float(matched.sum() / known.sum())


def _run_mode(pairs, calibration, temporal, config, in_flight) -> list[dict]:
    rows = []
    disparities = []
    for detection in detect_stream(_frames(pairs, len(pairs)), calibration, config=config, temporal=temporal,
                                   in_flight=in_flight):
        stats = detection.result.match_stats
        rows.append({"seeds": detection.seeds, "done_s": time.perf_counter(),
                     "total_s": detection.result.timings_s["total"],
                     "matching_s": detection.result.timings_s["matching"], "stages_s": dict(detection.result.timings_s),
                     "seed_stage_s": stats.seeds_seconds, "growth_s": stats.growth_seconds})
        disparities.append(detection.result.disparity)
    for row, disparity, pair in zip(rows, disparities, pairs, strict=True):  # after the timed run
        row["bad1"], row["density"] = _accuracy(disparity, pair)
    return rows


def _frames_per_second(run: list[dict]) -> float:
    """Frames delivered per second of wall time after the warm-up frames."""
    return (len(run) - WARM_UP_FRAMES) / (run[-1]["done_s"] - run[WARM_UP_FRAMES - 1]["done_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--size", default="640x480")
    parser.add_argument("--memory-frames", type=int, default=1000)
    parser.add_argument("--memory-size", default="320x240")
    parser.add_argument("--matching-scale", type=float, default=None,
                        help="DetectionConfig.matching_scale of every run (default: the pipeline's)")
    parser.add_argument("--in-flight", type=int, default=IN_FLIGHT,
                        help=f"frames detected at once (default {IN_FLIGHT}, as the video command)")
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args()
    width, height = _size(args.size)
    config = DetectionConfig() if args.matching_scale is None else DetectionConfig(matching_scale=args.matching_scale)
    keep_freed_memory()  # as the video command does
    machine = (f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, Python "
               f"{sys.version.split()[0]}, NumPy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    print(f"machine: {machine}")
    warm_up()
    start = time.perf_counter()
    pairs = list(render_sequence(default_scene(width, height), args.frames, SPEED_M_PER_FRAME))
    print(f"rendered {len(pairs)} {width}x{height} frames in {time.perf_counter() - start:.0f} s")
    calibration = pairs[0].calibration
    modes = {"edge": None, "temporal": TemporalSeedParameters(refine_frames=0),
             "temporal+motion": TemporalSeedParameters(forward_m_per_frame=SPEED_M_PER_FRAME, refine_frames=0),
             **{f"refine {n}" + (" (default)" if n == TemporalSeedParameters().refine_frames else ""):
                TemporalSeedParameters(refine_frames=n) for n in (1, 2, 3)}}
    results: dict[str, list[list[dict]]] = {name: [] for name in modes}
    for _ in range(2):
        for name, temporal in modes.items():
            results[name].append(_run_mode(pairs, calibration, temporal, config, args.in_flight))
    summary = {"machine": machine, "size": [width, height], "matching_scale": config.matching_scale,
               "in_flight": args.in_flight, "frames": len(pairs), "modes": {}}
    print(f"matching scale {config.matching_scale:g}, {args.in_flight} frame(s) in flight")
    print(f"\n{'seeds':<20} {'fps':>6} {'latency ms':>11} {'match ms':>9} {'bad-1 %':>8} {'density %':>10}")
    for name, runs in results.items():
        timed = [row for run in runs for row in run[WARM_UP_FRAMES:]]
        total = statistics.median(r["total_s"] for r in timed)
        matching = statistics.median(r["matching_s"] for r in timed)
        fps = statistics.median(_frames_per_second(run) for run in runs)
        bad = statistics.median(r["bad1"] for r in runs[0])
        density = statistics.median(r["density"] for r in runs[0])
        summary["modes"][name] = {"fps": fps, "frame_s": total, "matching_s": matching,
                                  "bad1_median": bad, "density_median": density,
                                  "per_frame": runs[0]}
        print(f"{name:<20} {fps:6.2f} {1e3 * total:11.0f} {1e3 * matching:9.0f} {100 * bad:8.2f} "
              f"{100 * density:10.1f}")
    print("\nmedian seconds per stage (frames after warm-up):")
    for name, runs in results.items():
        timed = [row for run in runs for row in run[WARM_UP_FRAMES:]]
        stages = {key: statistics.median(r["stages_s"][key] for r in timed) for key in timed[0]["stages_s"]}
        stages["  of matching: seeds"] = statistics.median(r["seed_stage_s"] for r in timed)
        stages["  of matching: growth"] = statistics.median(r["growth_s"] for r in timed)
        summary["modes"][name]["stages_s"] = stages
        print(f"  {name:<20} " + ", ".join(f"{key.strip()} {1e3 * v:.0f} ms" for key, v in stages.items()))
    edge = summary["modes"]["edge"]
    for name in list(modes)[1:]:
        mode = summary["modes"][name]
        print(f"speed-up of {name} over edge seeds: frames per second x{mode['fps'] / edge['fps']:.2f}, "
              f"matching x{edge['matching_s'] / mode['matching_s']:.2f}")
    print("\nper frame (first run): seeds, bad-1 %, density % for " + " | ".join(modes))
    for k in range(len(pairs)):
        cells = [f"{results[n][0][k]['seeds'][:4]} {100 * results[n][0][k]['bad1']:.2f} "
                 f"{100 * results[n][0][k]['density']:.1f}" for n in modes]
        print(f"  frame {k:3d}: " + " | ".join(cells))

    if args.memory_frames:
        mw, mh = _size(args.memory_size)
        walk = list(render_sequence(default_scene(mw, mh), 12, SPEED_M_PER_FRAME))
        rss = {}
        start = time.perf_counter()
        for detection in detect_stream(_frames(walk, args.memory_frames), walk[0].calibration, config=config,
                                       temporal=TemporalSeedParameters(), in_flight=args.in_flight):
            json.dumps(frame_record(detection))
            annotate_frame(detection)
            k = detection.frame.index + 1
            if k in (10, 100, args.memory_frames // 2, args.memory_frames):
                rss[k] = _rss_mb()
        seconds = time.perf_counter() - start
        summary["memory"] = {"size": [mw, mh], "frames": args.memory_frames, "rss_mb": rss, "seconds": seconds}
        print(f"\nmemory over {args.memory_frames} {mw}x{mh} frames ({seconds:.0f} s, "
              f"{args.memory_frames / seconds:.1f} fps): " + ", ".join(f"RSS at frame {k} {v:.0f} MB"
                                                                     for k, v in rss.items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=1)


if __name__ == "__main__":
    main()
