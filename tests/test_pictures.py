"""Pictures: obstacle overlay, labels with legend, disparity and depth with colour bars."""

from __future__ import annotations

import numpy as np
import pytest
from _obstacle_scene import detection

from stereo_obstacles.colorize import colorize_depth, colorize_disparity
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.labels import LABEL_COLOURS_RGB, Label, colorize_labels
from stereo_obstacles.obstacles import Obstacle, ObstacleList
from stereo_obstacles.direction_scan import DirectionScan
from stereo_obstacles.pictures import (
    FREE_RGB, MIN_PANEL_WIDTH_PX, REJECTED_COLOUR_RGB, SCAN_PICTURE_SIZE_PX, TINT_ALPHA, UNSEEN_RGB, depth_picture,
    describe_detection, disparity_picture, draw_obstacles, labels_picture, obstacle_colour, scan_picture)

DETECTION = detection()


def test_obstacle_pixels_are_tinted_in_their_colour_and_others_are_untouched():
    picture = draw_obstacles(DETECTION.left, DETECTION.calibrated, calibrated=True)
    h, w = DETECTION.left.shape[:2]
    assert picture.dtype == np.uint8 and picture.shape[1] == w and picture.shape[0] > h
    image = picture[:h]
    box = DETECTION.calibrated.obstacles[0]
    x0, y0, x1, y1 = box.box_px
    cx, cy = (x0 + x1) // 2, (y0 + y1) // 2
    assert DETECTION.calibrated.id_map[cy, cx] == 1
    expected = np.rint((1 - TINT_ALPHA) * DETECTION.left[cy, cx] + TINT_ALPHA * np.array(obstacle_colour(1)))
    np.testing.assert_array_equal(image[cy, cx], expected)
    np.testing.assert_array_equal(image[h // 2, w - 3], DETECTION.left[h // 2, w - 3])  # ground, far from all


def test_boxes_are_drawn_in_obstacle_colours_and_rejected_in_grey():
    image = draw_obstacles(DETECTION.left, DETECTION.calibrated, calibrated=True)[:DETECTION.left.shape[0]]
    for obstacle in DETECTION.calibrated.obstacles:
        x0, y0, x1, y1 = obstacle.box_px
        bottom_edge = image[y1 - 1, x0 + 2:x1 - 2]
        assert (bottom_edge == obstacle_colour(obstacle.id)).all(axis=1).mean() > 0.5
    x0, y0, x1, y1 = DETECTION.calibrated.rejected[0].box_px
    assert (image[y1 - 1, x0:x1] == REJECTED_COLOUR_RGB).all()


def test_caption_panel_differs_between_calibrated_and_pixels():
    h = DETECTION.left.shape[0]
    metres = draw_obstacles(DETECTION.left, DETECTION.calibrated, calibrated=True)
    pixels = draw_obstacles(DETECTION.left, DETECTION.uncalibrated, calibrated=False)
    assert (metres[h:] != metres[h, 0]).any()  # the panel holds text
    assert not np.array_equal(metres[h:], pixels[h:])
    assert not np.array_equal(metres[:h], pixels[:h])  # "4.00 m" against "d=10.5 px"


def test_description_names_nearest_corridor_units_and_rejections():
    metres = describe_detection(DETECTION.calibrated, True)
    pixels = describe_detection(DETECTION.uncalibrated, False)
    assert metres == ["3 obstacles, nearest #1 4.00 m", "1 m corridor: free 4.00 m to #1",
                      "1 rejected (thin boxes without caption)"]
    assert pixels[0] == "3 obstacles, nearest #1 d=10.5 px" and "no calibration" in pixels[1]
    assert pixels[1].endswith("larger is nearer")
    local = describe_detection(DETECTION.uncalibrated, False, nearer_by_disparity=False)   # --uncalibrated
    assert local[1] == "no calibration: d = disparity in px, larger is nearer only between obstacles close together"
    panel = draw_obstacles(DETECTION.left, DETECTION.uncalibrated, calibrated=False, nearer_by_disparity=False)
    h = DETECTION.left.shape[0]
    assert not np.array_equal(panel[h:], draw_obstacles(DETECTION.left, DETECTION.uncalibrated, calibrated=False)[h:])


def test_grey_left_image_is_accepted_and_mismatched_sizes_are_refused():
    grey = DETECTION.left[..., 1]
    assert draw_obstacles(grey, DETECTION.calibrated, calibrated=True).ndim == 3
    with pytest.raises(InvalidInputError, match="id_map is \\(240, 320\\), the left image \\(240, 300\\)"):
        draw_obstacles(DETECTION.left[:, :300], DETECTION.calibrated, calibrated=True)
    with pytest.raises(InvalidInputError, match="left_rgb must be uint8"):
        draw_obstacles(DETECTION.left.astype(np.float32), DETECTION.calibrated, calibrated=True)


def test_labels_picture_shows_label_colours_and_a_legend_of_present_labels():
    picture = labels_picture(DETECTION.labels)
    h, w = DETECTION.labels.shape
    np.testing.assert_array_equal(picture[:h, :w], colorize_labels(DETECTION.labels))
    legend = picture[h:]
    assert legend.shape[0] > 10
    for label in (Label.GROUND, Label.SHADOW, Label.OBSTACLE, Label.SKY):  # present: a swatch in the legend
        assert (legend == LABEL_COLOURS_RGB[label]).all(axis=2).sum() > 20
    assert (legend == LABEL_COLOURS_RGB[Label.MARKING]).all(axis=2).sum() == 0  # absent: not listed


def test_narrow_labels_picture_is_padded_to_the_legend_width():
    picture = labels_picture(np.full((10, 20), Label.GROUND, np.uint8))
    assert picture.shape[1] == MIN_PANEL_WIDTH_PX
    assert (picture[:10, 20:] == 0).all()
    with pytest.raises(InvalidInputError, match="labels must be uint8"):
        labels_picture(np.zeros((4, 4), np.int32))


def _count(picture: np.ndarray, rgb: np.ndarray) -> int:
    return int((picture == rgb.reshape(1, 1, 3)).all(axis=2).sum())


def test_disparity_picture_uses_the_given_range_and_shows_both_ends_in_the_bar():
    d = DETECTION.disparity
    h, w = d.shape
    picture = disparity_picture(d, vmin=2.0, vmax=12.0)
    assert picture.dtype == np.uint8 and picture.shape[1] == w and picture.shape[0] > h + 20
    np.testing.assert_array_equal(picture[:h], colorize_disparity(d, vmin=2.0, vmax=12.0))
    assert (picture[:h][np.isnan(d)] == 0).all()
    ends = colorize_disparity(np.array([[2.0, 12.0]], np.float32), vmin=2.0, vmax=12.0)[0]
    bar = picture[h:]
    assert _count(bar, ends[0]) > 10 and _count(bar, ends[1]) > 10


def test_disparity_picture_default_range_is_rounded_out_to_whole_pixels():
    d = np.linspace(3.3, 20.7, 40 * 60, dtype=np.float32).reshape(40, 60)
    d[0, :5] = np.nan
    picture = disparity_picture(d)
    np.testing.assert_array_equal(picture[:40, :60], colorize_disparity(d, vmin=3.0, vmax=21.0))
    assert disparity_picture(np.full((5, 5), np.nan, np.float32)).shape[1] == MIN_PANEL_WIDTH_PX  # all invalid


def test_depth_picture_default_range_is_a_round_number_above_most_depths():
    z = np.linspace(1.0, 8.6, 50 * 80, dtype=np.float32).reshape(50, 80)
    z[10, 10] = np.nan
    picture = depth_picture(z)  # 75th percentile 6.7 m rounds up to 8 m
    np.testing.assert_array_equal(picture[:50, :80], colorize_depth(z, 8.0))
    np.testing.assert_array_equal(depth_picture(z, max_m=20.0)[:50, :80], colorize_depth(z, 20.0))
    assert (picture[10, 10] == 0).all()


@pytest.mark.parametrize("call, message", [
    (lambda: disparity_picture(np.zeros((4, 4), np.int16)), "disparity must be a float"),
    (lambda: disparity_picture(np.zeros((4, 4), np.float32), vmin=5.0, vmax=5.0), "maximum above the minimum"),
    (lambda: depth_picture(np.ones((4, 4, 3), np.float32)), "depth_m must be a float"),
    (lambda: depth_picture(np.ones((4, 4), np.float32), max_m=-1.0), "maximum above the minimum"),
])
def test_bad_maps_and_ranges(call, message):
    with pytest.raises(InvalidInputError, match=message):
        call()


def _stacked(count: int) -> ObstacleList:
    """``count`` obstacles sharing one box in a 120 x 160 image."""
    id_map = np.zeros((120, 160), np.int32)
    id_map[40:80, 60:100] = 1
    obstacles = tuple(Obstacle(id=i, box_px=(60, 40, 100, 80), pixel_count=1600, disparity_px=30.0 - i,
                               confidence=0.9) for i in range(1, count + 1))
    return ObstacleList(obstacles=obstacles, id_map=id_map)


def test_captions_that_find_no_room_are_left_out_and_counted():
    left = np.full((120, 160, 3), 90, np.uint8)
    three = draw_obstacles(left, _stacked(3), calibrated=False)    # above, inside and below the box
    many = draw_obstacles(left, _stacked(30), calibrated=False)
    np.testing.assert_array_equal(three[:120], many[:120])  # the same three places hold captions
    assert many.shape[0] > three.shape[0]                    # plus a line saying how many were left out


def test_the_scan_seen_from_above_is_free_up_to_each_arc_and_grey_where_nothing_was_reported():
    # sectors of 10 deg from -30: obstacle 1 4 m away at 0..10 deg, nothing at -30..-20; rings every 2 m
    scan = DirectionScan(sector_deg=10.0, first_bearing_deg=-30.0, field_of_view_deg=(-30.0, 30.0),
                         ranges_m=(None, 6.0, 6.0, 4.0, 6.0, 6.0),
                         obstacle_ids=(None, 2, 2, 1, 2, 2))
    picture = scan_picture(scan, max_range_m=8.0)
    width, height = SCAN_PICTURE_SIZE_PX
    assert picture.shape[1] == width and picture.shape[0] > height                 # the view and its legend
    view = picture[:height]
    origin_x, origin_y = width / 2, height - 12
    px_per_m = (height - 24) / 8.0

    def pixel(bearing_deg, range_m):
        b = np.radians(bearing_deg)
        return view[int(round(origin_y - px_per_m * range_m * np.cos(b))), int(round(origin_x + px_per_m * range_m * np.sin(b)))]

    assert tuple(pixel(5.0, 2.9)) == FREE_RGB and tuple(pixel(5.0, 4.6)) != FREE_RGB   # free before the arc only
    assert tuple(pixel(5.0, 4.0)) == obstacle_colour(1) and tuple(pixel(-15.0, 6.0)) == obstacle_colour(2)
    assert tuple(pixel(-25.0, 3.0)) == UNSEEN_RGB and tuple(pixel(-25.0, 7.5)) == UNSEEN_RGB
    assert tuple(pixel(-35.0, 3.0)) == (32, 32, 32)                                   # outside the field of view
    assert scan_picture(scan).shape == picture.shape                                  # the default range: 6 m rounded up
    wide = DirectionScan(sector_deg=45.0, first_bearing_deg=-45.0, field_of_view_deg=(-30.0, 30.0),
                         ranges_m=(4.0, None), obstacle_ids=(1, None))
    view = scan_picture(wide, max_range_m=8.0)[:height]
    assert tuple(pixel(-15.0, 3.9)) == FREE_RGB                    # the wedge follows its arc, not the chord (3.86 m)
    assert tuple(pixel(-35.0, 3.0)) == (32, 32, 32)                # a sector is drawn within the field of view only
    with pytest.raises(InvalidInputError, match="scan range must be finite"):
        scan_picture(scan, max_range_m=0.0)
