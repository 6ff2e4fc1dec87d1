"""Per-frame wiring of a stream: seeds per frame, tracks, the JSON record, the renumbered pictures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from _stream_frames import FPS, N_FRAMES, SIZE, frames
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.pipeline import detect
from stereo_obstacles.stream_detection import annotate_frame, detect_stream, frame_record, tracked_list
from stereo_obstacles.streams import StereoFrame
from stereo_obstacles.temporal_seeds import TemporalSeedParameters


def _stream():
    return [StereoFrame(k, k / FPS, p.left, p.right, f"f{k}") for k, p in enumerate(frames())]


def test_stream_detection_record_and_pictures():
    temporal = TemporalSeedParameters(refresh_every=3, forward_m_per_frame=0.1, refine_frames=0)
    detections = list(detect_stream(_stream(), frames()[0].calibration, temporal=temporal, in_flight=1))
    assert [d.seeds for d in detections] == ["edge", "temporal", "temporal", "edge"][:N_FRAMES]
    assert detections[0].n_seed_points == 0 and detections[1].n_seed_points > 50
    for detection in detections:
        seen = [t for t in detection.tracks if t.obstacle is not None]
        assert [t.obstacle for t in seen] == list(detection.result.obstacles.obstacles)
        record = json.loads(json.dumps(frame_record(detection), allow_nan=False))
        assert [o["track_id"] for o in record["obstacles"]] == [t.track_id for t in seen]
        assert [o["detection_id"] for o in record["obstacles"]] == [t.obstacle.id for t in seen]
        smoothed = [o[key] for o in record["obstacles"] for key in ("distance_m", "closing_speed_mps")
                    if o[key] is not None]
        assert smoothed and all(v == round(v, 3) for v in smoothed)              # to the mm, not 4.151999999999999
        track_of = {t.obstacle.id: t.track_id for t in seen}
        scan = detection.result.obstacles.scan
        assert record["scan"]["ranges_m"] == list(scan.ranges_m) and any(scan.obstacle_ids)
        assert record["scan"]["obstacle_ids"] == [track_of.get(i) for i in scan.obstacle_ids]

        renamed = tracked_list(detection)
        original = detection.result.obstacles.id_map
        for track in seen:
            assert np.all(renamed.id_map[original == track.obstacle.id] == track.track_id)
        assert np.all(renamed.id_map[original == 0] == 0)
        assert [o.distance_m for o in renamed.obstacles] == [t.distance_m for t in seen]
        assert renamed.scan.obstacle_ids == tuple(record["scan"]["obstacle_ids"])

        picture = annotate_frame(detection)
        assert picture.shape == (SIZE[1], SIZE[0], 3) and picture.dtype == np.uint8
        assert not np.array_equal(picture, detection.frame.left)


def test_frames_in_flight_keep_their_order_and_seed_from_the_latest_finished_frame():
    temporal = TemporalSeedParameters(refresh_every=3, refine_frames=0)
    two = list(detect_stream(_stream(), frames()[0].calibration, temporal=temporal, in_flight=2))
    assert [d.frame.index for d in two] == list(range(N_FRAMES))
    # frame 1 starts before frame 0 is done, so both use edge seeds; frame 2 is seeded by frame 0
    assert [d.seeds for d in two] == ["edge", "edge", "temporal", "temporal"][:N_FRAMES]


def test_frames_in_flight_give_the_same_detections_with_edge_seeds():
    one, three = (list(detect_stream(_stream(), frames()[0].calibration, temporal=None, in_flight=n))
                  for n in (1, 3))
    for a, b in zip(one, three, strict=True):
        np.testing.assert_array_equal(a.result.disparity, b.result.disparity)
        assert a.result.obstacles.obstacles == b.result.obstacles.obstacles
        assert [t.track_id for t in a.tracks] == [t.track_id for t in b.tracks]


def test_closing_the_stream_early_leaves_no_frame_thread():
    import threading

    stream = detect_stream(_stream(), frames()[0].calibration, in_flight=3)
    next(stream)
    stream.close()
    assert not [t for t in threading.enumerate() if t.name.startswith("stream-frame")]


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_bad_in_flight_is_refused(bad):
    with pytest.raises(InvalidInputError, match="in_flight must be an integer >= 1"):
        next(detect_stream(_stream(), None, in_flight=bad))


def test_refined_frames_alternate_with_grown_ones_by_default():
    detections = list(detect_stream(_stream(), frames()[0].calibration, in_flight=1))
    assert [d.seeds for d in detections] == ["edge", "refined", "temporal", "refined"][:N_FRAMES]
    for detection in detections:
        stats = detection.result.match_stats
        assert (stats.growth_seconds == 0.0) == (detection.seeds == "refined")
        assert json.loads(json.dumps(frame_record(detection)))["seeds"] == detection.seeds


def test_a_refined_frame_the_estimate_no_longer_fits_is_grown_again():
    """A jolt: every disparity of the second frame is 6 px larger than the first frame's, beyond
    the refinement's reach; it kept 16 % of the estimate, mostly wrong, and reported it."""
    first = frames()[0]
    jolted = np.roll(first.right, -6, axis=1)
    stream = [StereoFrame(0, 0.0, first.left, first.right, "f0"), StereoFrame(1, 1 / FPS, first.left, jolted, "f1")]
    detections = list(detect_stream(stream, first.calibration, in_flight=1))
    assert [d.seeds for d in detections] == ["edge", "regrown"]
    assert detections[1].result.match_stats.growth_seconds > 0.0            # grown, not refined
    grown_alone = detect(first.left, jolted, first.calibration)
    assert [o.distance_m for o in detections[1].result.obstacles.obstacles] == pytest.approx(
        [o.distance_m for o in grown_alone.obstacles.obstacles], rel=0.02)


