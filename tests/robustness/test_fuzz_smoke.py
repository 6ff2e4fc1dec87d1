"""A few seconds of the fuzz run in benchmarks/fuzz_inputs.py: readers and command lines."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

FUZZ = Path(__file__).resolve().parents[2] / "benchmarks" / "fuzz_inputs.py"


@pytest.fixture(scope="module")
def fuzz_module():
    spec = importlib.util.spec_from_file_location("fuzz_inputs", FUZZ)
    module = importlib.util.module_from_spec(spec)
    sys.modules["fuzz_inputs"] = module
    spec.loader.exec_module(module)
    yield module
    del sys.modules["fuzz_inputs"]


def test_fuzz_smoke_finds_no_failure(fuzz_module):
    result = fuzz_module.fuzz(6.0, batch=12, seed=0)
    assert result["readers"] > 0 and result["load_pair"] > 0 and result["cli"] > 0
    assert result["failures"] == []
