"""Checks of the fields of the frozen parameter dataclasses, each failing with one clear line."""

from __future__ import annotations

import dataclasses
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


def python_number(value: object) -> object:
    """``value`` as a Python number when it is a NumPy integer or floating-point scalar (a
    ``longdouble`` too) or a 0-d array of one; a tuple with each such element converted; any
    other value as it is."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value[()]
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, tuple) and any(isinstance(v, (np.generic, np.ndarray)) for v in value):
        return tuple(python_number(v) for v in value)
    return value


def plain_number(owner: object, name: str) -> object:
    """``owner.name``, replaced on ``owner`` (a frozen dataclass too) by :func:`python_number` of
    it: a field that came from an array (``K[0, 0]``, ``image.shape`` of a NumPy array of sizes,
    a tuple of thresholds) is then JSON-ready, and a narrow integer cannot overflow in the sizes
    computed from it."""
    value = getattr(owner, name)
    plain = python_number(value)
    if plain is not value:
        object.__setattr__(owner, name, plain)
    return plain


def plain_numbers(owner: object) -> None:
    """:func:`plain_number` on every field of the dataclass ``owner``."""
    for field in dataclasses.fields(owner):
        plain_number(owner, field.name)


def check_numbers(owner: object, ranges: Iterable[tuple[str, float, float]]) -> None:
    """Each ``(name, low, high)``: ``owner.name`` must be a finite real number (Python's or NumPy's,
    not a bool) in ``[low, high]``; a NumPy one is replaced by the Python number
    (:func:`plain_number`).

    Raises
    ------
    InvalidInputError
        ``"<name> must be in [low, high], got <value>"`` for the first field that is not.
    """
    for name, low, high in ranges:
        value = plain_number(owner, name)
        if not is_finite_real(value) or not low <= value <= high:
            raise InvalidInputError(f"{name} must be in [{low}, {high}], got {value!r}")


def check_positive(owner: object, names: Iterable[str]) -> None:
    """Each ``owner.name`` must be a finite real number (Python's or NumPy's, not a bool) above 0;
    a NumPy one is replaced by the Python number (:func:`plain_number`).

    Raises
    ------
    InvalidInputError
        ``"<name> must be a finite number > 0, got <value>"`` for the first field that is not.
    """
    for name in names:
        value = plain_number(owner, name)
        if not (is_finite_real(value) and value > 0):
            raise InvalidInputError(f"{name} must be a finite number > 0, got {value!r}")


def check_integers(owner: object, ranges: Iterable[tuple[str, int, int]], *, odd: bool = False) -> None:
    """Each ``(name, low, high)``: ``owner.name`` must be an integer, Python's or NumPy's (not a
    bool; a NumPy one is replaced by the Python integer, :func:`plain_number`), in ``[low, high]``,
    and odd when ``odd`` (a window side).

    Raises
    ------
    InvalidInputError
        ``"<name> must be an (odd) integer in [low, high], got <value>"`` for the first field
        that is not.
    """
    for name, low, high in ranges:
        value = plain_number(owner, name)
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


__all__ = ["python_number", "plain_number", "plain_numbers", "check_numbers", "check_positive", "check_integers",
           "check_types"]
