"""Benchmark of the stereo matchers: accuracy and speed against OpenCV, seed ablation, scaling.

Run from the repository root::

    python benchmarks/bench_matching.py            # writes docs/benchmarks.md
    python benchmarks/bench_matching.py --quick    # fewer runs, no Aloe, no 2 MP scene

Sections (each skipped with a stated reason when what it needs is absent):

1. **Comparison** on every Middlebury pair in ``../shared/data`` (Tsukuba, Venus, Teddy, Cones,
   Aloe): our GCS matcher, OpenCV SGBM and BM, exhaustive NCC WTA, through
   :func:`stereo_obstacles.evaluation.evaluate_pair`; ratios to SGBM of time and bad-1.
2. **Seed ablation**: GCS with Sobel (the default), Canny and random seeds: time, seeds, visited
   disparity-space points, density, bad-1.
3. **Scaling**: the built-in synthetic scene (``stereo_obstacles.synthetic``) at 0.25, 0.5, 1
   and 2 megapixels: GCS and SGBM time per megapixel.
4. **Extensions**: GCS with one row band (the published single growth) and two (the default,
   parallel threads), with and without the shifted-window check, and the coarse-to-fine
   matching of the obstacle pipeline, against SGBM, interleaved in one loop: match time, whole
   call time, bad-1, density.
5. **Compile cost**: GCS warm-up in a fresh process with an empty numba cache (compilation)
   and again with the cache filled (cache loading), kept apart from steady-state times.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from stereo_obstacles.datasets import StereoPair, load_pair
from stereo_obstacles.disparity_metrics import evaluate_disparity
from stereo_obstacles.evaluation import (METHODS, available_methods, evaluate_pair,
                                         machine_info, resolve_methods)
from stereo_obstacles.pipeline import MatchingOptions, pipeline_match_kwargs
from stereo_obstacles.seeds import DEFAULT_SEEDS

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA", REPO.parent / "shared" / "data"))
MIDDLEBURY = ("middlebury2001_tsukuba", "middlebury2001_venus", "middlebury2003_teddy",
              "middlebury2003_cones", "opencv_aloe")
TARGET_PAIRS = ("middlebury2003_teddy", "middlebury2003_cones")
SEED_KINDS = ("sobel", "canny", "random")
EXTENSIONS = (("published method (1 band, tau 0.6, mu 0.1, K 10, no check, no speckle removal)",
               {"bands": 1, "tau": 0.6, "mu": 0.1, "max_candidates": 10, "shifted_windows": False,
                "speckle_size": 0}),
              ("defaults with 1 band", {"bands": 1}),
              ("defaults without the shifted-window check", {"shifted_windows": False}),
              ("defaults without speckle removal", {"speckle_size": 0}),
              ("defaults (2 bands, check, speckle removal)", {}),
              ("coarse to fine (scale 0.5, the pipeline's settings: no speckle removal)",
               {"matching_scale": 0.5, **pipeline_match_kwargs(MatchingOptions())}))
"""Settings of the extensions section: ``match`` options, or ``matching_scale`` for
:func:`stereo_obstacles.scaled_matching.match_at_scale` (growth on a half-size copy, refined at
full size), whose disparity has no single ``match_seconds``: its rows report the whole call."""
SCALING_SIZES = ((576, 432), (816, 612), (1152, 864), (1632, 1224))  # 0.25, 0.5, 1, 2 MP


def _fmt(value: float | None, digits: int = 2) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) \
        else f"{value:.{digits}f}"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _present_pairs(data: Path, names: tuple[str, ...]):
    """The pairs of ``names`` found under ``data``, loaded, in order; absent ones are said and skipped."""
    for name in names:
        folder = data / name
        if not folder.is_dir():
            print(f"skip {name}: not in {data}", file=sys.stderr)
            continue
        yield load_pair(folder)


# --- 1. comparison ---------------------------------------------------------------------------

def comparison(data: Path, names: tuple[str, ...], repeat: int) -> tuple[str, list[dict]]:
    methods = resolve_methods(None)
    results = []
    for pair in _present_pairs(data, names):
        print(f"comparison: {pair.name}", file=sys.stderr)
        results.extend(evaluate_pair(pair, methods, repeat=repeat))
    rows, ratio_rows, records = [], [], []
    sgbm = {r.pair: r for r in results if r.method == "sgbm"}
    for r in results:
        m = r.metrics
        rows.append([r.pair, r.method, _fmt(m.density_pct, 1), _fmt(m.bad1_matched_pct),
                     _fmt(m.bad2_matched_pct), _fmt(m.bad1_all_pct), _fmt(m.epe_px),
                     _fmt(r.median_seconds * 1000, 1), _fmt(r.first_call_seconds * 1000, 1)])
        ref = sgbm.get(r.pair)
        record = r.to_dict()
        if ref is not None and r.method != "sgbm":
            time_ratio = r.median_seconds / ref.median_seconds
            bad_ratio = m.bad1_matched_pct / ref.metrics.bad1_matched_pct
            record.update(time_ratio_to_sgbm=time_ratio, bad1_ratio_to_sgbm=bad_ratio)
            ratio_rows.append([r.pair, r.method, _fmt(time_ratio), _fmt(bad_ratio),
                               _fmt(m.density_pct, 1), _fmt(ref.metrics.density_pct, 1)])
        records.append(record)
    text = "\n\n".join([
        "Accuracy over non-occluded pixels with ground truth (Middlebury `nonocc` masks; Aloe "
        "has no mask, so all pixels with ground truth). bad-N: |d − gt| > N px over matched "
        "pixels; bad-1u: unmatched pixels counted as bad. Times: median of "
        f"{repeat} calls after a first call (first call shown separately). Every method gets "
        "the disparity range of the ground truth.",
        _table(["pair", "method", "density %", "bad-1 %", "bad-2 %", "bad-1u %", "EPE px",
                "median ms", "first call ms"], rows),
        "Ratios to OpenCV SGBM in the same run (time: median; bad-1: over matched "
        "non-occluded pixels; below 1 is better):",
        _table(["pair", "method", "time / SGBM", "bad-1 / SGBM", "density %", "SGBM density %"],
               ratio_rows),
    ])
    return text, records


# --- 2. seed ablation ------------------------------------------------------------------------

def seed_ablation(data: Path, names: tuple[str, ...], repeat: int) -> tuple[str, list[dict]]:
    from stereo_obstacles.matching import match

    rows, records = [], []
    for pair in _present_pairs(data, names):
        max_d = math.ceil(pair.max_gt_disparity)
        for kind in SEED_KINDS:  # first calls, not in the medians
            match(pair.left, pair.right, seeds=kind, max_disparity=max_d)
        walls: dict[str, list[float]] = {kind: [] for kind in SEED_KINDS}
        runs: dict[str, list] = {kind: [] for kind in SEED_KINDS}
        for _ in range(repeat):  # interleaved, so that load from other processes hits all alike
            for kind in SEED_KINDS:
                t0 = time.perf_counter()
                result = match(pair.left, pair.right, seeds=kind, max_disparity=max_d)
                walls[kind].append(time.perf_counter() - t0)
                runs[kind].append(result)
        for kind in SEED_KINDS:
            result = runs[kind][-1]
            stats = result.stats
            m = evaluate_disparity(result.disparity, pair.gt_disparity, mask=pair.nonocc)
            record = {"pair": pair.name, "seeds": kind,
                      "median_seconds": statistics.median(walls[kind]),
                      "median_match_seconds": statistics.median(
                          r.stats.match_seconds for r in runs[kind]),
                      "n_seeds": stats.n_seeds, "n_visited": stats.n_visited,
                      "visited_fraction_range": stats.visited_fraction_range,
                      "metrics": m.to_dict()}
            records.append(record)
            rows.append([pair.name, kind, _fmt(record["median_seconds"] * 1000, 1),
                         _fmt(record["median_match_seconds"] * 1000, 1), str(stats.n_seeds),
                         f"{stats.n_visited:,}", _fmt(100 * stats.visited_fraction_range, 2),
                         _fmt(m.density_pct, 1), _fmt(m.bad1_matched_pct)])
    text = "\n\n".join([
        f"GCS with each seed source (median of {repeat} calls after a first call, the seed kinds "
        "interleaved; `match ms` is "
        "seeds + growth + final matching + shifted-window check + speckle removal as reported by the matcher, `total` the whole call). "
        "Visited: distinct disparity-space points whose similarity was computed; % of range: "
        "as a share of an exhaustive search over the same disparity range.",
        _table(["pair", "seeds", "total ms", "match ms", "seeds used", "visited",
                "% of range", "density %", "bad-1 %"], rows),
    ])
    return text, records


# --- extensions ------------------------------------------------------------------------------

def _run_setting(pair, max_d: int, options: dict) -> tuple[np.ndarray, float | None, float]:
    """Disparity, ``match_seconds`` (None for coarse to fine) and wall seconds of one call."""
    from stereo_obstacles.matching import match
    from stereo_obstacles.scaled_matching import match_at_scale

    options = dict(options)
    scale = options.pop("matching_scale", None)
    t0 = time.perf_counter()
    if scale is None:
        result = match(pair.left, pair.right, max_disparity=max_d, **options)
        return result.disparity, result.stats.match_seconds, time.perf_counter() - t0
    disparity, _ = match_at_scale(pair.left, pair.right, scale, max_disparity=max_d, **options)
    return disparity, None, time.perf_counter() - t0


def extensions(data: Path, names: tuple[str, ...], repeat: int) -> tuple[str, list[dict]]:
    from stereo_obstacles.peers import sgbm_disparity

    rows, records = [], []
    for pair in _present_pairs(data, names):
        max_d = math.ceil(pair.max_gt_disparity)
        for _, options in EXTENSIONS:  # first calls, not in the medians
            _run_setting(pair, max_d, options)
        sgbm_walls: list[float] = []
        runs: dict[str, list] = {label: [] for label, _ in EXTENSIONS}
        for _ in range(repeat):  # interleaved with SGBM, so that load from other processes hits all alike
            t0 = time.perf_counter()
            sgbm = sgbm_disparity(pair.left, pair.right, max_disparity=max_d)
            sgbm_walls.append(time.perf_counter() - t0)
            for label, options in EXTENSIONS:
                runs[label].append(_run_setting(pair, max_d, options))
        sgbm_seconds = statistics.median(sgbm_walls)
        sgbm_bad1 = evaluate_disparity(sgbm, pair.gt_disparity, mask=pair.nonocc).bad1_matched_pct
        for label, _ in EXTENSIONS:
            m = evaluate_disparity(runs[label][-1][0], pair.gt_disparity, mask=pair.nonocc)
            match_times = [r[1] for r in runs[label] if r[1] is not None]
            match_seconds = statistics.median(match_times) if match_times else None
            call_seconds = statistics.median(r[2] for r in runs[label])
            record = {"pair": pair.name, "setting": label, "median_match_seconds": match_seconds,
                      "median_call_seconds": call_seconds, "sgbm_seconds": sgbm_seconds,
                      "match_ratio_to_sgbm": None if match_seconds is None else match_seconds / sgbm_seconds,
                      "call_ratio_to_sgbm": call_seconds / sgbm_seconds,
                      "bad1_ratio_to_sgbm": m.bad1_matched_pct / sgbm_bad1 if sgbm_bad1 else math.nan,
                      "metrics": m.to_dict()}
            records.append(record)
            rows.append([pair.name, label, _fmt(None if match_seconds is None else match_seconds * 1000, 1),
                         _fmt(record["match_ratio_to_sgbm"]), _fmt(call_seconds * 1000, 1),
                         _fmt(record["call_ratio_to_sgbm"]), _fmt(m.bad1_matched_pct),
                         _fmt(record["bad1_ratio_to_sgbm"]), _fmt(m.density_pct, 1)])
    text = "\n\n".join([
        "GCS as published and with each extension turned off in turn: `bands=1` (one growth over "
        "the image, as published; the default `bands=2` grows two row bands in two threads), "
        "`shifted_windows=False` (the check against foreground fattening) and `speckle_size=0` "
        "(no removal of small disparity islands); neither check is part of the published method "
        f"(`docs/matching.md`). Median of {repeat} calls after a first call, "
        "interleaved with SGBM in one loop. `match ms` is seeds + growth + final matching (+ the "
        "checks), as reported by the matcher; `call ms` the whole call; `/ SGBM` divides by SGBM's "
        "whole call in the same loop. The last row of each pair is the coarse-to-fine matching the "
        "obstacle pipeline uses by default (`scaled_matching.match_at_scale`, scale 0.5: growth on a "
        "half-size copy, every match refined on the full-size pair; `docs/matching.md`, \"Coarse to "
        "fine\"), with the pipeline's matcher settings; it has no separate match time.",
        _table(["pair", "setting", "match ms", "match / SGBM", "call ms", "call / SGBM", "bad-1 %",
                "bad-1 / SGBM", "density %"], rows),
    ])
    return text, records


# --- 3. scaling ------------------------------------------------------------------------------

def _synthetic_pair(width: int, height: int) -> StereoPair:
    """The built-in default scene rendered at ``width x height`` (helper A's synthetic world)."""
    from stereo_obstacles.synthetic.layout import default_scene
    from stereo_obstacles.synthetic.render import render_pair

    rendered = render_pair(default_scene(width, height))
    return StereoPair(name=f"default scene {width}x{height}", left=rendered.left,
                      right=rendered.right, gt_disparity=rendered.disparity,
                      nonocc=rendered.nonocc & np.isfinite(rendered.disparity),
                      calibration=rendered.calibration, source=Path("<synthetic>"),
                      layout="synthetic")


def scaling(sizes: tuple[tuple[int, int], ...], repeat: int) -> tuple[str, list[dict]]:
    methods = resolve_methods([n for n in ("gcs", "sgbm") if n in available_methods()])
    rows, records = [], []
    for width, height in sizes:
        print(f"scaling: {width}x{height}", file=sys.stderr)
        pair = _synthetic_pair(width, height)
        megapixels = width * height / 1e6
        for r in evaluate_pair(pair, methods, repeat=repeat):
            record = r.to_dict()
            record["megapixels"] = megapixels
            records.append(record)
            rows.append([f"{width}x{height}", _fmt(megapixels, 2), r.method,
                         str(r.max_disparity_px), _fmt(r.median_seconds * 1000, 1),
                         _fmt(r.median_seconds / megapixels, 3),
                         _fmt(r.metrics.density_pct, 1), _fmt(r.metrics.bad1_matched_pct)])
    text = "\n\n".join([
        "The built-in default synthetic scene (`stereo_obstacles.synthetic`, fixed field of "
        "view) rendered at four sizes, scored over its non-occluded pixels; "
        f"median of {repeat} calls. The disparity range grows with the width, so an exhaustive "
        "method's cost grows faster than the pixel count.",
        _table(["size", "MP", "method", "max d", "median ms", "s per MP", "density %",
                "bad-1 %"], rows),
    ])
    return text, records


# --- 4. compile cost -------------------------------------------------------------------------

def compile_cost() -> tuple[str, dict]:
    code = "from stereo_obstacles.matching import warm_up; print(warm_up())"
    with tempfile.TemporaryDirectory(prefix="bench-numba-cache-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        figures = []
        for _ in range(2):
            out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                                 capture_output=True, text=True)
            figures.append(float(out.stdout.strip().splitlines()[-1]))
    record = {"cold_compile_seconds": figures[0], "cached_first_call_seconds": figures[1]}
    text = (f"`stereo_obstacles.matching.warm_up()` in a fresh process: **{figures[0]:.2f} s** "
            f"with an empty numba cache (compilation of every kernel), **{figures[1]:.2f} s** "
            f"with the cache filled (`cache=True`: loading). Steady-state times above exclude "
            f"this.")
    return text, record


# --- report ----------------------------------------------------------------------------------

def closing_note(comparison_records: list[dict], ablation_records: list[dict]) -> str:
    lines = []
    for rec in comparison_records:
        if rec["method"] == "gcs" and rec["pair"] in TARGET_PAIRS and "time_ratio_to_sgbm" in rec:
            sgbm_seconds = rec["median_seconds"] / rec["time_ratio_to_sgbm"]
            match_seconds = (rec["method_stats"] or {}).get("match_seconds", math.nan)
            lines.append(f"- {rec['pair']}: GCS time / SGBM = {rec['time_ratio_to_sgbm']:.2f} "
                         f"(whole call; seeds + growth + final matching + shifted-window check + speckle removal, last run: "
                         f"{match_seconds / sgbm_seconds:.2f}; target ≤ 1.0), "
                         f"bad-1 / SGBM = {rec['bad1_ratio_to_sgbm']:.2f} (target ≤ 0.7), "
                         f"density {rec['metrics']['density_pct']:.1f} % (target ≥ 80 %).")
    by_pair: dict[str, dict[str, dict]] = {}
    for rec in ablation_records:
        by_pair.setdefault(rec["pair"], {})[rec["seeds"]] = rec
    edge = DEFAULT_SEEDS.capitalize()
    for pair, kinds in by_pair.items():
        if DEFAULT_SEEDS in kinds and "random" in kinds:
            e, r = kinds[DEFAULT_SEEDS], kinds["random"]
            others = "".join(f", random / {kind.capitalize()} "
                              f"{r['median_match_seconds'] / kinds[kind]['median_match_seconds']:.2f}"
                              for kind in kinds if kind not in (DEFAULT_SEEDS, "random"))
            lines.append(
                f"- Seeds on {pair}: random / {edge} (the default edge seeds) time = "
                f"{r['median_match_seconds'] / e['median_match_seconds']:.2f} (the paper claims about 3.3 "
                f"for edge seeds){others}; bad-1 {edge} {_fmt(e['metrics']['bad1_matched_pct'])} % "
                f"vs random {_fmt(r['metrics']['bad1_matched_pct'])} %, density "
                f"{_fmt(e['metrics']['density_pct'], 1)} % vs {_fmt(r['metrics']['density_pct'], 1)} %.")
    return "\n".join(lines) if lines else "No GCS figures in this run."


def _source_version() -> str:
    """``git describe`` of the checkout (``-dirty`` when files differ from the commit)."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=REPO, check=True,
                             capture_output=True, text=True)
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return out.stdout.strip()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="shared data folder")
    parser.add_argument("--repeat", type=int, default=5, help="timed calls per measurement")
    parser.add_argument("--quick", action="store_true",
                        help="3 runs, no Aloe, no 2 MP scene, no cold-compile measurement")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "benchmarks.md")
    parser.add_argument("--json", type=Path, default=None, help="also write raw figures as JSON")
    args = parser.parse_args(argv)
    repeat = 3 if args.quick else args.repeat
    names = MIDDLEBURY[:-1] if args.quick else MIDDLEBURY
    sizes = SCALING_SIZES[:-1] if args.quick else SCALING_SIZES
    have_gcs = "gcs" in available_methods()
    sections, raw = [], {"machine": machine_info(), "repeat": repeat}

    compile_text = "Skipped: " + ("--quick." if args.quick else "the GCS matcher is not installed.")
    if have_gcs and not args.quick:
        compile_text, raw["compile"] = compile_cost()
        from stereo_obstacles.matching import warm_up
        warm_up()  # this process: steady state from here on

    if args.data.is_dir():
        text, raw["comparison"] = comparison(args.data, names, repeat)
        if have_gcs:
            ablation_text, raw["seed_ablation"] = seed_ablation(args.data, TARGET_PAIRS, repeat)
        else:
            ablation_text, raw["seed_ablation"] = "Skipped: the GCS matcher is not installed.", []
    else:
        reason = f"Skipped: shared data not found at {args.data}."
        text, ablation_text, raw["comparison"], raw["seed_ablation"] = reason, reason, [], []
    sections += [("Comparison on Middlebury", text), ("Seed ablation", ablation_text)]
    if args.data.is_dir() and have_gcs:
        ext_text, raw["extensions"] = extensions(args.data, names[:4], repeat)
    else:
        ext_text, raw["extensions"] = "Skipped: shared data or the GCS matcher missing.", []
    sections.append(("Extensions: row bands, the shifted-window check, speckle removal", ext_text))

    try:
        scaling_text, raw["scaling"] = scaling(sizes, repeat)
    except ImportError as exc:
        scaling_text, raw["scaling"] = f"Skipped: synthetic scenes unavailable ({exc}).", []
    sections += [("Scaling with image size", scaling_text), ("Compile cost", compile_text)]

    machine = raw["machine"]
    header = (
        "# Benchmarks\n\n"
        "Written by `python benchmarks/bench_matching.py` "
        f"({'--quick' if args.quick else f'--repeat {repeat}'}) on "
        f"{time.strftime('%Y-%m-%d')}. Machine: {machine['cpu']}, {machine['logical_cpus']} "
        f"logical CPUs, {machine['system']}; Python {machine['python']}, NumPy "
        f"{machine['numpy']}, OpenCV {machine['opencv']} ({machine['opencv_threads']} threads), "
        f"numba {machine['numba']} ({machine['numba_threads']} threads); stereo-obstacles "
        f"{machine['stereo_obstacles']} (source {_source_version()}). Methods: "
        + "; ".join(f"`{m.name}` {m.description}" for m in METHODS.values()) + ".\n\n"
        "Wall-clock times on a shared virtual machine: compare ratios within one run, not "
        "absolute figures across runs."
    )
    body = "\n\n".join(f"## {title}\n\n{text}" for title, text in sections)
    note = "## Closing note\n\n" + closing_note(raw["comparison"], raw["seed_ablation"])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(f"{header}\n\n{body}\n\n{note}\n", encoding="utf-8")
    print(f"wrote {args.out}", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps(raw, indent=2, default=float) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
