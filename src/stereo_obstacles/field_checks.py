"""Checks of the fields of the frozen parameter dataclasses, each failing with one clear line."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable

import numpy as np

from stereo_obstacles.errors import InvalidInputError


def is_finite_real(value: object) -> bool:
    """True for a finite real number, Python's or NumPy's, other than a bool (an integer too
    large for a float is not finite)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def is_whole_number(value: object) -> bool:
    """True for an integer, Python's or NumPy's, other than a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def check_numbers(owner: object, ranges: Iterable[tuple[str, float, float]]) -> None:
    """Each ``(name, low, high)``: ``owner.name`` must be a finite real number (Python's or NumPy's,
    not a bool) in ``[low, high]``.

    Raises
    ------
    InvalidInputError
        ``"<name> must be in [low, high], got <value>"`` for the first field that is not.
    """
    for name, low, high in ranges:
        value = getattr(owner, name)
        if not is_finite_real(value) or not low <= value <= high:
            raise InvalidInputError(f"{name} must be in [{low}, {high}], got {value!r}")


def check_positive(owner: object, names: Iterable[str]) -> None:
    """Each ``owner.name`` must be a finite real number (Python's or NumPy's, not a bool) above 0.

    Raises
    ------
    InvalidInputError
        ``"<name> must be a finite number > 0, got <value>"`` for the first field that is not.
    """
    for name in names:
        value = getattr(owner, name)
        if not (is_finite_real(value) and value > 0):
            raise InvalidInputError(f"{name} must be a finite number > 0, got {value!r}")


def check_integers(owner: object, ranges: Iterable[tuple[str, int, int]], *, odd: bool = False) -> None:
    """Each ``(name, low, high)``: ``owner.name`` must be a Python integer (not a bool; a narrow
    NumPy integer would overflow in the sizes computed from it) in ``[low, high]``, and odd when
    ``odd`` (a window side).

    Raises
    ------
    InvalidInputError
        ``"<name> must be an (odd) integer in [low, high], got <value>"`` for the first field
        that is not.
    """
    for name, low, high in ranges:
        value = getattr(owner, name)
        if (isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high
                or (odd and value % 2 == 0)):
            kind = "an odd integer" if odd else "an integer"
            raise InvalidInputError(f"{name} must be {kind} in [{low}, {high}], got {value!r}")


def check_types(owner: object, kinds: Iterable[tuple[str, type]], *, allow_none: bool = False) -> None:
    """Each ``(name, kind)``: ``owner.name`` must be an instance of ``kind`` (a nested parameter
    dataclass), or None when ``allow_none`` (a stage switched off).

    Raises
    ------
    InvalidInputError
        ``"<name> must be <Kind> (or None), got <type>"`` for the first field that is not.
    """
    for name, kind in kinds:
        value = getattr(owner, name)
        if not (isinstance(value, kind) or (allow_none and value is None)):
            expected = f"{kind.__name__} or None" if allow_none else kind.__name__
            raise InvalidInputError(f"{name} must be {expected}, got {type(value).__name__}")


__all__ = ["check_numbers", "check_positive", "check_integers", "check_types"]
