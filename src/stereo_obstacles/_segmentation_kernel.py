"""Compiled passes of the ground/shadow/obstacle segmentation (see :mod:`stereo_obstacles.segmentation`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from stereo_obstacles._colour_kernel import hsi_pixel

GROUND_MATCH, SHADOW_MATCH, SUNLIT_MATCH, VALID = 0, 1, 2, 3
"""Channels of the flag image: colour matches for ground, shadow, sunlit ground; colour valid."""


@njit(cache=True, nogil=True)
def match_flags_kernel(rgb, inv_full_scale, min_intensity, min_saturation, grey, ref_x, ref_y,
                       cos_ground, cos_veto, max_sat_ground, max_sat_veto, ref_rgb, blue_shift,
                       chroma_band, flags, veto, intensity):
    """Per-pixel colour tests against the ground reference.

    Ground (same light as the reference). Coloured ground: colour valid = hue valid; the
    pixel is within ``T`` degrees of the reference hue when the angle between its
    chromaticity vector and the unit reference vector ``(ref_x, ref_y)`` is at most ``T``:
    ``dot >= |c| cos T`` (no arctangent). Grey ground: colour valid = saturation valid; the
    test is ``saturation <= max_sat_ground``.

    Shadow / sunlit ground (other light). The per-channel ratios ``k = (rgb + 1) /
    (ref_rgb + 1)`` of a surface seen under skylight alone against sun and sky (or the
    reverse) differ along the blue-yellow axis only: a shadow has ``k_B >= blue_shift k_R``,
    sunlit ground seen from a shadowed reference ``blue_shift k_B <= k_R``, and both keep
    ``k_G`` near the geometric mean of ``k_R`` and ``k_B``:
    ``k_G**2 / (k_R k_B)`` within ``[1 / chroma_band, chroma_band]``.

    Outputs: ``flags[y, x, :]`` (see the channel constants) as 0/1, ``veto`` (the pixel's
    own colour is far from the ground's) and ``intensity`` in [0, 1].
    """
    height, width = rgb.shape[0], rgb.shape[1]
    one = np.float32(1.0)
    inv_r = one / np.float32(ref_rgb[0] + 1.0)
    inv_g = one / np.float32(ref_rgb[1] + 1.0)
    inv_b = one / np.float32(ref_rgb[2] + 1.0)
    shift = np.float32(blue_shift)
    band = np.float32(chroma_band)
    inv_band = one / band
    for y in range(height):
        for x in range(width):
            r = rgb[y, x, 0]
            g = rgb[y, x, 1]
            b = rgb[y, x, 2]
            i, s, cx, cy = hsi_pixel(r, g, b, inv_full_scale)
            intensity[y, x] = i
            valid = i >= min_intensity
            near_ground = False
            far = False
            if grey:
                if valid:
                    near_ground = s <= max_sat_ground
                    far = s > max_sat_veto
            else:
                valid = valid and s >= min_saturation
                if valid:
                    dot = cx * ref_x + cy * ref_y
                    norm = math.sqrt(cx * cx + cy * cy)
                    near_ground = dot >= norm * cos_ground
                    far = dot < norm * cos_veto
            k_r = (np.float32(r) + one) * inv_r
            k_g = (np.float32(g) + one) * inv_g
            k_b = (np.float32(b) + one) * inv_b
            green = k_g * k_g
            red_blue = k_r * k_b
            neutral = inv_band * red_blue <= green <= band * red_blue
            flags[y, x, GROUND_MATCH] = near_ground
            flags[y, x, SHADOW_MATCH] = neutral and k_b >= shift * k_r
            flags[y, x, SUNLIT_MATCH] = neutral and shift * k_b <= k_r
            flags[y, x, VALID] = valid
            veto[y, x] = far


@njit(cache=True, nogil=True)
def classify_kernel(counts, n_window, veto, intensity, min_intensity, ground_low, ground_high,
                    shadow_low, shadow_high, sunlit_low, sunlit_high, shadow_rule, unknown,
                    ground, shadow, obstacle, labels):
    """Label every pixel from its window counts (see ``match_flags_kernel``) and its intensity.

    A ground colour test passes when at least half of the window's colour-valid pixels pass
    it (the median filter), and the pixel itself is not vetoed (so that the filter cannot
    erase a thin pole). The shadow and sunlit tests are ratios, defined for every pixel, so
    their majority is over the whole window (``n_window``).
    """
    height, width = intensity.shape
    for y in range(height):
        for x in range(width):
            i = intensity[y, x]
            n_valid = counts[y, x, VALID]
            half_window = n_window[y, x]
            if (n_valid > 0 and not veto[y, x] and ground_low <= i <= ground_high
                    and 2 * counts[y, x, GROUND_MATCH] >= n_valid):
                labels[y, x] = ground
            elif (shadow_rule and shadow_low <= i <= shadow_high
                  and 2 * counts[y, x, SHADOW_MATCH] >= half_window):
                labels[y, x] = shadow
            elif (shadow_rule and sunlit_low <= i <= sunlit_high
                  and 2 * counts[y, x, SUNLIT_MATCH] >= half_window):
                labels[y, x] = ground
            elif shadow_rule and i < min_intensity and shadow_low <= i:
                labels[y, x] = unknown  # too dark to measure colour, yet bright enough for a shadow
            else:
                labels[y, x] = obstacle


@njit(cache=True, nogil=True)
def classify_modes_kernel(counts, veto, measurable, unknown, ground, shadow, obstacle, labels):
    """Label every pixel from the window counts of the ground colour model's tests.

    ``counts[y, x]`` holds, over the window, how many pixels have a ground colour, a shadow
    colour, a sunlit colour, and how many are measurable. The median filter of the paper,
    for three exclusive-ish tests: the pixel is ground (or shadow) when one kind of match
    covers at least half of the measurable pixels and its own colour is not vetoed (so
    that the window cannot erase a thin pole); shadow when the shadow matches outnumber
    the others. Unmatched pixels too dark to measure yet near a model colour (a deep
    shadow) are unknown, the rest obstacles.
    """
    height, width = veto.shape
    for y in range(height):
        for x in range(width):
            n_ground = counts[y, x, 0]
            n_shadow = counts[y, x, 1]
            n_sunlit = counts[y, x, 2]
            best = max(n_ground, n_shadow, n_sunlit)
            if counts[y, x, 3] > 0 and not veto[y, x] and 2 * best >= counts[y, x, 3]:
                if n_shadow > n_ground and n_shadow > n_sunlit:
                    labels[y, x] = shadow
                else:
                    labels[y, x] = ground
            elif not measurable[y, x] and not veto[y, x]:
                labels[y, x] = unknown
            else:
                labels[y, x] = obstacle


@njit(cache=True, nogil=True, inline="always")
def component_areas(components, n_components):
    """``int64 (n_components,)``: pixels of each label of an ``int32 (H, W)`` component map.

    Counted run by run along the rows: one increment per run of equal labels instead of one
    per pixel (consecutive increments of one counter wait for each other)."""
    height, width = components.shape
    area = np.zeros(n_components, dtype=np.int64)
    if width == 0:
        return area
    for y in range(height):
        row = components[y]
        start = 0
        for x in range(1, width):
            if row[x] != row[start]:
                area[row[start]] += x - start
                start = x
        area[row[start]] += width - start
    return area


@njit(cache=True, nogil=True)
def fill_small_components_kernel(components, n_components, min_area, darker, fill, fill_darker,
                                 labels):
    """Relabel the pixels of every component smaller than ``min_area`` pixels, in place.

    ``components`` is an ``int32 (H, W)`` component map with ``n_components`` labels, 0 the
    background (never relabelled); a pixel of a small component becomes ``fill_darker`` where
    ``darker`` is set and ``fill`` elsewhere.
    """
    height, width = components.shape
    small = component_areas(components, n_components) < min_area
    small[0] = False
    if not small.any():
        return
    for y in range(height):
        for x in range(width):
            if small[components[y, x]]:
                labels[y, x] = fill_darker if darker[y, x] else fill


@njit(cache=True, nogil=True)
def fill_holes_kernel(components, n_components, min_area, max_enclosed_area, fill, labels):
    """Relabel to ``fill``, in place, every component smaller than ``min_area`` pixels, and every
    component of at most ``max_enclosed_area`` pixels that does not touch the image border (a
    hole enclosed by the background).

    ``components`` is an ``int32 (H, W)`` component map with ``n_components`` labels, 0 the
    background (never relabelled).
    """
    height, width = components.shape
    on_border = np.zeros(n_components, dtype=np.bool_)
    for x in range(width):
        on_border[components[0, x]] = True
        on_border[components[height - 1, x]] = True
    for y in range(height):
        on_border[components[y, 0]] = True
        on_border[components[y, width - 1]] = True
    area = component_areas(components, n_components)
    hole = (area < min_area) | ((area <= max_enclosed_area) & ~on_border)
    hole[0] = False
    if not hole.any():
        return
    for y in range(height):
        for x in range(width):
            if hole[components[y, x]]:
                labels[y, x] = fill
