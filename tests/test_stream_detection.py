"""Per-frame wiring of a stream: seeds per frame, tracks, the JSON record, the renumbered pictures."""

from __future__ import annotations

import json

import numpy as np

from _stream_frames import FPS, N_FRAMES, SIZE, frames
from stereo_obstacles.stream_detection import annotate_frame, detect_stream, frame_record, tracked_list
from stereo_obstacles.streams import StereoFrame
from stereo_obstacles.temporal_seeds import TemporalSeedParameters


def _stream():
    return [StereoFrame(k, k / FPS, p.left, p.right, f"f{k}") for k, p in enumerate(frames())]


def test_stream_detection_record_and_pictures():
    temporal = TemporalSeedParameters(refresh_every=3, forward_m_per_frame=0.1)
    detections = list(detect_stream(_stream(), frames()[0].calibration, temporal=temporal))
    assert [d.seeds for d in detections] == ["edge", "temporal", "temporal", "edge"][:N_FRAMES]
    assert detections[0].n_seed_points == 0 and detections[1].n_seed_points > 50
    for detection in detections:
        seen = [t for t in detection.tracks if t.obstacle is not None]
        assert [t.obstacle for t in seen] == list(detection.result.obstacles.obstacles)
        record = json.loads(json.dumps(frame_record(detection), allow_nan=False))
        assert [o["track_id"] for o in record["obstacles"]] == [t.track_id for t in seen]
        assert [o["detection_id"] for o in record["obstacles"]] == [t.obstacle.id for t in seen]

        renamed = tracked_list(detection)
        original = detection.result.obstacles.id_map
        for track in seen:
            assert np.all(renamed.id_map[original == track.obstacle.id] == track.track_id)
        assert np.all(renamed.id_map[original == 0] == 0)
        assert [o.distance_m for o in renamed.obstacles] == [t.distance_m for t in seen]

        picture = annotate_frame(detection)
        assert picture.shape == (SIZE[1], SIZE[0], 3) and picture.dtype == np.uint8
        assert not np.array_equal(picture, detection.frame.left)
