"""Joining neighbouring obstacle groups that are pieces of one flat surface.

The grouping (:mod:`stereo_obstacles.obstacle_grouping`) links 8 x 8 cells whose median
disparities agree, so a surface whose matches have gaps, or whose disparity changes by more
than the link tolerance from one cell to the next (a wall seen at a slant, close by), can come
out as several groups: one wall listed four times. A scene plane is a plane ``d = a x + b y +
c`` in disparity, which gives a test that neither fattened outlines nor noisy cells pass by
chance: two groups with cells within one cell of each other are joined when the least-squares
plane of their pixels together describes each of them almost as well as the group's own plane
does: over each group's pixels the two planes differ by at most ``tolerance_px + rel_tolerance
* d`` (root mean square). Each group must lie on the joint plane, not only the larger one,
and with its own slant: a plane slanted to pass through a near box and the far pole rising
above it fits neither's upright face. (Testing only each group's median residual to the joint
plane joined objects side by side at different depths; ``docs/pipeline.md``.)

Joined groups are tested again against their neighbours until nothing changes. Every test
works on the plane-fit sums of the groups' pixels (:func:`stereo_obstacles.plane_fit.plane_moments`),
which add up as groups join: one pass over the pixels in all.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from stereo_obstacles._coplanar_merging_kernel import group_sums_kernel
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.plane_fit import mean_squared_residual, plane_from_moments

__all__ = ["merge_coplanar_groups"]


def _coplanar(part_a: np.ndarray, part_b: np.ndarray, tolerance_px: float, rel_tolerance: float) -> bool:
    """Whether the plane through both parts (given by their plane-fit sums) lies, over each part's
    pixels, within ``tolerance_px + rel_tolerance * d`` (root mean square) of the part's own
    least-squares plane. A part that pins no plane down (one row, column or line) is never joined:
    its own fit is then no yardstick."""
    joint = plane_from_moments(part_a + part_b)
    if joint is None:
        return False
    for part in (part_a, part_b):
        own = plane_from_moments(part)
        if own is None:
            return False
        off_plane = math.sqrt(max(mean_squared_residual(part, joint) - mean_squared_residual(part, own), 0.0))
        if off_plane > tolerance_px + rel_tolerance * part[3] / part[0]:
            return False
    return True


def merge_coplanar_groups(groups: np.ndarray, disparity: np.ndarray, *, cell_px: int, tolerance_px: float,
                          rel_tolerance: float, split_from: np.ndarray | None = None) -> np.ndarray:
    """Join neighbouring groups that lie on one plane in disparity.

    Parameters
    ----------
    groups
        ``int64 (H, W)``: the group of each pixel, ``0..n-1``, or -1 for none. Labels without
        pixels take part in nothing (and keep a number of their own in the result).
    disparity
        ``float32 (H, W)`` disparity in pixels, finite at every labelled pixel (a group with a
        NaN among its pixels is never joined).
    cell_px
        Side of the grid cells that decide which groups are neighbours (pixels in one cell or in
        two neighbouring ones).
    tolerance_px, rel_tolerance
        The test of the module docstring: ``tolerance_px + rel_tolerance * d`` pixels of disparity.
    split_from
        ``int (n,)`` or None: groups with the same value here never end up in one group, directly
        or through others (the depth layers that :mod:`stereo_obstacles.obstacle_grouping` split
        apart: it found a step between them).

    Returns
    -------
    numpy.ndarray
        ``int64 (H, W)``: the joined groups numbered ``0..m-1`` in the order of their lowest
        original label, -1 where ``groups`` is -1; ``groups`` itself when it holds fewer than two.

    Raises
    ------
    InvalidInputError
        A label below -1, or ``split_from`` not of length ``n``.
    """
    if groups.size and groups.min() < -1:
        raise InvalidInputError(f"groups: labels must be -1 (none) or 0..n-1, got {groups.min()}")
    n = int(groups.max(initial=-1)) + 1
    if split_from is not None and np.shape(split_from) != (n,):
        raise InvalidInputError(f"split_from must have one value per group, shape ({n},), got {np.shape(split_from)}")
    if n < 2:
        return groups
    sums, keys = group_sums_kernel(groups, disparity, cell_px, n)
    neighbours = [set() for _ in range(n)]
    for g, k in zip(keys // n, keys % n):
        neighbours[g].add(int(k))
        neighbours[k].add(int(g))
    origins = [{int(o)} for o in (np.arange(n) if split_from is None else split_from)]
    members = [[g] for g in range(n)]
    root = np.arange(n)
    pending = deque((int(g), int(k)) for g, k in zip(keys // n, keys % n))
    while pending:
        a, b = pending.popleft()
        if root[a] != a or root[b] != b or not origins[a].isdisjoint(origins[b]) or not _coplanar(
                sums[a], sums[b], tolerance_px, rel_tolerance):
            continue                                    # absorbed since queued, or not to be joined
        keep, other = min(a, b), max(a, b)
        sums[keep] += sums[other]
        origins[keep] |= origins[other]
        root[members[other]] = keep
        members[keep] += members[other]
        for x in neighbours[other] - {keep}:
            neighbours[x].discard(other)
            neighbours[x].add(keep)
        neighbours[keep] |= neighbours[other] - {keep}
        neighbours[keep].discard(other)
        pending.extend((keep, x) for x in neighbours[keep])  # the joined group is a new part to test
    _, compact = np.unique(root, return_inverse=True)
    return np.concatenate([[-1], compact])[groups + 1]
