"""Compiled thinning of edge pixels to the strongest one per square cell (private).

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
    flat = np.sort(flat[:n])
    return (flat // w).astype(np.int32), (flat % w).astype(np.int32)
