"""Obstacles across frames: stable ids, smoothed distances, approaching obstacles flagged.

A detection numbers its obstacles nearest first, so the same object changes number from frame
to frame and its measured distance jitters by a few per cent. :class:`ObstacleTracker` keeps
tracks:

* **association** — each frame's obstacles are matched greedily, best pair first, to the
  existing tracks. A pair qualifies when the 3-D centres (the track's moved by its predicted
  change of distance) are within ``max_centre_jump_m``, or when the image boxes overlap with
  an intersection over union of at least ``min_iou``; its cost is the smaller of
  ``jump / max_centre_jump_m`` and ``1 - IoU``. Either cue alone is fragile: the centre of
  an object that the detector merges with its neighbour in one frame jumps by a metre, while
  its box still overlaps. A pair by boxes also needs the obstacle's distance within
  ``max_distance_change`` of the track's predicted or last one (as a fraction of the predicted
  one; at least ``max_centre_jump_m``): a box over a far tree and one over a near car overlap
  too, and one such pair made a track close at 670 m/s. Unmatched obstacles start new tracks; a track not
  seen for more than ``max_missed_frames`` frames ends.
* **smoothing** — an alpha-beta filter (a steady-state 1-D constant-velocity Kalman filter)
  on the distance: ``predicted = z + v dt``, ``z = predicted + alpha r``, ``v = v + beta r / dt``
  with the residual ``r = measured - predicted``; the velocity starts from the difference of
  the first two measurements (starting at 0 would take ~1/beta frames to notice an approach).
* **approach** — closing speed ``-v`` (m/s, positive when the obstacle comes nearer — which
  includes static obstacles a walking user approaches); a track at least ``min_age_frames``
  old closing faster than ``min_closing_speed_mps`` is *approaching*, with a time to contact
  ``distance / closing speed``.

Without a calibration there are no distances: tracks keep ids by box overlap only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive, is_finite_real
from stereo_obstacles.obstacles import Obstacle, ObstacleList

__all__ = ["ObstacleTracker", "Track", "TrackingParameters", "box_iou_matrix"]


@dataclass(frozen=True)
class TrackingParameters:
    """Options of :class:`ObstacleTracker`.

    Attributes
    ----------
    max_centre_jump_m : float
        Largest distance in metres between a track's predicted 3-D centre and an obstacle's
        centre for the two to be associated.
    min_iou : float
        Smallest box overlap (intersection over union, in (0, 1]) for an association by boxes.
    max_distance_change : float
        Largest change of distance from the track's predicted or last distance, as a fraction of
        the predicted one (at least ``max_centre_jump_m``), for an association by boxes.
    alpha, beta : float
        Gains of the alpha-beta filter on distance (0 < alpha <= 1, 0 <= beta <= 2).
    max_missed_frames : int
        A track survives this many frames without a detection (it is then reported with
        ``missed_frames > 0``, its distance predicted).
    min_age_frames : int
        Frames a track needs before it may be flagged approaching (no warning from a
        single noisy measurement).
    min_closing_speed_mps : float
        Closing speed in m/s above which a track is approaching.
    """

    max_centre_jump_m: float = 1.0
    min_iou: float = 0.2
    max_distance_change: float = 0.3
    alpha: float = 0.5
    beta: float = 0.1
    max_missed_frames: int = 3
    min_age_frames: int = 3
    min_closing_speed_mps: float = 0.2

    def __post_init__(self) -> None:
        check_positive(self, ("max_centre_jump_m", "min_iou", "alpha"))
        check_numbers(self, (("min_iou", 0.0, 1.0), ("alpha", 0.0, 1.0), ("beta", 0.0, 2.0),
                             ("max_distance_change", 0.0, math.inf),
                             ("min_closing_speed_mps", 0.0, math.inf)))
        check_integers(self, (("max_missed_frames", 0, math.inf), ("min_age_frames", 0, math.inf)))


@dataclass(frozen=True)
class Track:
    """The state of one tracked obstacle after a frame.

    Attributes
    ----------
    track_id : int
        Stable id, 1, 2, ... in order of first appearance.
    obstacle : Obstacle or None
        This frame's detection, ``None`` when the track was missed in this frame.
    distance_m : float or None
        Smoothed distance in metres (predicted when missed), at least 0; ``None`` without a
        calibration.
    closing_speed_mps : float or None
        Speed at which the distance shrinks, m/s (negative: receding).
    time_to_contact_s : float or None
        ``distance_m / closing_speed_mps`` while approaching (0 once a missed track's predicted
        distance has reached zero), else ``None``.
    approaching : bool
        Old enough and closing faster than the threshold.
    age_frames : int
        Frames since the track started (1 in its first frame).
    missed_frames : int
        Consecutive frames without a detection.
    """

    track_id: int
    obstacle: Obstacle | None
    distance_m: float | None
    closing_speed_mps: float | None
    time_to_contact_s: float | None
    approaching: bool
    age_frames: int
    missed_frames: int


def box_iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union of every ``(x0, y0, x1, y1)`` box of ``a`` (shape (N, 4)) with every
    box of ``b`` (shape (M, 4)), x1 and y1 exclusive: an (N, M) array.

    >>> box_iou_matrix(np.array([[0, 0, 10, 10]]), np.array([[5, 0, 15, 10], [20, 20, 30, 30]]))
    array([[0.33333333, 0.        ]])
    """
    iw = np.minimum(a[:, None, 2], b[None, :, 2]) - np.maximum(a[:, None, 0], b[None, :, 0])
    ih = np.minimum(a[:, None, 3], b[None, :, 3]) - np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.where((iw > 0) & (ih > 0), iw * ih, 0.0)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    return inter / (area_a[:, None] + area_b[None, :] - inter)


