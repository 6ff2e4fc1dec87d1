"""Figures of docs/rectification.md: rectification quality and GCS accuracy after it.

Run: ``python benchmarks/eval_rectification.py [--data DIR]``. Prints Markdown tables:

* the synthetic default scene (320x240, 1 and 2x2 rays per pixel) with the right camera
  turned by (0.6, -0.4, 0.8) degrees and shifted down 3 px;
* Middlebury 2003 Cones with the right camera turned by (0.3, 0, 1.0) degrees (f = 450 px
  assumed) and shifted down 2.5 px;
* stereo calibration of the OpenCV chessboard sample (13 pairs, 9x6, 25 mm squares).

For each pair: the vertical offset of the exact correspondences after rectification (from
the true cameras), of inlier/consistent SIFT matches, and GCS density and bad-1 over matched
non-occluded pixels against ground truth mapped into the rectified frame, next to the same
figures on the perfect (unturned) pair against its own ground truth.
"""

from __future__ import annotations

import argparse
import glob
import os
from pathlib import Path

from stereo_obstacles.chessboard_calibration import Board, calibrate_pairs
from stereo_obstacles.datasets import load_pair
from stereo_obstacles.disparity_metrics import evaluate_disparity
from stereo_obstacles.fileio import read_image
from stereo_obstacles.matching import match
from stereo_obstacles.rectification import rectify_calibration
from stereo_obstacles.rectification_check import check_rectification
from stereo_obstacles.rectification_evaluation import (rectified_ground_truth, synthetic_camera_pair,
                                                       turn_right_camera)
from stereo_obstacles.synthetic import RenderOptions, RightCameraError, default_scene, render_pair
from stereo_obstacles.uncalibrated_rectification import rectify_uncalibrated

HEADER = ("| pair | rectification | exact vertical offset median / p95 (px) | SIFT matches: median / p95 (px) "
          "| GCS density (%) | GCS bad-1 over matched (%) |\n|---|---|---|---|---|---|")


def _row(name, method, exact, features, metrics) -> str:
    exact_text = "—" if exact is None else f"{exact.median_px:.3f} / {exact.p95_px:.3f}"
    return (f"| {name} | {method} | {exact_text} | {features.median_px:.3f} / {features.p95_px:.3f} | "
            f"{metrics.density_pct:.1f} | {metrics.bad1_matched_pct:.2f} |")


def _evaluate(name, left, right, perfect, gt_perfect, nonocc_perfect, depth, nonocc, calibration, max_disparity):
    rows = []
    checked = check_rectification(perfect[0], perfect[1], warn=False).offsets
    metrics = evaluate_disparity(match(*perfect, max_disparity=max_disparity).disparity, gt_perfect,
                                 mask=nonocc_perfect)
    rows.append(_row(name, "none needed (perfect pair)", None, checked, metrics))
    checked = check_rectification(left, right, warn=False).offsets
    metrics = evaluate_disparity(match(left, right, max_disparity=max_disparity).disparity, gt_perfect,
                                 mask=nonocc_perfect)
    rows.append(_row(name, "none (turned right camera)", None, checked, metrics))
    truth_args = {"camera_matrix_left": calibration.camera_matrix_left,
                  "camera_matrix_right": calibration.camera_matrix_right, "rotation": calibration.rotation,
                  "translation_m": calibration.translation_m}
    for method, rectification in (("calibrated (true R, T, K)", rectify_calibration(calibration)),
                                  ("uncalibrated, quasi-Euclidean", rectify_uncalibrated(left, right)),
                                  ("uncalibrated, Hartley (OpenCV)", rectify_uncalibrated(left, right,
                                                                                          model="hartley"))):
        new_left, new_right = rectification.apply(left, right)
        truth = rectified_ground_truth(rectification, depth, nonocc, **truth_args)
        checked = check_rectification(new_left, new_right, warn=False).offsets
        metrics = evaluate_disparity(match(new_left, new_right, max_disparity=max_disparity).disparity,
                                     truth.disparity, mask=truth.nonocc)
        rows.append(_row(name, method, truth.vertical, checked, metrics))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
    parser.add_argument("--data", type=Path, default=default)
    args = parser.parse_args()

    print(HEADER)
    error = RightCameraError(rotation_deg=(0.6, -0.4, 0.8), vertical_offset_px=3.0)
    for supersample in (1, 2):
        scene = default_scene(320, 240)
        perfect = render_pair(scene, RenderOptions(supersample=supersample))
        pair = render_pair(scene, RenderOptions(supersample=supersample, right_error=error))
        rows = _evaluate(f"synthetic 320x240, {supersample}x{supersample} rays/px", pair.left, pair.right,
                         (perfect.left, perfect.right), perfect.disparity, perfect.nonocc, pair.depth, pair.nonocc,
                         synthetic_camera_pair(pair), None)
        print("\n".join(rows))
    cones = args.data / "middlebury2003_cones"
    if cones.is_dir():
        pair = load_pair(cones)
        right, depth, calibration = turn_right_camera(pair.right, pair.gt_disparity, focal_px=450.0, baseline_m=0.1,
                                                      rotation_deg=(0.3, 0.0, 1.0), shift_px=2.5)
        print("\n".join(_evaluate("Middlebury 2003 Cones", pair.left, right, (pair.left, pair.right),
                                  pair.gt_disparity, pair.nonocc, depth, pair.nonocc, calibration, 60)))
    else:
        print(f"\nSkipped Middlebury: {cones} not found")
    board_dir = args.data / "calibration_examples" / "opencv_stereo_chessboard"
    if board_dir.is_dir():
        pairs = [(Path(left).name, read_image(left, mode="gray"), read_image(left.replace("left", "right"), mode="gray"))
                 for left in sorted(glob.glob(str(board_dir / "left*.jpg")))]
        result = calibrate_pairs(pairs, Board(9, 6, 0.025))
        print(f"\nChessboard calibration: {len(result.used)} of {len(pairs)} pairs, RMS {result.rms_px:.3f} px "
              f"(left {result.rms_left_px:.3f}, right {result.rms_right_px:.3f}), baseline "
              f"{1000 * result.calibration.baseline_m:.1f} mm; epipolar error after rectification: "
              f"{result.epipolar.describe()}")


if __name__ == "__main__":
    main()
