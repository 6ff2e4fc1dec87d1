"""Whether the depth layers of one obstacle group are one surface or several objects.

The depth-layer split of :mod:`stereo_obstacles.obstacle_grouping` finds, inside a group, tight
groups ("layers") whose disparities differ. Two objects a little apart in depth give two layers,
but so does one slanted surface (a wall seen at an angle, whose disparity changes across it by
more than the tight tolerance): it comes out in bands. What tells them apart is where two layers
meet. On one surface neighbouring pixels of the two bands have nearly the same disparity; where a
nearer object stands in front of a farther one, the disparity steps by their difference in
depth. So two touching layers are taken as one surface when the median disparity difference
between 4-neighbouring pixels of the two is at most a minimum step; layers joined that way,
directly or through others, form one part.

Two walls meeting at a corner also meet without a step: they stay one part. And where the
matching blurs a step over several pixels (:mod:`stereo_obstacles.part_boundaries`, which
compares planes fitted away from the boundary instead, for the colour split), neighbouring
pixels differ by only part of it: two surfaces 1 px apart whose step is spread over 8 pixels
read as one. Over the evaluation scenes the test mends more merges than it makes (measured in
``docs/pipeline.md``, session 30).
"""

from __future__ import annotations

import numpy as np

from stereo_obstacles.errors import InvalidInputError


def layer_surfaces(ys: np.ndarray, xs: np.ndarray, d: np.ndarray, layer: np.ndarray, n_layers: int,
                   min_step_px: float) -> np.ndarray:
    """Which surface each layer belongs to.

    Parameters
    ----------
    ys, xs
        ``int (N,)`` rows and columns of a group's pixels (each pixel once).
    d
        ``float (N,)`` their disparities in pixels, finite.
    layer
        ``int (N,)`` the layer of each pixel, ``0..n_layers-1``, or -1 for a pixel in none (it
        takes no part in the test).
    n_layers
        Number of layers (>= 1).
    min_step_px
        Two touching layers whose boundary's median disparity difference is at most this many
        pixels are one surface.

    Returns
    -------
    numpy.ndarray
        ``int64 (n_layers,)``: the surface of each layer, ``0..k-1`` numbered in the order of their
        first layers; layers that touch no other stay surfaces of their own.

    Raises
    ------
    InvalidInputError
        No pixels, arrays of different lengths, ``n_layers`` below 1 or a layer outside
        ``-1..n_layers-1``.

    Examples
    --------
    Three bands of columns: the first two meet without a step, the third stands 1 px nearer.

    >>> d = np.array([[7.0, 7.1, 7.2, 8.3]])
    >>> layer_surfaces(np.zeros(4, int), np.arange(4), d[0], np.array([0, 0, 1, 2]), 3, 0.3).tolist()
    [0, 0, 1]
    """
    n = len(ys)
    if not (n >= 1 and len(xs) == len(d) == len(layer) == n):
        raise InvalidInputError(f"layer_surfaces needs one or more pixels, with as many columns, disparities and "
                                f"layers as rows: got {len(ys)}, {len(xs)}, {len(d)}, {len(layer)}")
    if n_layers < 1 or layer.min() < -1 or layer.max() >= n_layers:
        raise InvalidInputError(f"layers must lie in -1..{n_layers - 1} (n_layers >= 1), got "
                                f"{layer.min()}..{layer.max()} of {n_layers}")
    y0, x0 = ys.min(), xs.min()
    layer_image = np.full((ys.max() - y0 + 1, xs.max() - x0 + 1), -1, dtype=np.int64)
    layer_image[ys - y0, xs - x0] = layer
    d_image = np.zeros(layer_image.shape)
    d_image[ys - y0, xs - x0] = d
    pairs, steps = [], []
    for a, b, da, db in ((layer_image[:, :-1], layer_image[:, 1:], d_image[:, :-1], d_image[:, 1:]),
                         (layer_image[:-1, :], layer_image[1:, :], d_image[:-1, :], d_image[1:, :])):
        across = (a >= 0) & (b >= 0) & (a != b)
        pairs.append(np.minimum(a[across], b[across]) * n_layers + np.maximum(a[across], b[across]))
        steps.append(np.abs(da[across] - db[across]))
    pairs, steps = np.concatenate(pairs), np.concatenate(steps)
    surface = np.arange(n_layers)
    for pair in np.unique(pairs):
        if np.median(steps[pairs == pair]) <= min_step_px:
            first, second = surface[pair // n_layers], surface[pair % n_layers]
            surface[surface == max(first, second)] = min(first, second)
    return np.unique(surface, return_inverse=True)[1].astype(np.int64)
