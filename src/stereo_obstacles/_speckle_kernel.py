"""Compiled region labelling of :mod:`stereo_obstacles.speckles` (private).

Two passes: :func:`link_kernel` writes one byte per pixel saying whether it is matched and
whether it joins its right and its lower neighbour; :func:`speckle_kernel` (or
:func:`region_kernel`, which numbers the regions) then fills the regions through those bytes
alone. The fill reads no disparity and converts nothing, which made it 1.6x faster than one
pass comparing float disparities at every step (Teddy, Cones: 0.8 against 1.3 ms, the same
regions).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE

MATCHED, JOINS_RIGHT, JOINS_DOWN, SEEN = 1, 2, 4, 8
"""Bits of a link byte: the pixel has a finite disparity; it is in one region with its right
neighbour; with its lower neighbour; the fill has reached it."""


@njit(cache=CACHE, nogil=True)
def link_kernel(disparity, max_difference, links):
    """Fill ``links`` (``uint8 (H, W)``) from ``disparity`` (float, ``(H, W)``, non-finite where
    unmatched): :data:`MATCHED`, and :data:`JOINS_RIGHT` / :data:`JOINS_DOWN` where that neighbour
    is matched too and the two disparities differ by at most ``max_difference`` pixels (the step
    computed in float64)."""
    h, w = disparity.shape
    for y in range(h):
        for x in range(w):
            d = disparity[y, x]
            bits = 0
            if np.isfinite(d):
                bits = MATCHED
                if x + 1 < w:
                    e = disparity[y, x + 1]
                    if np.isfinite(e) and abs(np.float64(e) - np.float64(d)) <= max_difference:
                        bits |= JOINS_RIGHT
                if y + 1 < h:
                    e = disparity[y + 1, x]
                    if np.isfinite(e) and abs(np.float64(e) - np.float64(d)) <= max_difference:
                        bits |= JOINS_DOWN
            links[y, x] = bits


@njit(cache=CACHE, nogil=True, inline="always")
def _fill_region(flat_links, w, start, queue):
    """Breadth-first fill of the region of ``start`` (an unseen matched pixel, flat index)
    through the joins of ``flat_links`` (image width ``w``): sets its pixels' :data:`SEEN` bits
    and writes their flat indices to ``queue[:n]``; returns ``n``."""
    flat_links[start] |= SEEN
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        p = queue[head]
        head += 1
        bits = flat_links[p]
        if bits & JOINS_RIGHT and not flat_links[p + 1] & SEEN:
            flat_links[p + 1] |= SEEN
            queue[tail] = p + 1
            tail += 1
        if bits & JOINS_DOWN and not flat_links[p + w] & SEEN:
            flat_links[p + w] |= SEEN
            queue[tail] = p + w
            tail += 1
        if p % w > 0:
            left = flat_links[p - 1]
            if left & JOINS_RIGHT and not left & SEEN:
                flat_links[p - 1] = left | SEEN
                queue[tail] = p - 1
                tail += 1
        if p >= w:
            up = flat_links[p - w]
            if up & JOINS_DOWN and not up & SEEN:
                flat_links[p - w] = up | SEEN
                queue[tail] = p - w
                tail += 1
    return tail


@njit(cache=CACHE, nogil=True)
def speckle_kernel(links, max_size, removed):
    """Set ``removed`` (``bool (H, W)``, all False on entry) on the regions of at most ``max_size``
    pixels, the regions being the pixels connected through the joins of ``links`` (from
    :func:`link_kernel`; its :data:`SEEN` bits are set on return). Every matched pixel is entered
    once; returns the count set."""
    h, w = links.shape
    flat_links = links.ravel()
    flat_removed = removed.ravel()
    queue = np.empty(h * w, np.int32)
    n_removed = 0
    for start in range(h * w):
        if flat_links[start] & (MATCHED | SEEN) != MATCHED:
            continue
        n = _fill_region(flat_links, w, start, queue)
        if n <= max_size:
            for i in range(n):
                flat_removed[queue[i]] = True
            n_removed += n
    return n_removed


@njit(cache=CACHE, nogil=True)
def region_kernel(links, labels):
    """Write into ``labels`` (``int32 (H, W)``) the region number (0, 1, ... in raster order of
    their first pixel) of every matched pixel of ``links`` (from :func:`link_kernel`; its
    :data:`SEEN` bits are set on return) and -1 elsewhere; returns the number of regions."""
    h, w = links.shape
    flat_links = links.ravel()
    flat_labels = labels.ravel()
    flat_labels[:] = -1
    queue = np.empty(h * w, np.int32)
    count = 0
    for start in range(h * w):
        if flat_links[start] & (MATCHED | SEEN) != MATCHED:
            continue
        n = _fill_region(flat_links, w, start, queue)
        for i in range(n):
            flat_labels[queue[i]] = count
        count += 1
    return count
