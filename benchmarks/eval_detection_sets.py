"""Issue 5's detection figures over large sets of synthetic scenes, rendered once and reused.

`stereo-obstacles evaluate-detection` renders every scene it scores (about 1 s a scene with 3 x 3
rays per pixel); comparing two versions of the pipeline over the 1660 scenes of the sets below
renders them again each time. This script renders each set once into a folder and scores the
pipeline found on the Python path against it, two processes at a time:

    python benchmarks/eval_detection_sets.py render CACHE            # the six sets, about 15 min
    PYTHONPATH=src python benchmarks/eval_detection_sets.py run CACHE RESULTS/base
    PYTHONPATH=/tmp/other/src python benchmarks/eval_detection_sets.py run CACHE RESULTS/new [--without-own-colour]
    python benchmarks/eval_detection_sets.py compare RESULTS/new RESULTS/base

With ``--held-out``, ``render`` and ``run`` take the two held-out sets instead (420 pairs, about 4
min to render): scenes on which no setting has been chosen, to check a change chosen on the six
before keeping it (session 46). Choosing settings on them too would make them six more.

``compare`` prints, per set, the figures of the issue's targets (found, median, cases above 5 %,
false alarms, repeats), each true obstacle whose distance error moved by more than 0.3 points,
or that was found or lost, and each scene whose false alarms changed. The cache holds pickled pairs: read only caches this script wrote.
The sets: 0..959, 960..1139, 1140..1319, 1320..1499 (640 x 480), noise 2 on 0..119, and 320 x 240
on 0..39 (``docs/pipeline.md``, sessions 27-40); held out: 1500..1799 (640 x 480) and noise 2 on
120..239 (session 46).
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

SETS = {"0..959": (0, 960, "640x480", 0.0), "960..1139": (960, 1140, "640x480", 0.0),
        "1140..1319": (1140, 1320, "640x480", 0.0), "1320..1499": (1320, 1500, "640x480", 0.0),
        "noise 2": (0, 120, "640x480", 2.0), "320x240": (0, 40, "320x240", 0.0)}
"""Each set's first seed, last seed + 1, image size and noise (grey levels): the sets the pipeline's
settings were chosen on."""

HELD_OUT_SETS = {"1500..1799": (1500, 1800, "640x480", 0.0), "noise 2 120..239": (120, 240, "640x480", 2.0)}
"""Sets of the same kind that no setting was chosen on (``--held-out``)."""

PROCESSES = 2


def _pair_path(cache: Path, name: str, seed: int) -> Path:
    return cache / name.replace(" ", "_").replace(".", "-") / f"{seed}.pkl"


def _render(cache: Path, name: str, seed: int) -> None:
    from stereo_obstacles.detection_evaluation import EVALUATION_SUPERSAMPLE
    from stereo_obstacles.synthetic import RenderOptions, default_scene, random_scene, render_pair

    path = _pair_path(cache, name, seed)
    if path.exists():
        return
    _, _, size, noise = {**SETS, **HELD_OUT_SETS}[name]
    width, height = map(int, size.split("x"))
    scene = default_scene(width, height) if seed == 0 else random_scene(seed, width_px=width, height_px=height)
    pair = render_pair(scene, RenderOptions(supersample=EVALUATION_SUPERSAMPLE, noise_sigma=noise))
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(".tmp")
    partial.write_bytes(pickle.dumps((scene.ground.name, pair)))
    os.replace(partial, path)


def _evaluate(cache: Path, name: str, seeds: range, without_own_colour: bool) -> list:
    import logging

    from stereo_obstacles.detection_evaluation import evaluate_rendered_pair
    from stereo_obstacles.pipeline import DetectionConfig, warm_up

    logging.disable(logging.WARNING)          # the reference-area notes of scene after scene
    warm_up()
    config = DetectionConfig(own_colour=None) if without_own_colour else DetectionConfig()
    evaluations = []
    for seed in seeds:
        ground, pair = pickle.loads(_pair_path(cache, name, seed).read_bytes())
        evaluations.append(evaluate_rendered_pair(seed, ground, pair, config=config))
    return evaluations


def _sets(args: argparse.Namespace) -> dict:
    return HELD_OUT_SETS if args.held_out else SETS


def render(args: argparse.Namespace) -> None:
    jobs = [(name, seed) for name, (first, stop, _, _) in _sets(args).items() for seed in range(first, stop)]
    with ProcessPoolExecutor(PROCESSES) as pool:
        for future in [pool.submit(_render, args.cache, name, seed) for name, seed in jobs]:
            future.result()
    print(f"{len(jobs)} pairs in {args.cache}")


def run(args: argparse.Namespace) -> None:
    results = {}
    with ProcessPoolExecutor(PROCESSES) as pool:
        for name, (first, stop, _, _) in _sets(args).items():
            halves = [pool.submit(_evaluate, args.cache, name, range(first + k, stop, PROCESSES),
                                  args.without_own_colour) for k in range(PROCESSES)]
            results[name] = sorted((e for half in halves for e in half.result()), key=lambda e: e.seed)
    args.results.parent.mkdir(parents=True, exist_ok=True)
    args.results.write_bytes(pickle.dumps(results))
    print(f"wrote {args.results}")


def _error_pct(comparison) -> float | None:
    return None if comparison.relative_error is None else 100 * comparison.relative_error


def compare(args: argparse.Namespace) -> None:
    from stereo_obstacles.detection_evaluation import is_counted, summarise

    new = pickle.loads(args.new.read_bytes())
    base = pickle.loads(args.base.read_bytes()) if args.base else {}
    for name, evaluations in new.items():
        s = summarise(evaluations)
        print(f"[{name}] found {s.n_found}/{s.n_obstacles}, median {s.median_abs_error_pct:.2f} %, above 5 %: "
              f"{len(s.large_errors)}, false alarms {s.false_alarms_on_shadow}/{s.false_alarms_on_marking}/"
              f"{s.false_alarms_other} (shadow/marking/other), repeats {s.n_repeated}")
        before = {e.seed: e for e in base.get(name, [])}
        for evaluation in evaluations:
            old = before.get(evaluation.seed)
            if old is None:
                continue
            old_errors = {c.truth_id: _error_pct(c) for c in old.comparisons}
            for c in evaluation.comparisons:
                was, now = old_errors.get(c.truth_id), _error_pct(c)
                if (was is None) != (now is None) or (was is not None and abs(abs(now) - abs(was)) > 0.3):
                    scored = " (scored)" if is_counted(c) else ""
                    print(f"   {evaluation.seed} #{c.truth_id} {c.kind} at {c.true_distance_m:.2f} m: "
                          f"{'missed' if was is None else f'{was:+.1f} %'} -> "
                          f"{'missed' if now is None else f'{now:+.1f} %'}{scored}")
            if _alarms(evaluation) != _alarms(old):
                print(f"   {evaluation.seed} false alarms: {_alarms(old) or 'none'} -> {_alarms(evaluation) or 'none'}")


def _alarms(evaluation) -> str:
    """The scene's false alarms, each as its distance and what it lies on (``7.87 m on ground``)."""
    return ", ".join(f"{'?' if a.distance_m is None else f'{a.distance_m:.2f}'} m on {a.lies_on}"
                     for a in evaluation.false_alarms)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    held_out = "the held-out sets instead of the six (check a change with them; choose nothing on them)"
    p = commands.add_parser("render", help="render every set into CACHE (kept pairs are not rendered again)")
    p.add_argument("cache", type=Path)
    p.add_argument("--held-out", action="store_true", help=held_out)
    p = commands.add_parser("run", help="score the pipeline on the Python path over the cached sets")
    p.add_argument("cache", type=Path)
    p.add_argument("results", type=Path)
    p.add_argument("--held-out", action="store_true", help=held_out)
    p.add_argument("--without-own-colour", action="store_true",
                   help="with DetectionConfig(own_colour=None), the default before session 41")
    p = commands.add_parser("compare", help="figures per set, and what moved against BASE")
    p.add_argument("new", type=Path)
    p.add_argument("base", type=Path, nargs="?")
    args = parser.parse_args()
    {"render": render, "run": run, "compare": compare}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