class _State:
    """Mutable filter state of one track."""

    def __init__(self, track_id: int, obstacle: Obstacle, time_s: float) -> None:
        self.track_id = track_id
        self.obstacle = obstacle
        self.box = obstacle.box_px
        self.centre = np.asarray(obstacle.centre_m) if obstacle.centre_m is not None else None
        self.distance = obstacle.distance_m
        self.velocity = 0.0
        self.time_s = time_s
        self.age = 1
        self.missed = 0

    def predicted_distance(self, time_s: float) -> float | None:
        if self.distance is None:
            return None
        return self.distance + self.velocity * (time_s - self.time_s)

    def predicted_centre(self, time_s: float) -> np.ndarray | None:
        if self.centre is None:
            return None
        predicted = self.predicted_distance(time_s)
        if predicted is None or self.distance is None:
            return self.centre
        return self.centre + np.array([0.0, 0.0, predicted - self.distance])


class ObstacleTracker:
    """Tracks obstacles over a sequence of detections; feed it frame by frame.

    Parameters
    ----------
    params : TrackingParameters

    Examples
    --------
    >>> from stereo_obstacles.obstacles import Obstacle
    >>> tracker = ObstacleTracker()
    >>> def seen(z):
    ...     return Obstacle(id=1, box_px=(10, 10, 20, 30), pixel_count=100, disparity_px=10.0,
    ...                     confidence=1.0, distance_m=z, centre_m=(0.0, 0.0, z))
    >>> [tracker.update([seen(5.0 - 0.1 * k)], k * 0.1)[0].track_id for k in range(5)]
    [1, 1, 1, 1, 1]
    >>> tracker.update([seen(4.4)], 0.6)[0].approaching
    True
    """

    def __init__(self, params: TrackingParameters = TrackingParameters()) -> None:
        if not isinstance(params, TrackingParameters):
            raise InvalidInputError(f"params must be a TrackingParameters, got {type(params).__name__}")
        self.params = params
        self._tracks: list[_State] = []
        self._next_id = 1
        self._last_time_s: float | None = None

    def update(self, obstacles, time_s: float) -> list[Track]:
        """Associate one frame's obstacles with the tracks and return every live track.

        Parameters
        ----------
        obstacles : sequence of Obstacle, or ObstacleList
            This frame's detections (any order); an ``ObstacleList`` gives its ``obstacles``.
        time_s : float
            Time of the frame in seconds; must increase from frame to frame.

        Returns
        -------
        list of Track
            Tracks seen in this frame first (in the order of ``obstacles``), then tracks
            missed in this frame.

        Raises
        ------
        InvalidInputError
            ``time_s`` is not finite or does not increase.
        """
        if not is_finite_real(time_s):
            raise InvalidInputError(f"time_s must be a finite number of seconds, got {time_s!r}")
        if isinstance(obstacles, ObstacleList):          # a detection's list, not its obstacles: take them
            obstacles = obstacles.obstacles
        if self._last_time_s is not None and time_s <= self._last_time_s:
            raise InvalidInputError(f"time_s must increase: {time_s} after {self._last_time_s}")
        self._last_time_s = time_s
        obstacles = list(obstacles)
        pairs = self._associate(obstacles, time_s)
        seen: list[Track] = []
        for index, obstacle in enumerate(obstacles):
            if index in pairs:
                state = pairs[index][0]
                self._correct(state, obstacle, time_s)
            else:
                state = _State(self._next_id, obstacle, time_s)
                self._next_id += 1
                self._tracks.append(state)
            seen.append(self._report(state, obstacle))
        missed: list[Track] = []
        for state in self._tracks:
            if state.time_s == time_s:
                continue
            state.missed += 1
            state.age += 1
            if state.missed <= self.params.max_missed_frames:
                missed.append(self._report(state, None, time_s))
        self._tracks = [s for s in self._tracks if s.missed <= self.params.max_missed_frames]
        return seen + missed

    def _associate(self, obstacles: list[Obstacle], time_s: float) -> dict[int, tuple[_State, float]]:
        """Greedy best-first pairs ``{obstacle index: (track, cost)}`` within the gates.

        The cost of a track and an obstacle is the smaller of ``jump / max_centre_jump_m`` (3-D
        centre distance, when both have a centre and it is within the gate) and ``1 - IoU`` of
        their boxes (when the IoU reaches ``min_iou``); pairs with neither are not candidates.
        All pairs at once with NumPy (a stream has tens of tracks and obstacles per frame).
        """
        if not self._tracks or not obstacles:
            return {}
        nan3 = (np.nan, np.nan, np.nan)
        track_centres = np.array([c if (c := s.predicted_centre(time_s)) is not None else nan3
                                  for s in self._tracks], dtype=np.float64)
        centres = np.array([o.centre_m if o.centre_m is not None else nan3 for o in obstacles], dtype=np.float64)
        jump = np.sqrt(((track_centres[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2))
        jump_cost = np.where(jump <= self.params.max_centre_jump_m, jump / self.params.max_centre_jump_m, np.inf)
        iou = box_iou_matrix(np.array([s.box for s in self._tracks], dtype=np.float64),
                             np.array([o.box_px for o in obstacles], dtype=np.float64))
        predicted = np.array([np.nan if (z := s.predicted_distance(time_s)) is None else z for s in self._tracks])
        last = np.array([np.nan if s.distance is None else s.distance for s in self._tracks])
        measured = np.array([np.nan if o.distance_m is None else o.distance_m for o in obstacles])
        # from the prediction or from the last distance: one noisy frame throws a young track's velocity off
        change = np.fmin(np.abs(measured[None, :] - predicted[:, None]), np.abs(measured[None, :] - last[:, None]))
        reach = np.maximum(self.params.max_centre_jump_m, self.params.max_distance_change * np.abs(predicted))[:, None]
        plausible = ~(change > reach)                     # NaN (no distance on either side): boxes alone
        cost = np.minimum(jump_cost, np.where((iou >= self.params.min_iou) & plausible, 1.0 - iou, np.inf))
        ts, js = np.nonzero(np.isfinite(cost))
        costs = sorted(zip(cost[ts, js].tolist(), ts.tolist(), js.tolist()))
        pairs: dict[int, tuple[_State, float]] = {}
        used_tracks: set[int] = set()
        for c, t, i in costs:
            if t in used_tracks or i in pairs:
                continue
            used_tracks.add(t)
            pairs[i] = (self._tracks[t], c)
        return pairs

    def _correct(self, state: _State, obstacle: Obstacle, time_s: float) -> None:
        dt = time_s - state.time_s
        predicted = state.predicted_distance(time_s)
        if state.age == 1 and predicted is not None and obstacle.distance_m is not None:
            state.velocity = (obstacle.distance_m - state.distance) / dt     # two-point start
            state.distance = obstacle.distance_m
        elif predicted is not None and obstacle.distance_m is not None:
            residual = obstacle.distance_m - predicted
            state.distance = predicted + self.params.alpha * residual
            state.velocity += self.params.beta * residual / dt
        else:
            state.distance = obstacle.distance_m
            state.velocity = 0.0
        state.obstacle = obstacle
        state.box = obstacle.box_px
        state.centre = np.asarray(obstacle.centre_m) if obstacle.centre_m is not None else None
        state.time_s = time_s
        state.age += 1
        state.missed = 0

    def _report(self, state: _State, obstacle: Obstacle | None, time_s: float | None = None) -> Track:
        distance = state.distance if time_s is None else state.predicted_distance(time_s)
        if distance is not None:
            distance = max(distance, 0.0)     # a prediction past the camera: at contact, not behind it
        closing = 0.0 - state.velocity if distance is not None else None      # not -0.0 for a new track
        approaching = bool(closing is not None and state.age >= self.params.min_age_frames
                           and closing > self.params.min_closing_speed_mps)
        contact = distance / closing if approaching and distance is not None else None
        return Track(track_id=state.track_id, obstacle=obstacle, distance_m=distance, closing_speed_mps=closing,
                     time_to_contact_s=contact, approaching=approaching, age_frames=state.age,
                     missed_frames=state.missed)
