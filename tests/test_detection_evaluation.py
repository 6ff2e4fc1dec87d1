"""Pairing detections with true obstacles, and the figures over many scenes (constructed cases)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from stereo_obstacles.detection_evaluation import (SceneEvaluation, TruthComparison, compare_with_truth, is_counted,
                                                   repeated_detections, summarise)
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import Label
from stereo_obstacles.obstacles import Obstacle, ObstacleList

SHAPE = (60, 100)


def _truth(obstacle_id: int, instances: np.ndarray, depth_m: float, height_m: float = 1.0):
    return SimpleNamespace(obstacle_id=obstacle_id, kind="box", size_m=(0.5, 0.5, height_m), nearest_depth_m=depth_m,
                           visible_pixels=int(np.count_nonzero(instances == obstacle_id)))


def _detections(id_map: np.ndarray, distances_m: dict[int, float]) -> ObstacleList:
    obstacles = tuple(Obstacle(id=i, box_px=(0, 0, 1, 1), pixel_count=int(np.count_nonzero(id_map == i)),
                               disparity_px=10.0, confidence=1.0, distance_m=d) for i, d in distances_m.items())
    return ObstacleList(obstacles=obstacles, id_map=id_map)


def _scene():
    """Three true obstacles on ground; four detections.

    * truth 1 (20x20 px at 4 m): detection 1 covers a quarter of it;
    * truth 2 (20x15 px at 8 m, small and far): a big neighbouring detection 2 reaches 56 of its
      pixels (19 %), its own small detection 3 covers 40 (13 %) and lies 80 % on it;
    * truth 3 (10x10 px at 6 m): nothing covers it;
    * detection 4 lies on a shadow.
    """
    instances = np.zeros(SHAPE, np.uint8)
    labels = np.full(SHAPE, Label.GROUND, np.uint8)
    instances[0:20, 0:20] = 1
    instances[30:50, 40:55] = 2
    instances[0:10, 80:90] = 3
    labels[instances > 0] = Label.OBSTACLE
    labels[50:60, 80:100] = Label.SHADOW
    id_map = np.zeros(SHAPE, np.int32)
    id_map[0:10, 0:10] = 1
    id_map[20:60, 0:40] = 2
    id_map[30:44, 40:44] = 2                 # 56 pixels of truth 2
    id_map[30:40, 44:48] = 3                 # 40 pixels of truth 2 ...
    id_map[20:30, 44] = 3                    # ... and 10 of the ground
    id_map[52:58, 82:98] = 4
    truths = [_truth(1, instances, 4.0), _truth(2, instances, 8.0), _truth(3, instances, 6.0)]
    detections = _detections(id_map, {1: 4.1, 2: 5.0, 3: 7.6, 4: 9.0})
    return detections, instances, labels, truths


def test_each_truth_is_paired_with_a_detection_that_passes_the_overlap_rule():
    detections, instances, labels, truths = _scene()
    comparisons, alarms = compare_with_truth(detections, instances, labels, truths)
    by_id = {c.truth_id: c for c in comparisons}
    assert [c.truth_id for c in comparisons] == [1, 3, 2]  # nearest first
    assert by_id[1].detected_id == 1 and by_id[1].relative_error == pytest.approx(0.025)
    # the big neighbour overlaps truth 2 most but passes neither test; truth 2's own detection does
    assert by_id[2].detected_id == 3 and by_id[2].detected_distance_m == 7.6
    assert by_id[2].relative_error == pytest.approx(-0.05)
    assert by_id[3].detected_id is None and by_id[3].relative_error is None
    assert [(a.detected_id, a.lies_on) for a in alarms] == [(2, "ground"), (4, "shadow")]


def test_among_passing_detections_the_largest_overlap_gives_the_distance():
    detections, instances, labels, truths = _scene()
    id_map = detections.id_map.copy()
    id_map[40:50, 40:55] = 2                 # detection 2 now covers 56 + 150 of truth 2's 300 pixels
    comparisons, _ = compare_with_truth(_detections(id_map, {1: 4.1, 2: 8.2, 3: 7.6, 4: 9.0}), instances, labels,
                                        truths)
    assert {c.truth_id: c.detected_id for c in comparisons}[2] == 2


def test_off_screen_truths_are_left_out():
    detections, instances, labels, truths = _scene()
    hidden = SimpleNamespace(obstacle_id=9, kind="box", size_m=(1, 1, 1), nearest_depth_m=None, visible_pixels=0)
    comparisons, _ = compare_with_truth(detections, instances, labels, truths + [hidden])
    assert 9 not in {c.truth_id for c in comparisons}


def test_a_detection_lying_mostly_on_an_obstacle_a_larger_one_covers_repeats_it():
    detections, instances, labels, truths = _scene()
    assert repeated_detections(detections, instances) == ()         # 3 lies mostly on truth 2, 2 mostly on ground
    id_map = detections.id_map.copy()
    id_map[10:20, 0:20] = 5                                          # truth 1's other half: 200 px
    id_map[0:10, 10:12] = 6                                          # and a sliver of 20 px
    repeated = _detections(id_map, {1: 4.1, 2: 5.0, 3: 7.6, 4: 9.0, 5: 4.2, 6: 4.3})
    assert repeated_detections(repeated, instances) == (1, 6)        # 5 is the largest on truth 1
    evaluations = [SceneEvaluation(seed=s, ground="asphalt", comparisons=(), false_alarms=(), seconds=0.1,
                                   n_detections=6, n_repeated=2) for s in (1, 2)]
    assert (summarise(evaluations).n_detections, summarise(evaluations).n_repeated) == (12, 4)


def test_summary_counts_only_relevant_truths():
    detections, instances, labels, truths = _scene()
    truths[0] = _truth(1, instances, 4.0, height_m=0.2)  # too low to count
    comparisons, alarms = compare_with_truth(detections, instances, labels, truths)
    evaluation = SceneEvaluation(seed=7, ground="asphalt", comparisons=tuple(comparisons),
                                 false_alarms=tuple(alarms), seconds=0.5)
    summary = summarise([evaluation], min_height_m=0.3, max_distance_m=10.0, min_visible_px=50)
    assert (summary.n_obstacles, summary.n_found) == (2, 1)
    assert summary.median_abs_error_pct == pytest.approx(5.0) == summary.max_abs_error_pct
    assert (summary.false_alarms_on_shadow, summary.false_alarms_on_marking, summary.false_alarms_other) == (1, 0, 1)
    assert summary.missed == ("seed 7: #3 box at 6.0 m (100 px seen by both cameras)",)
    assert summary.large_errors == ()                   # 5.0 % is not above 5 %
    assert summarise([evaluation], max_distance_m=5.0, min_visible_px=50).n_obstacles == 0


def test_an_obstacle_counts_by_the_pixels_both_cameras_see():
    detections, instances, labels, truths = _scene()
    seen_by_both = np.ones(SHAPE, bool)
    seen_by_both[0:10, 80:86] = False        # 60 of truth 3's 100 pixels: the left camera's alone
    comparisons, alarms = compare_with_truth(detections, instances, labels, truths, seen_by_both=seen_by_both)
    by_id = {c.truth_id: c for c in comparisons}
    assert (by_id[3].visible_pixels, by_id[3].stereo_visible_pixels) == (100, 40)
    assert by_id[1].stereo_visible_pixels == 400
    evaluation = SceneEvaluation(seed=7, ground="asphalt", comparisons=tuple(comparisons),
                                 false_alarms=tuple(alarms), seconds=0.5)
    summary = summarise([evaluation], min_visible_px=50)
    assert (summary.n_obstacles, summary.n_found, summary.missed) == (2, 2, ())
    assert summarise([evaluation], min_visible_px=40).missed == ("seed 7: #3 box at 6.0 m (40 px seen by both cameras)",)
    as_png = compare_with_truth(detections, instances, labels, truths, seen_by_both=seen_by_both.astype(np.uint8) * 255)
    assert [c.stereo_visible_pixels for c in as_png[0]] == [c.stereo_visible_pixels for c in comparisons]
    with pytest.raises(InvalidInputError, match="seen_by_both"):
        compare_with_truth(detections, instances, labels, truths, seen_by_both=seen_by_both[:, :-1])


def test_which_true_obstacles_count():
    def comparison(**fields):
        return TruthComparison(**{"truth_id": 1, "kind": "box", "height_m": 1.0, "true_distance_m": 6.0,
                                  "visible_pixels": 500, "detected_id": None, "detected_distance_m": None, **fields})

    assert is_counted(comparison())                                # not known: all 500 visible pixels
    assert is_counted(comparison(stereo_visible_pixels=200))
    assert not is_counted(comparison(stereo_visible_pixels=199))
    assert not is_counted(comparison(stereo_visible_pixels=0))     # none, not "not known"
    assert not is_counted(comparison(height_m=0.29))
    assert not is_counted(comparison(true_distance_m=10.01))
    assert not is_counted(comparison(true_distance_m=None))
    assert is_counted(comparison(true_distance_m=12.0), max_distance_m=15.0)


@pytest.mark.parametrize("kwargs, match", [({"min_height_m": -1.0}, "min_height_m"),
                                           ({"max_distance_m": float("nan")}, "max_distance_m")])
def test_summary_refuses_bad_limits(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        summarise([], **kwargs)


def test_errors_above_five_percent_are_listed_worst_first():
    def found(truth_id, true_m, reported_m):
        return TruthComparison(truth_id=truth_id, kind="pole", height_m=1.0, true_distance_m=true_m, visible_pixels=500,
                               detected_id=1, detected_distance_m=reported_m)

    evaluation = SceneEvaluation(seed=3, ground="asphalt", comparisons=(found(1, 8.0, 8.8), found(2, 4.0, 4.1),
                                                                         found(3, 9.0, 7.2)),
                                 false_alarms=(), seconds=0.1)
    assert summarise([evaluation]).large_errors == ("seed 3: #3 pole at 9.00 m, reported 7.20 m (-20.0 %)",
                                                    "seed 3: #1 pole at 8.00 m, reported 8.80 m (+10.0 %)")


def _recording_render(monkeypatch) -> list:
    """Make ``render_pair`` record the ``RenderOptions`` it is given (``pipeline.warm_up`` renders
    a small pair with the defaults first: ``None``)."""
    import stereo_obstacles.synthetic as synthetic

    seen, render = [], synthetic.render_pair

    def recording(scene, options=None, **kwargs):
        seen.append(options)
        return render(scene, options, **kwargs)

    monkeypatch.setattr(synthetic, "render_pair", recording)
    return seen


def test_evaluate_detection_command_renders_with_the_asked_rays_per_pixel(tmp_path, capsys, monkeypatch):
    import json

    from stereo_obstacles import cli

    seen = _recording_render(monkeypatch)
    out = tmp_path / "figures.json"
    assert cli.main(["evaluate-detection", "--scenes", "1", "--size", "320x240", "--supersample", "2",
                     "--json", str(out)]) == 0
    assert [(o.supersample, o.noise_sigma, o.jpeg_quality) for o in seen if o is not None] == [(2, 0.0, None)]
    printed = capsys.readouterr().out
    assert "(320x240, 2x2 rays per pixel)" in printed
    figures = json.loads(out.read_text())["synthetic"]
    assert figures["supersample"] == 2 and figures["n_scenes"] == 1
    scan = figures["scan"]
    assert scan["n_sectors"] == 60 and scan["n_reported"] <= scan["n_with_obstacle"] > 0
    assert (f"free range per 1 deg of bearing: {scan['n_reported']}/{scan['n_with_obstacle']} sectors with such an "
            f"obstacle ranged") in printed
    assert figures["n_found"] == figures["n_obstacles"] == 6  # the built-in scene: six true obstacles
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["evaluate-detection", "--supersample", "5"])
    assert exit_info.value.code == 2


def test_evaluate_detection_command_degrades_the_images_as_asked(tmp_path, capsys, monkeypatch):
    import json

    from stereo_obstacles import cli

    seen = _recording_render(monkeypatch)
    out = tmp_path / "figures.json"
    assert cli.main(["evaluate-detection", "--scenes", "1", "--size", "320x240", "--supersample", "1", "--noise", "1",
                     "--jpeg-quality", "90", "--json", str(out)]) == 0
    assert [(o.supersample, o.noise_sigma, o.jpeg_quality) for o in seen if o is not None] == [(1, 1.0, 90)]
    assert "noise 1, JPEG quality 90)" in capsys.readouterr().out
    figures = json.loads(out.read_text())["synthetic"]
    assert (figures["noise_sigma"], figures["jpeg_quality"]) == (1.0, 90)
    for bad in (["--jpeg-quality", "0"], ["--jpeg-quality", "101"], ["--noise", "-1"], ["--noise", "nan"]):
        with pytest.raises(SystemExit) as exit_info:
            cli.main(["evaluate-detection", *bad])
        assert exit_info.value.code == 2
        assert "expected" in capsys.readouterr().err


def test_evaluate_detection_says_a_warning_of_every_scene_once(capsys, caplog):
    from stereo_obstacles import cli

    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        assert cli.main(["evaluate-detection", "--scenes", "2", "--size", "320x240", "--supersample", "1",
                         "--matching-scale", "0.3"]) == 0
    said = [r.getMessage() for r in caplog.records if "matching scale 0.3 is raised to 0.5" in r.getMessage()]
    assert len(said) == 1                                                    # was once per scene
    assert "repeats of the warnings above not shown" in capsys.readouterr().err


def test_evaluate_detection_writes_the_dataset_figures_as_json(tmp_path, capsys, shared_dataset):
    import json

    from stereo_obstacles import cli

    out = tmp_path / "figures.json"
    assert cli.main(["evaluate-detection", "--scenes", "1", "--size", "320x240", "--supersample", "1",
                     "--dataset", str(shared_dataset("kitti2015_000005")), "--json", str(out)]) == 0
    (figures,) = json.loads(out.read_text())["datasets"]
    assert figures["name"] == "kitti2015_000005" and figures["obstacles"] > 0
    assert set(figures["timings_s"]) >= {"matching", "obstacles", "total"}
    assert "kitti2015_000005: density" in capsys.readouterr().out
