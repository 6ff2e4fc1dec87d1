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
plane joined objects side by side at different depths; ``docs/pipeline.md``.) Groups of one
colour (given their mean chroma) are tested up to a few cells apart: the pieces of a wall whose
weakly textured stretches left gaps of more than one cell.

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


def _pairs_to_sets(keys: np.ndarray, n: int) -> list[set[int]]:
    """Each group's partners in the pairs ``keys`` (``g * n + k``)."""
    partners = [set() for _ in range(n)]
    for g, k in zip(keys // n, keys % n):
        partners[g].add(int(k))
        partners[k].add(int(g))
    return partners


def _alike(colour_sums: np.ndarray | None, sums: np.ndarray, a: int, b: int, max_distance: float) -> bool:
    """Whether groups ``a`` and ``b`` have mean colours closer than ``max_distance`` (False
    without colours): ``colour_sums`` ``(n, 2)`` over each group's pixels, ``sums[:, 0]`` their
    counts."""
    if colour_sums is None:
        return False
    return math.dist(colour_sums[a] / sums[a, 0], colour_sums[b] / sums[b, 0]) < max_distance


def merge_coplanar_groups(groups: np.ndarray, disparity: np.ndarray, *, cell_px: int, tolerance_px: float,
                          rel_tolerance: float, split_from: np.ndarray | None = None,
                          colours: np.ndarray | None = None, colour_reach_cells: int = 1,
                          max_chroma_distance: float = 0.0) -> np.ndarray:
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
    colours, colour_reach_cells, max_chroma_distance
        ``float (n, 2)`` mean chroma ``(a*, b*)`` of each group, or None: groups whose colours lie
        closer than ``max_chroma_distance`` are neighbours up to ``colour_reach_cells`` cells apart
        (along each axis), not only in neighbouring cells (a wall whose weakly textured stretches
        left gaps of more than a cell; objects of distinct colours so far apart are not tested:
        a plane slanted through two of them fits both).

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
    if colours is not None and np.shape(colours) != (n, 2):
        raise InvalidInputError(f"colours must have one (a*, b*) per group, shape ({n}, 2), got {np.shape(colours)}")
    if n < 2:
        return groups
    sums, keys, farther = group_sums_kernel(groups, disparity, cell_px, n,
                                            colour_reach_cells if colours is not None else 1)
    neighbours, distant = _pairs_to_sets(keys, n), _pairs_to_sets(farther, n)
    for g in range(n):
        distant[g] -= neighbours[g]
    colour_sums = None if colours is None else np.asarray(colours, dtype=np.float64) * sums[:, :1]
    origins = [{int(o)} for o in (np.arange(n) if split_from is None else split_from)]
    members = [[g] for g in range(n)]
    root = np.arange(n)
    pending = deque((int(g), int(k)) for g, k in zip(keys // n, keys % n))
    pending.extend((int(g), int(k)) for g, k in zip(farther // n, farther % n) if int(k) in distant[g])
    while pending:
        a, b = pending.popleft()
        if root[a] != a or root[b] != b or not origins[a].isdisjoint(origins[b]):
            continue                                    # absorbed since queued, or split apart
        if b not in neighbours[a] and not _alike(colour_sums, sums, a, b, max_chroma_distance):
            continue                                    # a distant pair of distinct colours
        if not _coplanar(sums[a], sums[b], tolerance_px, rel_tolerance):
            continue
        keep, other = min(a, b), max(a, b)
        sums[keep] += sums[other]
        if colour_sums is not None:
            colour_sums[keep] += colour_sums[other]
        origins[keep] |= origins[other]
        root[members[other]] = keep
        members[keep] += members[other]
        for sets in (neighbours, distant):
            for x in sets[other] - {keep}:
                sets[x].discard(other)
                sets[x].add(keep)
            sets[keep] |= sets[other] - {keep}
            sets[keep].discard(other)
        pending.extend((keep, x) for x in neighbours[keep] | distant[keep])  # the joined group is a new part
    _, compact = np.unique(root, return_inverse=True)
    return np.concatenate([[-1], compact])[groups + 1]
