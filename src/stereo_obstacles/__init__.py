"""stereo-obstacles: where the obstacles in front of two colour cameras are, and how far away.

The package is organised as stages (segmentation, matching, depth, obstacles) that are
plain functions from arrays to arrays or small frozen dataclasses; see the README.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("stereo-obstacles")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
