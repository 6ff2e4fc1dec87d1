"""Obstacles found in pieces, joined into one and measured as one.

The grouping can list one object as several obstacles: the two outlines of a textureless face
(:mod:`stereo_obstacles.face_joining`), the pieces of an object whose matches have gaps
(:mod:`stereo_obstacles.footprint_joining`). Once such pairs are known, their groups are joined
(joins chain: pieces linked through others become one) and the joined groups are measured again,
as :func:`~stereo_obstacles.obstacles.measure_obstacles` does, but the distance of a group made of
pieces is never farther than that of its largest piece, as it was measured alone. A receding wall
measured on its plane at its near end, joined with a piece that is off that plane, is no longer
one plane, and the low percentile of the patches lies behind the near end (a wall in a noisy
scene read +0.8 % alone, +10.8 % with a piece; ``docs/pipeline.md``, "The pieces of one object,
joined by their footprints").

The union may read nearer than every piece: a face slanted in depth, found as two pieces each too
little slanted to be read on its plane (:mod:`stereo_obstacles.near_face`), is read on the plane
of both at its near end. Until session 32 it was kept no nearer than its nearest piece, against
a slanted-face plane then read where no patch of the face lay (a box's top face read at its
front face); the plane is now read only on its own patches. The nearest piece alone is not
taken: a stray piece would decide (a 182-pixel mixture of a wall and the box in front of it,
joined to the wall, put the wall at the box's distance).
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.ground_plane import GroundPlane
from stereo_obstacles.obstacles import (Obstacle, ObstacleList, ObstacleParameters, RejectedGroup,
                                        list_obstacles, measure_groups)

__all__ = ["join_obstacles", "measure_joined"]


def join_obstacles(id_map: np.ndarray, pairs: list[tuple[int, int]]) -> np.ndarray:
    """``int32 (H, W)``: ``id_map`` with each set of obstacles that ``pairs`` link (directly or
    through others) under the smallest id among them."""
    ids = np.asarray(id_map)
    top = int(ids.max(initial=0))
    root = np.arange(top + 1)

    def find(k: int) -> int:
        while root[k] != k:
            k = root[k]
        return k

    for first, second in pairs:
        r1, r2 = find(first), find(second)
        root[max(r1, r2)] = min(r1, r2)
    for k in range(top + 1):
        root[k] = find(k)
    return root[ids].astype(np.int32)


def measure_joined(groups: np.ndarray, pieces: ObstacleList, pairs: list[tuple[int, int]], disparity: np.ndarray,
                   calibration: StereoCalibration | None, ground: GroundPlane | None,
                   params: ObstacleParameters = ObstacleParameters()) -> tuple[np.ndarray, ObstacleList]:
    """Join the obstacles of each pair and measure the joined groups again (module docstring).

    Parameters
    ----------
    groups
        ``int (H, W)`` group number per pixel (0: none) that ``pieces`` were measured from.
    pieces
        The obstacles measured from ``groups`` on ``disparity`` (without the scan).
    pairs
        ``(a, b)`` ids of obstacles of ``pieces`` to join; pairs of the two joinings may chain
        (a footprint star and a face pair sharing a piece are one obstacle).
    disparity, calibration, ground, params
        As :func:`~stereo_obstacles.obstacles.measure_obstacles` takes them.

    Returns
    -------
    joined : numpy.ndarray
        ``int32 (H, W)``: ``groups`` with the groups of each pair under one number.
    obstacles : ObstacleList
        The obstacles of ``joined``, numbered nearest first, without the scan; a joined one no
        farther than its largest piece; the pieces' rejections kept.

    Raises
    ------
    InvalidInputError
        A pair names an id that is not one of ``pieces``' obstacles.
    """
    known = {o.id for o in pieces.obstacles}
    unknown = sorted({k for pair in pairs for k in pair} - known)
    if unknown:
        raise InvalidInputError(f"pairs: {unknown} are not ids of the pieces' obstacles ({sorted(known)})")
    flat_ids, flat_groups = np.asarray(pieces.id_map).ravel(), np.asarray(groups).ravel()
    covered = np.flatnonzero(flat_ids)
    group_of = np.zeros(int(flat_ids.max(initial=0)) + 1, dtype=np.int64)    # by obstacle id
    pixel_of = np.zeros_like(group_of)                                      # a pixel of each obstacle
    group_of[flat_ids[covered]], pixel_of[flat_ids[covered]] = flat_groups[covered], covered
    joined = join_obstacles(groups, [(int(group_of[a]), int(group_of[b])) for a, b in pairs])
    paired = {k for pair in pairs for k in pair}
    members: dict[int, list[Obstacle]] = {}            # joined group -> its pieces
    for piece in pieces.obstacles:
        if piece.id in paired:
            members.setdefault(int(joined.ravel()[pixel_of[piece.id]]), []).append(piece)
    # only the joined groups are measured again (the measure of a group does not depend on others)
    measured: dict[int, Obstacle | RejectedGroup] = {
        int(group_of[o.id]): o for o in pieces.obstacles if o.id not in paired}
    in_joined = covered[np.isin(flat_ids[covered], list(paired))]
    only_joined = np.zeros(np.shape(groups), dtype=np.int32)
    only_joined.ravel()[in_joined] = joined.ravel()[in_joined]
    # measured without the distance limit: the clamp below keeps a joined group within its largest
    # piece's distance, which was within the limit (the union alone could read beyond it)
    unlimited = replace(params, max_distance_m=sys.float_info.max)
    for group, outcome in measure_groups(only_joined, disparity, calibration, ground, unlimited).items():
        parts = members[group]
        if isinstance(outcome, Obstacle) and outcome.distance_m is not None:
            largest = max(parts, key=lambda part: part.pixel_count).distance_m
            outcome = replace(outcome, distance_m=min(outcome.distance_m, largest))
        measured[group] = outcome
    listed = list_obstacles(measured, joined, disparity, calibration, params, with_scan=False)
    return joined, replace(listed, rejected=pieces.rejected + listed.rejected)
