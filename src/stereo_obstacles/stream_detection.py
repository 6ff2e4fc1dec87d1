"""Detection over a stream of stereo frames: temporal seeds, tracking, one JSON record per frame.

:func:`detect_stream` runs :func:`stereo_obstacles.pipeline.detect` on every frame, seeding
the matcher from the previous frame's matches (:mod:`stereo_obstacles.temporal_seeds`) when
asked, and passes the obstacles to an :class:`~stereo_obstacles.tracking.ObstacleTracker`.
:func:`frame_record` turns one frame's outcome into the JSON-ready record that
``stereo-obstacles video --jsonl`` writes as one line; :func:`annotate_frame` draws it.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import cv2
import numpy as np

from stereo_obstacles.calibration import StereoCalibration, sized_for_images
from stereo_obstacles.direction_scan import DirectionScan
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.matching import disparity_range
from stereo_obstacles.obstacle_json import jsonable
from stereo_obstacles.obstacles import ObstacleList
from stereo_obstacles.pictures import draw_obstacles
from stereo_obstacles.pipeline import DetectionConfig, DetectionResult, detect
from stereo_obstacles.streams import StereoFrame
from stereo_obstacles.temporal_seeds import TemporalSeeder, TemporalSeedParameters
from stereo_obstacles.tracking import ObstacleTracker, Track, TrackingParameters

__all__ = ["IN_FLIGHT", "MIN_REFINED_SHARE", "STREAM_FORMAT", "FrameDetection", "annotate_frame", "detect_stream", "frame_record",
           "header_record", "tracked_list"]

STREAM_FORMAT = "stereo-obstacles/stream"
"""``format`` of the header line of a JSON-lines stream file."""


@dataclass(frozen=True, eq=False)
class FrameDetection:
    """What the stream detection found in one frame.

    Attributes
    ----------
    frame : StereoFrame
    result : DetectionResult
    tracks : tuple of Track
        Tracks seen in this frame first (in the order of ``result.obstacles.obstacles``,
        nearest first), then tracks missed in this frame.
    seeds : str
        What seeded the matcher: ``"edge"``, ``"temporal"`` (the previous frame's matches),
        ``"refined"`` (the previous frame's disparity refined, no growth; see
        :class:`~stereo_obstacles.temporal_seeds.TemporalSeedParameters`), or ``"regrown"``
        (a refined frame whose refinement kept less than :data:`MIN_REFINED_SHARE` of its
        estimate, matched again from edge seeds).
    n_seed_points : int
        Temporal seed points passed to the matcher (0 for edge seeds and refined frames).
    """

    frame: StereoFrame
    result: DetectionResult
    tracks: tuple[Track, ...]
    seeds: str
    n_seed_points: int


MIN_REFINED_SHARE = 0.8
"""A refined frame whose matches cover less than this share of the estimate's pixels is grown
again from edge seeds: the estimate no longer fits the frame (a fast turn, a cut in the video),
and what the refinement kept is mostly wrong. On the synthetic walk the share is 0.98 at
0.05 m per frame, 0.84-0.94 at 0.3 m (bad-1 0.9-2.8 %), 0.69-0.87 at 0.6 m (bad-1 2-5 %); an
estimate 5 px off keeps 0.13 of its pixels, 97 % of them wrong."""

IN_FLIGHT = 3
"""Default number of frames :func:`detect_stream` detects at once (``docs/streams.md``, "Frames in
flight": on two cores, a frame's single-threaded stages overlap the other frames' matching; 3
delivered 18.4 frames per second on the synthetic walk against 16.2 with 2 and 11.5 with 1, at a
latency of 160 ms against 112 and 85 ms)."""


def detect_stream(frames: Iterable[StereoFrame], calibration: StereoCalibration | None, *,
                  config: DetectionConfig = DetectionConfig(),
                  temporal: TemporalSeedParameters | None = TemporalSeedParameters(),
                  tracking: TrackingParameters = TrackingParameters(),
                  in_flight: int = IN_FLIGHT) -> Iterator[FrameDetection]:
    """Detect obstacles in every frame of a stream and track them.

    Parameters
    ----------
    frames : iterable of StereoFrame
        Rectified pairs in time order (timestamps increasing).
    calibration : StereoCalibration, optional
        Calibration of every frame; without it there are no metres (tracks by box overlap).
    config : DetectionConfig
        Options of the pipeline.
    temporal : TemporalSeedParameters or None
        Seed each frame from the previous one; ``None`` always uses the edge seeds.
    tracking : TrackingParameters
    in_flight : int
        Frames detected at once in worker threads (>= 1), yielded in order. With ``n``, the
        temporal seeds of a frame come from the frame ``n`` before it (the latest one
        finished), moved by ``n`` times the forward motion per frame.

    Yields
    ------
    FrameDetection
    """
    if not isinstance(in_flight, int) or isinstance(in_flight, bool) or in_flight < 1:
        raise InvalidInputError(f"in_flight must be an integer >= 1, got {in_flight!r}")
    for name, value, kind in (("config", config, DetectionConfig), ("tracking", tracking, TrackingParameters)):
        if not isinstance(value, kind):
            raise InvalidInputError(f"{name} must be a {kind.__name__}, got {type(value).__name__}")
    if temporal is not None and not isinstance(temporal, TemporalSeedParameters):
        raise InvalidInputError(f"temporal must be a TemporalSeedParameters or None, got {type(temporal).__name__}")
    seeder = TemporalSeeder(temporal, calibration) if temporal is not None else None
    tracker = ObstacleTracker(tracking)
    later_frames = replace(config, check_rectification=False)  # the rig does not change between frames
    frames = iter(frames)
    pending: deque = deque()  # (frame, future, what seeded it, seed points) in frame order

    def start(pool: ThreadPoolExecutor, frame: StereoFrame | None, first: bool) -> None:
        nonlocal calibration
        if frame is None:
            return
        if not isinstance(frame, StereoFrame):        # a (left, right) tuple, a dataset's StereoPair
            raise InvalidInputError(f"frames must give StereoFrame objects, got {type(frame).__name__}")
        if first and calibration is not None:   # checked and sized once: detect would warn of it every frame
            calibration = sized_for_images(calibration, frame.left.shape[1], frame.left.shape[0])
        estimate = seeder.estimate() if seeder is not None else None
        points = seeder.seeds() if seeder is not None and estimate is None else None
        seeds = "refined" if estimate is not None else "edge" if points is None else "temporal"
        pending.append((frame, pool.submit(detect, frame.left, frame.right, calibration,
                                           config=config if first else later_frames, seed_points=points,
                                           disparity_estimate=estimate),
                        seeds, 0 if points is None else len(points), estimate))

    source_error: Exception | None = None

    def read() -> StereoFrame | None:
        """The next frame; after the source failed, none (its error is raised once the frames
        already in flight are delivered)."""
        nonlocal source_error
        if source_error is not None:
            return None
        try:
            return next(frames, None)
        except Exception as exc:  # noqa: BLE001 - re-raised below, after the frames in flight
            source_error = exc
            return None

    with ThreadPoolExecutor(max_workers=in_flight, thread_name_prefix="stream-frame") as pool:
        try:
            for k in range(in_flight):
                start(pool, read(), first=k == 0)
            while pending:
                upcoming = read()  # read (decode) it while the frames in flight are detected
                frame, future, seeds, n_seed_points, estimate = pending.popleft()
                result = future.result()
                if seeds == "refined" and _refined_share(result.disparity, estimate) < MIN_REFINED_SHARE:
                    result, seeds = detect(frame.left, frame.right, calibration, config=later_frames), "regrown"
                if seeder is not None:
                    d_min, d_max = disparity_range(frame.left.shape[1], 0, config.matching.max_disparity)
                    seeder.observe(result.disparity, d_min=d_min, d_max=d_max, frames_ahead=in_flight,
                                   refined=seeds == "refined")
                start(pool, upcoming, first=False)  # at once: tracking and the caller's work overlap it
                tracks = tracker.update(result.obstacles.obstacles, frame.timestamp_s)
                yield FrameDetection(frame, result, tuple(tracks), seeds, n_seed_points)
            if source_error is not None:
                raise source_error
        finally:  # stopped early: frames still queued are dropped, a running one ends in its thread
            for _, future, _, _, _ in pending:
                future.cancel()


def _refined_share(disparity: np.ndarray, estimate: np.ndarray) -> float:
    """Matched pixels of a refined frame per pixel of its estimate (1.0 for an empty estimate)."""
    n_estimated = int(np.count_nonzero(np.isfinite(estimate)))
    return np.count_nonzero(np.isfinite(disparity)) / n_estimated if n_estimated else 1.0


def header_record(*, source: str, calibration: StereoCalibration | None, config: DetectionConfig,
                  temporal: TemporalSeedParameters | None, tracking: TrackingParameters,
                  rectification: dict | None = None) -> dict:
    """The first line of a stream file: format, version, units, source, calibration (of the
    rectified frames), how the frames were rectified (``rectification``: ``None`` when they came
    rectified), options."""
    from stereo_obstacles import __version__

    return {"type": "header", "format": STREAM_FORMAT, "version": 1, "package_version": __version__,
            "units": "metres" if calibration is not None else "pixels",
            "frame": "rectified left camera: x right, y down, z forward",
            "source": source, "calibration": calibration.to_dict() if calibration is not None else None,
            "rectification": rectification, "config": jsonable(config.to_dict()),
            "temporal_seeds": jsonable(temporal) if temporal is not None else None,
            "tracking": jsonable(tracking)}


def frame_record(detection: FrameDetection) -> dict:
    """One frame as a JSON-ready dict: index, time, seeds, timings, tracked obstacles and the
    free range per direction.

    Each obstacle has its stable ``track_id``, the smoothed ``distance_m``, the
    ``measured_distance_m`` of this frame, ``closing_speed_mps``, ``time_to_contact_s``,
    ``approaching``, and the detection's fields (box, centre, size, confidence). Tracks missed
    in this frame are listed under ``missed`` with their predicted distance. ``scan`` is the
    frame's :class:`~stereo_obstacles.direction_scan.DirectionScan` (measured, not smoothed) with
    track ids for its ``obstacle_ids``; ``None`` without a calibration.
    """
    obstacles, missed = [], []
    for track in detection.tracks:
        entry = {"track_id": track.track_id, "distance_m": _rounded(track.distance_m),
                 "closing_speed_mps": _rounded(track.closing_speed_mps),
                 "time_to_contact_s": _rounded(track.time_to_contact_s),
                 "approaching": track.approaching, "age_frames": track.age_frames}
        if track.obstacle is None:
            missed.append({**entry, "missed_frames": track.missed_frames})
            continue
        detected = dataclasses.asdict(track.obstacle)
        detected["measured_distance_m"] = detected.pop("distance_m")
        detected["detection_id"] = detected.pop("id")
        obstacles.append({**entry, **detected})
    return jsonable({"type": "frame", "frame": detection.frame.index, "timestamp_s": detection.frame.timestamp_s,
                      "name": detection.frame.name, "seeds": detection.seeds,
                      "n_seed_points": detection.n_seed_points, "density": detection.result.density,
                      "timings_s": detection.result.timings_s, "obstacles": obstacles, "missed": missed,
                      "scan": _tracked_scan(detection, _track_ids(detection))})


def _rounded(value: float | None) -> float | None:
    """A smoothed value as the record shows it: to the millimetre (or ms, mm/s), as detections are."""
    return None if value is None else round(float(value), 3)


def _track_ids(detection: FrameDetection) -> np.ndarray:
    """``int32``: the track id of each detection id of the frame (0: none)."""
    lookup = np.zeros(max((o.id for o in detection.result.obstacles.obstacles), default=0) + 1, np.int32)
    for track in detection.tracks:
        if track.obstacle is not None:
            lookup[track.obstacle.id] = track.track_id
    return lookup


def _tracked_scan(detection: FrameDetection, track_ids: np.ndarray) -> DirectionScan | None:
    """The frame's scan with track ids (None without a calibration)."""
    scan = detection.result.obstacles.scan
    return None if scan is None else scan.renumbered(track_ids)


def tracked_list(detection: FrameDetection) -> ObstacleList:
    """The frame's obstacles renumbered by track id, distances smoothed (for pictures)."""
    obstacle_list = detection.result.obstacles
    lookup = _track_ids(detection)
    renamed = [dataclasses.replace(track.obstacle, id=track.track_id, distance_m=track.distance_m)
               for track in detection.tracks if track.obstacle is not None]
    corridor = obstacle_list.corridor
    if corridor is not None and corridor.nearest_obstacle_id is not None:
        corridor = dataclasses.replace(corridor, nearest_obstacle_id=int(lookup[corridor.nearest_obstacle_id]))
    id_map = np.asarray(obstacle_list.id_map)
    return ObstacleList(tuple(renamed), lookup[np.clip(id_map, 0, len(lookup) - 1)], obstacle_list.rejected,
                        corridor, _tracked_scan(detection, lookup))


def annotate_frame(detection: FrameDetection) -> np.ndarray:
    """The left image with tracked obstacles drawn and a status line; ``uint8 (H, W, 3)`` RGB.

    The size is the frame's own (a video needs one size): boxes and captions as in
    :func:`~stereo_obstacles.pictures.draw_obstacles` with track ids and smoothed distances,
    and at the top the frame index and the nearest approaching obstacle with its time to contact.
    """
    left = detection.frame.left
    h, w = left.shape[:2]
    calibrated = detection.result.calibration is not None
    picture = np.ascontiguousarray(draw_obstacles(left, tracked_list(detection), calibrated=calibrated)[:h, :w])
    status = f"frame {detection.frame.index}  {len(detection.result.obstacles.obstacles)} obstacles"
    approaching = [t for t in detection.tracks if t.approaching and t.obstacle is not None]
    if approaching:
        nearest = min(approaching, key=lambda t: t.distance_m)
        status += (f"  APPROACHING #{nearest.track_id} {nearest.distance_m:.1f} m, "
                   f"contact in {nearest.time_to_contact_s:.1f} s")
    scale = max(0.35, h / 960)
    origin = (4, int(18 * scale / 0.5))
    cv2.putText(picture, status, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(picture, status, origin, cv2.FONT_HERSHEY_SIMPLEX, scale,
                (255, 80, 60) if approaching else (255, 255, 255), 1, cv2.LINE_AA)
    return picture
