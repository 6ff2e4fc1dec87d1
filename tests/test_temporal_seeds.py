"""Temporal seeds: the previous frame's matches as the next frame's seeds."""

from __future__ import annotations

import numpy as np
import pytest

from _stream_frames import SPEED_M_PER_FRAME, frames
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError
from stereo_obstacles.matching import match
from stereo_obstacles.pipeline import detect
from stereo_obstacles.temporal_seeds import (TemporalSeeder, TemporalSeedParameters, temporal_estimate,
                                             temporal_seed_points)

CALIB = StereoCalibration(focal_px=100.0, cx_px=10.0, cy_px=7.0, baseline_m=0.2, width_px=24, height_px=16,
                          doffs_px=1.5)


def reference_points(disparity, *, d_min, d_max, step, calibration=None, forward_m=0.0):
    """One pixel at a time, straight from the definitions."""
    h, w = disparity.shape
    rows = []
    for y in range(0, h, step):
        for x in range(0, w, step):
            d = float(disparity[y, x])
            if not np.isfinite(d):
                continue
            xn, yn, dn = float(x), float(y), d
            if forward_m:
                z = calibration.focal_px * calibration.baseline_m / (d + calibration.doffs_px)
                zn = z - forward_m
                if d + calibration.doffs_px <= 0 or zn <= 0:
                    continue
                xn = calibration.cx_px + (x - calibration.cx_px) * z / zn
                yn = calibration.cy_px + (y - calibration.cy_px) * z / zn
                dn = calibration.focal_px * calibration.baseline_m / zn - calibration.doffs_px
            xn, yn, dn = round(xn), round(yn), round(dn)
            if 0 <= xn < w and 0 <= yn < h and d_min <= dn <= d_max and xn - dn >= 0:
                rows.append((xn, yn, dn))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


@pytest.mark.parametrize("step,forward", [(1, 0.0), (3, 0.0), (2, 0.5), (1, -0.3)])
def test_points_match_the_reference(step, forward):
    rng = np.random.default_rng(step)
    disparity = rng.uniform(0.2, 14.0, (16, 24)).astype(np.float32)
    disparity[rng.random(disparity.shape) < 0.3] = np.nan
    got = temporal_seed_points(disparity, d_min=1, d_max=12, step_px=step, calibration=CALIB, forward_m=forward)
    want = reference_points(disparity, d_min=1, d_max=12, step=step, calibration=CALIB, forward_m=forward)
    assert got.shape[1] == 3 and got.dtype == np.float64
    np.testing.assert_array_equal(got, want)


def test_moving_forward_pushes_points_outwards_and_nearer():
    disparity = np.full((16, 24), np.nan, np.float32)
    disparity[12, 20] = 10.0
    (x, y, d), = temporal_seed_points(disparity, d_min=0, d_max=23, step_px=1, calibration=CALIB, forward_m=0.4)
    assert x > 20 and y > 12 and d > 10


def test_point_errors():
    with pytest.raises(InvalidInputError, match="2-D"):
        temporal_seed_points(np.zeros(5), d_min=0, d_max=3)
    with pytest.raises(InvalidInputError, match="step_px"):
        temporal_seed_points(np.zeros((4, 4)), d_min=0, d_max=3, step_px=0)
    with pytest.raises(InvalidInputError, match="needs a calibration"):
        temporal_seed_points(np.zeros((4, 4)), d_min=0, d_max=3, forward_m=0.1)
    with pytest.raises(InvalidInputError, match="step_px"):
        TemporalSeedParameters(step_px=0)
    with pytest.raises(InvalidInputError, match="forward_m_per_frame"):
        TemporalSeedParameters(forward_m_per_frame=float("nan"))


def test_seeder_refreshes_with_edge_seeds():
    seeder = TemporalSeeder(TemporalSeedParameters(step_px=1, refresh_every=3, min_seeds=5, refine_frames=0))
    matched = np.full((8, 8), 2.0, np.float32)
    kinds = []
    for _ in range(7):
        kinds.append("edge" if seeder.seeds() is None else "temporal")
        seeder.observe(matched, d_min=0, d_max=4)
    assert kinds == ["edge", "temporal", "temporal", "edge", "temporal", "temporal", "edge"]
    seeder.observe(np.full((8, 8), np.nan, np.float32), d_min=0, d_max=4)     # nothing matched
    assert seeder.seeds() is None


