"""Exception types raised by the library.

Every error a user can cause derives from :class:`StereoObstaclesError`; the command line
turns it into one line on stderr and a non-zero exit code. Messages name the file or the
argument at fault and, where it helps, what was expected against what was found.
"""

from __future__ import annotations


class StereoObstaclesError(Exception):
    """Base class of every error a caller of the library can cause."""


class InputFileError(StereoObstaclesError, OSError):
    """A file to read is missing, unreadable, empty, truncated or not in the expected format."""


class InvalidInputError(StereoObstaclesError, ValueError):
    """An argument (array, option, parameter) has the wrong shape, type or value."""


class ImageMismatchError(InvalidInputError):
    """The left and right images (or an image and its ground truth) do not fit together."""


class CalibrationError(InvalidInputError):
    """A calibration is missing, does not parse, or holds impossible values."""


class OutputError(StereoObstaclesError, OSError):
    """An output file or folder cannot be written."""


class RectificationError(InvalidInputError):
    """A pair cannot be rectified: too few feature matches, or a degenerate camera motion."""
