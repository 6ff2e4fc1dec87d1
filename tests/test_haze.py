"""The far-ground haze correction on constructed images with a known haze."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.haze import HazeParameters, estimate_haze, hazy_ground

HEIGHT, WIDTH, HORIZON = 200, 160, 40
PLANE = GroundPlane(a=0.0, b=0.2, c=-0.2 * HORIZON)             # d = 0.2 (y - 40)
GROUND = np.array((110.0, 140.0, 80.0))                           # green ground
AIRLIGHT = np.array((230.0, 236.0, 246.0))                        # bright bluish horizon
BOX = (0, 170, WIDTH, HEIGHT)


def _hazy_scene(k=0.5, seed=0, airlight=AIRLIGHT):
    """Ground of one colour seen through haze ``h = 1 - exp(-k / d)`` below the horizon, the
    airlight above it, a little noise; ``uint8 (H, W, 3)``."""
    d = PLANE.b * np.arange(HEIGHT) + PLANE.c
    h = np.where(d > 0, 1.0 - np.exp(-k / np.maximum(d, 1e-9)), 1.0)[:, None, None]
    image = GROUND * (1.0 - h) + airlight * h + np.random.default_rng(seed).normal(0, 1.5, (HEIGHT, WIDTH, 3))
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def test_the_haze_and_the_airlight_are_recovered():
    """The reference area is taken as haze-free; here it has 1.7 % of haze itself, which
    biases ``k`` low (0.41 for 0.5)."""
    estimate = estimate_haze(_hazy_scene(k=0.5), PLANE, BOX)
    assert estimate is not None
    assert 0.38 < estimate.k_px < 0.5
    np.testing.assert_allclose(estimate.airlight, AIRLIGHT, atol=3)
    d = estimate.row_disparity
    far = d > 1
    np.testing.assert_allclose(estimate.haze[far], 1 - np.exp(-estimate.k_px / d[far]), rtol=1e-9)
    assert np.all(estimate.haze[d <= 0] == 0.6)                  # at and above the horizon: the cap


def test_far_hazy_ground_becomes_ground_but_not_a_far_red_box_nor_near_pixels():
    rgb = _hazy_scene(k=0.5)
    rgb[45:52, 100:120] = (200, 40, 40)                            # a far red box
    obstacle = np.zeros((HEIGHT, WIDTH), bool)
    obstacle[41:60, :] = True                                      # what colour called the far band
    obstacle[120:130, 10:30] = True                                # near pixels: never touched
    estimate = estimate_haze(rgb, PLANE, BOX)
    flipped = hazy_ground(rgb, obstacle, estimate, BOX, min_intensity=0.05)
    # far: at least 10 times the reference's distance (d < 0.2 * (185 - 40) / 10 = 2.9, rows <= 54);
    # right under the horizon (d < 1.6) the haze is beyond what the estimate clears (k is biased
    # low, h capped at 0.6) and the pixels stay obstacle
    assert np.mean(flipped[49:55, :90]) > 0.95
    assert not flipped[41:48].any()
    assert not flipped[45:52, 104:116].any()                     # the box but its 3 px rim (7 x 7 vote)
    assert not flipped[55:].any()
    assert not flipped[~obstacle].any()


def test_an_obstacle_standing_on_nearer_ground_keeps_its_far_rows():
    """A pole whose base is near (row 150) reaches up into the far rows, with the ground's own
    colour there (what haze or an untextured face could look like): none of it becomes ground;
    the far band beside it does."""
    rgb = _hazy_scene(k=0.5)
    obstacle = np.zeros((HEIGHT, WIDTH), bool)
    obstacle[41:56, :] = True                                      # the far band, called obstacle
    obstacle[41:150, 120:130] = True                               # the pole, down to its base
    flipped = hazy_ground(rgb, obstacle, estimate_haze(rgb, PLANE, BOX), BOX, min_intensity=0.05)
    assert not flipped[:, 120:130].any()
    assert np.mean(flipped[49:55, :90]) > 0.95


def test_uint16_images_give_the_same_decision_and_estimate():
    rgb = _hazy_scene(k=0.5)
    wide = rgb.astype(np.uint16) * 257
    narrow, deep = estimate_haze(rgb, PLANE, BOX), estimate_haze(wide, PLANE, BOX)
    assert deep.k_px == pytest.approx(narrow.k_px, rel=1e-6)
    dull = _hazy_scene(airlight=GROUND + (6.0, 5.0, 4.0))                 # no distinct airlight colour
    assert estimate_haze(dull, PLANE, BOX) is None
    assert estimate_haze(dull.astype(np.uint16) * 257, PLANE, BOX) is None


@pytest.mark.parametrize("case", ["dark horizon", "colour drifts near", "no sloping plane", "off",
                                  "horizon at infinity"])
def test_no_estimate_when_the_image_does_not_show_haze(case):
    rgb, plane, params = _hazy_scene(), PLANE, HazeParameters()
    if case == "dark horizon":                                      # buildings or trees at the horizon
        rgb = _hazy_scene(airlight=np.array((40.0, 42.0, 38.0)))
    elif case == "colour drifts near":                              # haze-like drift even at 6-8 px
        rgb = _hazy_scene(k=5.0)
    elif case == "no sloping plane":
        plane = GroundPlane(a=0.0, b=0.0, c=5.0)
    elif case == "horizon at infinity":
        plane = GroundPlane(a=0.0, b=1e-320, c=-5.0)
    else:
        params = HazeParameters(enabled=False)
    assert estimate_haze(rgb, plane, BOX, params=params) is None


@pytest.mark.parametrize("kwargs, match", [
    ({"enabled": 1}, "enabled"), ({"window_px": 4}, "window_px"), ({"horizon_rows": 0}, "horizon_rows"),
    ({"estimate_disparity_px": (8.0, 0.5)}, "estimate_disparity_px"), ({"max_haze": 0.99}, "max_haze"),
    ({"min_distance_factor": 0.5}, "min_distance_factor"), ({"ground_fraction": float("nan")}, "ground_fraction"),
    ({"estimate_disparity_px": (False, True)}, "estimate_disparity_px"), ({"near_disparity_px": 20.0}, "near_disparity_px"),
    ({"min_haze": 0.7, "max_haze": 0.6}, "min_haze"),
])
def test_parameters_are_validated(kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        HazeParameters(**kwargs)


@pytest.mark.slow
def test_segment_with_the_right_image_calls_less_far_ground_obstacle():
    """Seed 8 (grass, far ground hazy): ground -> obstacle falls, recall does not."""
    from stereo_obstacles.segmentation import SegmentationParameters
    from stereo_obstacles.segmentation_evaluation import evaluate_synthetic, total

    off = total(evaluate_synthetic([8], params=SegmentationParameters(haze=HazeParameters(enabled=False))))
    on = total(evaluate_synthetic([8]))
    assert on.ground_to_obstacle_rate < off.ground_to_obstacle_rate - 0.05
    assert on.recall >= off.recall - 0.005
