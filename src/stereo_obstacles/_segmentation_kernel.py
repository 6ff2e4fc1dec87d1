"""Compiled passes of the ground/shadow/obstacle segmentation (see :mod:`stereo_obstacles.segmentation`)."""

from __future__ import annotations

import math

from numba import njit

from stereo_obstacles._colour_kernel import hsi_pixel


@njit(cache=True)
def match_flags_kernel(rgb, inv_full_scale, min_intensity, min_saturation, grey, ref_x, ref_y,
                       cos_ground, cos_shadow, cos_veto, max_sat_ground, max_sat_shadow,
                       max_sat_veto, flags, intensity):
    """Per pixel: matches the ground colour (ground tolerance, shadow tolerance), colour valid,
    and the veto: the pixel's own colour is far outside the shadow tolerance.

    Coloured ground: valid = hue valid; a pixel matches within ``T`` when the angle between
    its chromaticity vector and the unit reference vector ``(ref_x, ref_y)`` is at most ``T``,
    i.e. ``dot >= |c| cos T`` (no arctangent needed). Grey ground: valid = saturation valid;
    a pixel matches when its saturation is at most ``max_sat_*``.
    ``flags[y, x] = (match_ground, match_shadow, valid, veto)`` as 0/1; ``intensity`` in [0, 1].
    """
    height, width = rgb.shape[0], rgb.shape[1]
    for y in range(height):
        for x in range(width):
            i, s, cx, cy = hsi_pixel(rgb[y, x, 0], rgb[y, x, 1], rgb[y, x, 2], inv_full_scale)
            intensity[y, x] = i
            valid = i >= min_intensity
            match_ground = False
            match_shadow = False
            veto = False
            if grey:
                if valid:
                    match_ground = s <= max_sat_ground
                    match_shadow = s <= max_sat_shadow
                    veto = s > max_sat_veto
            else:
                valid = valid and s >= min_saturation
                if valid:
                    dot = cx * ref_x + cy * ref_y
                    norm = math.sqrt(cx * cx + cy * cy)
                    match_ground = dot >= norm * cos_ground
                    match_shadow = dot >= norm * cos_shadow
                    veto = dot < norm * cos_veto
            flags[y, x, 0] = match_ground
            flags[y, x, 1] = match_shadow
            flags[y, x, 2] = valid
            flags[y, x, 3] = veto


@njit(cache=True)
def classify_kernel(counts, flags, intensity, grey, min_intensity, ground_low, ground_high, shadow_low,
                    shadow_high, shadow_rule, unknown, ground, shadow, obstacle, labels):
    """Label every pixel from its window counts (see ``match_flags_kernel``) and its intensity.

    The colour test is the median filter: at least half of the window's valid pixels match,
    and the pixel itself is not vetoed (so that the filter cannot erase a thin pole).
    """
    height, width = intensity.shape
    for y in range(height):
        for x in range(width):
            i = intensity[y, x]
            n_valid = counts[y, x, 2]
            in_shadow_range = shadow_rule and shadow_low <= i <= shadow_high
            if n_valid == 0:
                # No colour anywhere in the window: a grey object on coloured ground, or dark.
                if (not grey and i >= min_intensity) or not in_shadow_range:
                    labels[y, x] = obstacle
                else:
                    labels[y, x] = unknown
                continue
            if flags[y, x, 3]:
                labels[y, x] = obstacle
            elif 2 * counts[y, x, 0] >= n_valid and ground_low <= i <= ground_high:
                labels[y, x] = ground
            elif in_shadow_range and 2 * counts[y, x, 1] >= n_valid:
                labels[y, x] = shadow
            else:
                labels[y, x] = obstacle
