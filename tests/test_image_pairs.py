"""The size and type check of a stereo pair read from two files."""

from __future__ import annotations

import numpy as np
import pytest

from stereo_obstacles.errors import ImageMismatchError
from stereo_obstacles.image_pairs import check_pair_of_files


def test_a_pair_of_files_is_refused_by_size_type_and_channels_naming_both_files():
    colour = np.zeros((48, 64, 3), np.uint8)
    check_pair_of_files(colour, colour.copy(), "l.png", "r.png")
    with pytest.raises(ImageMismatchError, match=r"^l.png is 64x48 but r.png is 32x48; a stereo pair needs one size$"):
        check_pair_of_files(colour, colour[:, :32], "l.png", "r.png")
    with pytest.raises(ImageMismatchError, match=r"^l.png is uint16 but r.png is uint8$"):
        check_pair_of_files(colour.astype(np.uint16), colour, "l.png", "r.png")
    with pytest.raises(ImageMismatchError, match=r"^l.png is 3-channel but r.png is grey$"):
        check_pair_of_files(colour, colour[..., 0], "l.png", "r.png")
    check_pair_of_files(colour, colour[..., 0], "l.png", "r.png", channels=False)     # the matcher takes both
