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
above it fits neither's upright face. (Testing only each group's mean residual to the joint
plane joined objects side by side at different depths; ``docs/pipeline.md``.)

Joined groups are tested again against their neighbours until nothing changes. Every test
works on the plane-fit sums of the groups' pixels (:func:`stereo_obstacles.plane_fit.plane_moments`),
which add up as groups join: one pass over the pixels in all.
"""

from __future__ import annotations

import math

import numpy as np

from stereo_obstacles._coplanar_merging_kernel import group_sums_kernel
from stereo_obstacles.plane_fit import mean_squared_residual, plane_from_moments

__all__ = ["merge_coplanar_groups"]


def _neighbour_pairs(occupied: np.ndarray) -> list[tuple[int, int]]:
    """Pairs ``(g, k)``, ``g < k``, of groups whose cells (``occupied``, bool ``(n, gh, gw)``) lie
    within one cell of each other (8-neighbourhood): a join on the cell index, since a cell holds
    few groups and a frame may hold many."""
    n, gh, gw = occupied.shape
    padded = np.pad(occupied, ((0, 0), (1, 1), (1, 1)))
    near = np.zeros_like(occupied)
    for dy in range(3):
        for dx in range(3):
            near |= padded[:, dy:dy + gh, dx:dx + gw]
    owner, owned_cell = np.nonzero(occupied.reshape(n, gh * gw))
    by_cell = np.argsort(owned_cell, kind="stable")
    owner, owned_cell = owner[by_cell], owned_cell[by_cell]
    group, near_cell = np.nonzero(near.reshape(n, gh * gw))
    first = np.searchsorted(owned_cell, near_cell, side="left")
    count = np.searchsorted(owned_cell, near_cell, side="right") - first
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    g, k = np.repeat(group, count), owner[np.repeat(first, count) + offset]
    keys = np.unique(np.minimum(g, k)[g != k] * n + np.maximum(g, k)[g != k])
    return [(int(key // n), int(key % n)) for key in keys]


def _off_plane_px(part: np.ndarray, plane: tuple[float, float, float]) -> float:
    """Root-mean-square distance, over a part's pixels (given by their plane-fit sums), between
    ``plane`` and the part's own least-squares plane (a constant for a part that pins no plane
    down): how much worse ``plane`` describes the part than the part itself does, in pixels."""
    own = plane_from_moments(part) or (0.0, 0.0, part[3] / part[0])
    return math.sqrt(max(mean_squared_residual(part, plane) - mean_squared_residual(part, own), 0.0))


def _coplanar(part_a: np.ndarray, part_b: np.ndarray, tolerance_px: float, rel_tolerance: float) -> bool:
    plane = plane_from_moments(part_a + part_b)
    return plane is not None and all(
        _off_plane_px(part, plane) <= tolerance_px + rel_tolerance * part[3] / part[0] for part in (part_a, part_b))


def merge_coplanar_groups(groups: np.ndarray, disparity: np.ndarray, *, cell_px: int, tolerance_px: float,
                          rel_tolerance: float, split_from: np.ndarray | None = None) -> np.ndarray:
    """Join neighbouring groups that lie on one plane in disparity.

    Parameters
    ----------
    groups
        ``int64 (H, W)``: the group of each pixel, ``0..n-1`` (each label used), or -1 for none.
    disparity
        ``float32 (H, W)`` disparity in pixels, finite at every labelled pixel.
    cell_px
        Side of the grid cells that decide which groups are neighbours (within one cell).
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
    """
    n = int(groups.max()) + 1
    if n < 2:
        return groups
    sums, occupied = group_sums_kernel(groups, disparity, cell_px, n)
    pairs = _neighbour_pairs(occupied)
    origins = [{int(o)} for o in (np.arange(n) if split_from is None else split_from)]
    root = np.arange(n)
    joined = True
    while joined:
        joined = False
        for g, k in pairs:
            a, b = root[g], root[k]
            if a != b and origins[a].isdisjoint(origins[b]) and _coplanar(sums[a], sums[b], tolerance_px,
                                                                          rel_tolerance):
                keep, other = min(a, b), max(a, b)
                sums[keep] += sums[other]
                origins[keep] |= origins[other]
                root[root == other] = keep
                joined = True
    _, compact = np.unique(root, return_inverse=True)
    return np.concatenate([[-1], compact])[groups + 1]
