"""NumPy's default percentile and median of 1-D arrays without NaN, to the bit, at a fraction of the cost.

``np.percentile`` and ``np.median`` cost about 0.1-0.2 ms per call on a few thousand values,
mostly in argument handling, and ``np.median`` of 46 000 ``float32`` values 0.46 ms against
0.04 ms for one ``np.partition`` (scratch measurements). Phase 3 takes several percentiles of
every obstacle (its distance, extent, disparity quartiles and centre), so it sorts each quantity
once and reads them here; phase 1 takes medians and percentiles of its reference area.

The arithmetic is NumPy's (NumPy 2), in NumPy's types:

* ``"linear"`` percentiles: the virtual index ``(n - 1) * q / 100`` and the interpolation
  ``a + (b - a) t``, or ``b - (b - a) (1 - t)`` when ``t >= 0.5``. For one ``q`` (a Python
  number) NumPy computes this in the array's type (``float32`` stays ``float32``); for a
  list of ``q`` the weight ``t`` is ``float64``, and so is everything after ``b - a``.
  :func:`percentile` and :func:`percentile_of_sorted` follow the first, :func:`percentiles`
  the second.
* The median of an even count is the mean of the two middle values: ``(a + b) / 2`` in the
  array's type for ``float32`` and ``float64``, in ``float64`` for integers and booleans.

The results are returned as Python floats. NaN, infinite values, -0.0 and ``float16`` are not
handled as NumPy handles them (it returns NaN for NaN input, for instance), and empty input
raises ``ValueError`` where NumPy returns NaN: callers pass finite, non-empty values only.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["percentile_of_sorted", "median_of_sorted", "percentile", "percentiles", "median"]


MAD_TO_SIGMA = 1.4826
"""The median absolute deviation of normally distributed values times this is their standard
deviation."""


def _interpolate(a, b, t):
    """NumPy's ``_lerp`` for one pair ``a <= b`` (NumPy scalars of the array's type) and weight
    ``t``: a Python float keeps the array's type, a ``np.float64`` makes the result ``float64``."""
    difference = b - a
    return b - difference * (1 - t) if t >= 0.5 else a + difference * t


def _position(n: int, q: float) -> tuple[int, float] | None:
    """The lower index and weight of the ``q`` th percentile of ``n`` sorted values, or None
    for the last value (no interpolation)."""
    position = (n - 1) * (q / 100.0)
    if position >= n - 1:
        return None
    low = math.floor(position)
    return low, position - low


def percentile_of_sorted(ordered: np.ndarray, q: float) -> float:
    """``np.percentile(values, q)`` from ``ordered``, the values sorted ascending (1-D, not empty,
    no NaN); ``q`` in ``[0, 100]``."""
    found = _position(ordered.size, q)
    if found is None:
        return float(ordered[-1])
    low, t = found
    return float(_interpolate(ordered[low], ordered[low + 1], t))


def _mean_of_two(a, b) -> float:
    """NumPy's mean of two values of one array: in ``float64`` for integers and booleans, else
    in their type (``float32``, ``float64``; ``float16`` is not handled as NumPy does)."""
    if np.asarray(a).dtype.kind in "biu":
        return (float(a) + float(b)) / 2.0
    return float((a + b) / 2)


def median_of_sorted(ordered: np.ndarray) -> float:
    """``np.median(values)`` from ``ordered``, the values sorted ascending (1-D, not empty, no NaN)."""
    half = ordered.size // 2
    if ordered.size % 2:
        return float(ordered[half])
    return _mean_of_two(ordered[half - 1], ordered[half])


def median(values: np.ndarray) -> float:
    """``np.median(values)`` of a 1-D array (not empty, no NaN) by one partial sort."""
    half = values.size // 2
    part = np.partition(values, half)
    if values.size % 2:
        return float(part[half])
    return _mean_of_two(part[:half].max(), part[half])


def percentile(values: np.ndarray, q: float) -> float:
    """``np.percentile(values, q)`` of a 1-D array (not empty, no NaN) by one partial sort;
    ``q`` in ``[0, 100]``."""
    found = _position(values.size, q)
    if found is None:
        return float(np.max(values))
    low, t = found
    part = np.partition(values, low + 1)     # one k: 3-9x faster than partitioning at (low, low + 1)
    return float(_interpolate(part[:low + 1].max(), part[low + 1], t))


def percentiles(values: np.ndarray, qs: tuple[float, ...]) -> tuple[float, ...]:
    """``tuple(np.percentile(values, list(qs)))`` of a 1-D array (not empty, no NaN) by one sort;
    each ``q`` in ``[0, 100]``. Interpolated in ``float64`` as NumPy does for a list of ``q``."""
    ordered = np.sort(values)
    found = [_position(values.size, q) for q in qs]
    return tuple(float(ordered[-1]) if f is None else
                 float(_interpolate(ordered[f[0]], ordered[f[0] + 1], np.float64(f[1]))) for f in found)
