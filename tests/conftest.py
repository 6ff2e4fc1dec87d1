"""Shared fixtures: the real stereo data beside the checkout, skipped with a reason when absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

_DEFAULT_SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
SHARED_DATA = Path(os.environ.get("STEREO_OBSTACLES_SHARED_DATA", _DEFAULT_SHARED_DATA))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The ``../shared/data`` folder (or ``$STEREO_OBSTACLES_SHARED_DATA``); skip when absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real stereo data not found at {SHARED_DATA} "
                    f"(set STEREO_OBSTACLES_SHARED_DATA to its folder)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def shared_dataset(shared_data):
    """A function returning one dataset folder of the shared data, skipping when it is missing."""
    def get(name: str) -> Path:
        folder = shared_data / name
        if not folder.is_dir():
            pytest.skip(f"dataset {name} not found in {shared_data}")
        return folder
    return get