def test_a_failing_source_still_delivers_the_frames_already_in_flight():
    def failing():
        yield from _stream()[:3]
        raise OSError("frame 3 cannot be decoded")

    delivered = []
    with pytest.raises(OSError, match="frame 3 cannot be decoded"):
        for detection in detect_stream(failing(), frames()[0].calibration, in_flight=3):
            delivered.append(detection.frame.index)
    assert delivered == [0, 1, 2]


def test_a_calibration_without_an_image_size_is_checked_once_a_stream(caplog):
    # detect warned of it on every frame (review, session 23); the stream sizes it on its first frame
    from dataclasses import replace

    calibration = frames()[0].calibration
    unsized = replace(calibration, width_px=None, height_px=None, cx_px=3 * calibration.cx_px)
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        detections = list(detect_stream(_stream(), unsized, temporal=None, in_flight=2))
    assert caplog.text.count("lies far from the centre of the") == 1
    assert {(d.result.calibration.width_px, d.result.calibration.height_px) for d in detections} == {SIZE}


def test_what_detect_stream_cannot_use_is_refused_by_its_name():
    # tracking=None and (left, right) tuples gave AttributeError from inside (API review, session 23)
    from stereo_obstacles.errors import ImageMismatchError

    calibration = frames()[0].calibration
    for options, message in (({"tracking": None}, "tracking must be a TrackingParameters, got NoneType"),
                             ({"config": None}, "config must be a DetectionConfig, got NoneType"),
                             ({"temporal": {"step_px": 8}}, "temporal must be a TemporalSeedParameters or None")):
        with pytest.raises(InvalidInputError, match=message):
            list(detect_stream(_stream(), calibration, **options))
    pair = frames()[0]
    with pytest.raises(InvalidInputError, match="frames must give StereoFrame objects, got tuple"):
        list(detect_stream([(pair.left, pair.right)], calibration))
    with pytest.raises(InvalidInputError, match="frame 0: left must be an RGB"):
        StereoFrame(0, 0.0, pair.left.tolist(), pair.right, "f0")
    with pytest.raises(InvalidInputError, match="timestamp_s must be a finite number"):
        StereoFrame(0, float("nan"), pair.left, pair.right, "f0")
    with pytest.raises(ImageMismatchError):
        StereoFrame(0, 0.0, pair.left, pair.right[:-1], "f0")
