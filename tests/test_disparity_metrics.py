"""Disparity accuracy figures on hand-made arrays whose answers are counted by hand."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stereo_obstacles.disparity_metrics import DisparityMetrics, evaluate_disparity
from stereo_obstacles.errors import ImageMismatchError, InvalidInputError

NAN = np.nan


def test_hand_counted_example():
    gt = np.array([[10, 10, 10, 10],
                   [20, 20, 20, NAN]], dtype=np.float32)
    est = np.array([[10.5, 11.5, 13.0, NAN],     # ok, bad-1, bad-1/bad-2, unmatched
                     [20.0, 24.0, 100.0, 5.0]],   # ok, bad-2, bad-2 + D1, no GT (ignored)
                    dtype=np.float32)
    m = evaluate_disparity(est, gt)
    assert m.evaluated_px == 7
    assert m.matched_px == 6
    assert m.density_pct == pytest.approx(100 * 6 / 7)
    # errors over matched: 0.5, 1.5, 3.0, 0.0, 4.0, 80.0
    assert m.bad1_matched_pct == pytest.approx(100 * 4 / 6)
    assert m.bad2_matched_pct == pytest.approx(100 * 3 / 6)
    assert m.bad1_all_pct == pytest.approx(100 * 5 / 7)
    assert m.bad2_all_pct == pytest.approx(100 * 4 / 7)
    assert m.epe_px == pytest.approx((0.5 + 1.5 + 3.0 + 0.0 + 4.0 + 80.0) / 6)
    # D1: > 3 px and > 5 % of gt -> 3.0 is not > 3; 4.0 > 3 and > 1.0; 80 yes.
    assert m.d1_matched_pct == pytest.approx(100 * 2 / 6)
    assert m.d1_all_pct == pytest.approx(100 * 3 / 7)


def test_d1_needs_both_absolute_and_relative_error():
    gt = np.array([[100.0, 100.0, 10.0]], dtype=np.float32)
    est = np.array([[104.0, 106.0, 13.5]], dtype=np.float32)  # 4 px = 4 % (ok), 6 %, 35 %
    m = evaluate_disparity(est, gt)
    assert m.d1_matched_pct == pytest.approx(100 * 2 / 3)


def test_mask_restricts_the_evaluated_region():
    gt = np.full((2, 3), 5.0, dtype=np.float32)
    est = np.array([[5.0, 9.0, NAN], [5.0, 5.0, 5.0]], dtype=np.float32)
    mask = np.array([[True, False, False], [True, True, True]])
    m = evaluate_disparity(est, gt, mask=mask)
    assert (m.evaluated_px, m.matched_px) == (4, 4)
    assert m.bad1_matched_pct == 0.0 and m.bad1_all_pct == 0.0


def test_exact_threshold_is_not_bad():
    gt = np.zeros((1, 2), dtype=np.float32) + 10
    est = np.array([[11.0, 8.0]], dtype=np.float32)
    m = evaluate_disparity(est, gt)
    assert m.bad1_matched_pct == pytest.approx(50.0)
    assert m.bad2_matched_pct == 0.0


def test_nothing_matched_gives_undefined_matched_figures_and_json_nulls():
    gt = np.ones((3, 3), dtype=np.float32)
    est = np.full((3, 3), NAN, dtype=np.float32)
    m = evaluate_disparity(est, gt)
    assert m.density_pct == 0.0
    assert math.isnan(m.bad1_matched_pct) and math.isnan(m.epe_px)
    assert m.bad1_all_pct == 100.0 and m.d1_all_pct == 100.0
    d = m.to_dict()
    assert d["bad1_matched_pct"] is None and d["epe_px"] is None
    assert json.loads(json.dumps(d, allow_nan=False))["matched_px"] == 0


def test_infinite_estimate_counts_as_unmatched():
    gt = np.ones((1, 2), dtype=np.float32)
    est = np.array([[np.inf, 1.0]], dtype=np.float32)
    assert evaluate_disparity(est, gt).matched_px == 1


@pytest.mark.parametrize(("est", "gt", "mask", "error", "match"), [
    (np.zeros((2, 2), np.float32), np.zeros((2, 3), np.float32), None, ImageMismatchError,
     "shape"),
    (np.zeros((2, 2), np.int32), np.zeros((2, 2), np.float32), None, InvalidInputError,
     "floating"),
    (np.zeros(4, np.float32), np.zeros((2, 2), np.float32), None, InvalidInputError, "2-D"),
    (np.zeros((2, 2), np.float32), np.zeros((2, 2), np.float32), np.ones((2, 2), np.uint8),
     InvalidInputError, "boolean"),
    (np.zeros((2, 2), np.float32), np.zeros((2, 2), np.float32), np.ones((1, 2), bool),
     ImageMismatchError, "mask"),
    (np.zeros((2, 2), np.float32), np.full((2, 2), NAN, np.float32), None, InvalidInputError,
     "no pixel"),
])
def test_bad_arguments(est, gt, mask, error, match):
    with pytest.raises(error, match=match):
        evaluate_disparity(est, gt, mask=mask)


def test_result_validates_itself():
    with pytest.raises(InvalidInputError, match="matched_px"):
        DisparityMetrics(evaluated_px=1, matched_px=2, density_pct=100.0, bad1_matched_pct=0.0,
                         bad2_matched_pct=0.0, bad1_all_pct=0.0, bad2_all_pct=0.0, epe_px=0.0,
                         d1_matched_pct=0.0, d1_all_pct=0.0)
