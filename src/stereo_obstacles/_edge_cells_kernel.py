"""Compiled gradient magnitudes and thinning of edge pixels to the strongest one per square cell
(private).

The public entry point is :func:`stereo_obstacles.seeds.edge_pixels`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stereo_obstacles._similarity_kernel import CACHE


@njit(cache=CACHE, nogil=True)
def strongest_per_cell(edges, magnitude, spacing):
    """Rows and columns (int32, raster order) of the edge pixel of largest ``magnitude`` in each
    ``spacing x spacing`` cell of the ``(H, W)`` bool map ``edges``; ties go to the first pixel of
    the cell in raster order, cells without an edge pixel give none."""
    h, w = edges.shape
    n_cells = ((h + spacing - 1) // spacing) * ((w + spacing - 1) // spacing)
    flat = np.empty(n_cells, np.int64)
    n = 0
    for y0 in range(0, h, spacing):
        for x0 in range(0, w, spacing):
            best = -1
            best_m = np.float32(0.0)
            for y in range(y0, min(y0 + spacing, h)):
                for x in range(x0, min(x0 + spacing, w)):
                    if edges[y, x] and (best < 0 or magnitude[y, x] > best_m):
                        best = y * w + x
                        best_m = magnitude[y, x]
            if best >= 0:
                flat[n] = best
                n += 1
    return rows_and_columns(np.sort(flat[:n]), w)


@njit(cache=CACHE, nogil=True)
def rows_and_columns(flat, w):
    """Rows and columns (int32) of flat pixel indices ``flat`` of an image ``w`` pixels wide."""
    return (flat // w).astype(np.int32), (flat % w).astype(np.int32)


@njit(cache=CACHE, nogil=True)
def magnitude_and_cells(gx, gy, spacing, magnitude, cell_max, cell_pos):
    """Gradient magnitude and the strongest pixel of each cell.

    Writes ``magnitude = sqrt(gx^2 + gy^2)`` (float32, ``(H, W)``, rounded as NumPy rounds it:
    no fast-math contraction here) and, per ``spacing x spacing`` cell, the largest magnitude
    ``cell_max`` (float32) and its flat pixel index ``cell_pos`` (int64), ties to the first pixel
    in raster order; both ``(ceil(H / spacing), ceil(W / spacing))``.
    """
    h, w = gx.shape
    n_cols = cell_max.shape[1]
    for cy in range(cell_max.shape[0]):
        for cx in range(n_cols):
            cell_max[cy, cx] = np.float32(-1.0)
            cell_pos[cy, cx] = -1
        for y in range(cy * spacing, min(h, (cy + 1) * spacing)):
            for x in range(w):  # apart from the maxima below, so that it vectorises
                magnitude[y, x] = np.sqrt(gx[y, x] * gx[y, x] + gy[y, x] * gy[y, x])
            for cx in range(n_cols):
                best = cell_max[cy, cx]
                at = -1
                for x in range(cx * spacing, min(w, (cx + 1) * spacing)):
                    if magnitude[y, x] > best:
                        best = magnitude[y, x]
                        at = x
                if at >= 0:
                    cell_max[cy, cx] = best
                    cell_pos[cy, cx] = y * w + at
