"""The documented image-size limits: a clear refusal with the memory figure, not an OOM kill."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles import match_memory
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.matching import match


def test_the_estimate_grows_with_the_pixels():
    assert match_memory.matching_memory_bytes(640, 480) == match_memory.MATCH_BYTES_PER_PIXEL * 640 * 480


def test_above_the_pixel_limit_the_message_gives_the_figures():
    with pytest.raises(InvalidInputError, match=r"10000x10000 images \(100 Mpx\) exceed the matching limit of "
                                                r"64 Mpx \(matching would need about 25.6 GB\)"):
        match_memory.check_matching_size(10_000, 10_000)


def test_more_than_the_available_memory_is_refused():
    with pytest.raises(InvalidInputError, match=r"needs about 2.0 GB but only 1.0 GB of memory is available"):
        match_memory.check_matching_size(4000, 2000, available_bytes=1_000_000_000)
    match_memory.check_matching_size(640, 480, available_bytes=1_000_000_000)


def test_available_memory_is_known_on_linux():
    available = match_memory.available_memory_bytes()
    assert available is None or available > 0


def test_match_refuses_before_allocating(monkeypatch):
    monkeypatch.setattr(match_memory, "MAX_MATCH_PIXELS", 100)
    image = np.random.default_rng(0).uniform(0, 255, (20, 20)).astype(np.float32)
    with pytest.raises(InvalidInputError, match="exceed the matching limit"):
        match(image, image)


def test_the_cli_reports_the_limit_as_one_line(inputs, run_cli, tmp_path, monkeypatch):
    monkeypatch.setattr(match_memory, "MAX_MATCH_PIXELS", 1000)
    code, _, err, _ = run_cli("disparity", inputs / "left.png", inputs / "right.png", "-o", tmp_path / "d.npy")
    assert code == 1 and "160x120 images (0 Mpx) exceed the matching limit" in err