def bad_and_density(disparity, truth):
    known = np.isfinite(truth)
    matched = known & np.isfinite(disparity)
    return float(np.mean(np.abs(disparity[matched] - truth[matched]) > 1)), matched.sum() / known.sum()


@pytest.mark.parametrize("forward", [0.0, SPEED_M_PER_FRAME])
def test_temporal_seeds_match_as_well_as_edge_seeds(forward):
    walk = frames()
    previous = match(walk[0].left, walk[0].right)
    pair = walk[1]
    points = temporal_seed_points(previous.disparity, d_min=previous.stats.d_min, d_max=previous.stats.d_max,
                                  calibration=pair.calibration, forward_m=forward)
    temporal = match(pair.left, pair.right, seed_points=points)
    edge = match(pair.left, pair.right)
    bad_t, density_t = bad_and_density(temporal.disparity, pair.disparity)
    bad_e, density_e = bad_and_density(edge.disparity, pair.disparity)
    assert temporal.stats.n_seed_pixels == len(points) > 50
    assert bad_t <= bad_e + 0.01
    assert density_t >= density_e - 0.02


def test_detect_passes_seed_points_to_the_matcher():
    pair = frames()[0]
    points = np.array([[80, 100, 20], [60, 110, 25]])
    result = detect(pair.left, pair.right, pair.calibration, seed_points=points)
    assert result.match_stats.n_seed_pixels == 2
    assert detect(pair.left, pair.right, pair.calibration).match_stats.n_seed_pixels > 2


def test_seeder_refines_after_each_grown_frame_and_only_grown_frames_give_estimates():
    seeder = TemporalSeeder(TemporalSeedParameters(step_px=1, refresh_every=0, min_seeds=5, refine_frames=2))
    kinds, estimates = [], []
    for k in range(8):
        estimate = seeder.estimate()
        kind = "refined" if estimate is not None else "edge" if seeder.seeds() is None else "temporal"
        kinds.append(kind)
        estimates.append(None if estimate is None else float(estimate[0, 0]))
        seeder.observe(np.full((8, 8), float(k), np.float32), d_min=0, d_max=9, refined=kind == "refined")
    assert kinds == ["edge", "refined", "refined", "temporal", "refined", "refined", "temporal", "refined"]
    assert estimates == [None, 0.0, 0.0, None, 3.0, 3.0, None, 6.0]   # always the latest grown frame


def test_estimate_spreads_matches_by_one_pixel_like_a_reference():
    rng = np.random.default_rng(4)
    disparity = rng.uniform(1, 9, (12, 15)).astype(np.float32)
    disparity[rng.random(disparity.shape) < 0.7] = np.nan
    got = temporal_estimate(disparity)
    h, w = disparity.shape
    for y in range(h):
        for x in range(w):
            around = disparity[max(0, y - 1):y + 2, max(0, x - 1):x + 2]
            want = disparity[y, x] if np.isfinite(disparity[y, x]) else (
                np.nanmax(around) if np.isfinite(around).any() else np.nan)
            np.testing.assert_equal(got[y, x], np.float32(want))


def test_refining_the_previous_frame_matches_almost_as_well_as_growing():
    walk = frames()
    previous = detect(walk[0].left, walk[0].right, walk[0].calibration)
    pair = walk[1]
    refined = detect(pair.left, pair.right, pair.calibration, disparity_estimate=temporal_estimate(previous.disparity))
    grown = detect(pair.left, pair.right, pair.calibration)
    bad_r, density_r = bad_and_density(refined.disparity, pair.disparity)
    bad_g, density_g = bad_and_density(grown.disparity, pair.disparity)
    assert refined.match_stats.n_seeds == 0 and refined.match_stats.growth_seconds == 0.0
    assert refined.match_stats.n_visited > 0
    assert bad_r <= bad_g + 0.01 and density_r >= density_g - 0.02


def test_detect_refuses_an_estimate_of_another_shape_or_with_seeds():
    pair = frames()[0]
    with pytest.raises(ImageMismatchError, match="disparity_estimate must have the images' shape"):
        detect(pair.left, pair.right, disparity_estimate=np.zeros((3, 3), np.float32))
    with pytest.raises(InvalidInputError, match="give one or the other"):
        detect(pair.left, pair.right, seed_points=np.array([[80, 100, 20]]),
               disparity_estimate=np.zeros(pair.left.shape[:2], np.float32))
