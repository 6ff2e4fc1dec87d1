"""Every Examples section of the package's docstrings runs and shows what it says."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import stereo_obstacles

MODULES = sorted(name for _, name, _ in pkgutil.walk_packages(stereo_obstacles.__path__, "stereo_obstacles.")
                 if not name.endswith("__main__"))


@pytest.mark.parametrize("module", MODULES)
def test_docstring_examples_run(module):
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_the_examples_cover_the_main_modules():
    attempted = {m: doctest.testmod(importlib.import_module(m), optionflags=doctest.NORMALIZE_WHITESPACE).attempted
                 for m in ("stereo_obstacles.matching", "stereo_obstacles.refinement", "stereo_obstacles.pipeline",
                           "stereo_obstacles.synthetic", "stereo_obstacles.temporal_seeds")}
    assert all(attempted.values()), attempted
