"""Binary PLY point clouds: round trip, NaN skipped, header layout and comments, bad files."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from stereo_obstacles.errors import InputFileError, InvalidInputError
from stereo_obstacles.point_cloud import FRAME_COMMENT, read_ply, write_ply


def _clouds():
    """(points, colours) with shape (N, 3) or (H, W, 3) and some NaN coordinates."""
    shape = st.one_of(st.tuples(st.integers(0, 30), st.just(3)),
                      st.tuples(st.integers(1, 6), st.integers(1, 7), st.just(3)))
    coordinate = st.one_of(st.floats(-1e4, 1e4, width=32), st.just(float("nan")))
    return shape.flatmap(lambda s: st.tuples(hnp.arrays(np.float32, s, elements=coordinate),
                                             hnp.arrays(np.uint8, s)))


@settings(max_examples=40, deadline=None)
@given(_clouds())
def test_round_trip_keeps_finite_points_and_their_colours_in_order(tmp_path_factory, cloud):
    points, colours = cloud
    path = write_ply(tmp_path_factory.mktemp("ply") / "p.ply", points, colours)
    back = read_ply(path)
    keep = np.isfinite(points.reshape(-1, 3)).all(axis=1)
    assert back.points.dtype == np.float32 and back.colours.dtype == np.uint8
    np.testing.assert_array_equal(back.points, points.reshape(-1, 3)[keep])
    np.testing.assert_array_equal(back.colours, colours.reshape(-1, 3)[keep])


def test_header_is_binary_little_endian_with_frame_units_and_properties(tmp_path):
    points = np.array([[[0.5, -0.25, 2.0], [np.nan, np.nan, np.nan]]], np.float32)
    colours = np.array([[[10, 20, 30], [1, 2, 3]]], np.uint8)
    path = write_ply(tmp_path / "p.ply", points, colours, comments=["scene: test"])
    raw = path.read_bytes()
    header, payload = raw.split(b"end_header\n")
    lines = header.decode("ascii").splitlines()
    assert lines[:2] == ["ply", "format binary_little_endian 1.0"]
    assert f"comment {FRAME_COMMENT}" in lines and "comment units: metres" in lines
    assert "comment scene: test" in lines and "element vertex 1" in lines
    assert lines[-6:] == ["property float x", "property float y", "property float z",
                          "property uchar red", "property uchar green", "property uchar blue"]
    assert "x right, y down, z forward" in FRAME_COMMENT
    assert len(payload) == 15
    assert np.frombuffer(payload[:12], "<f4").tolist() == [0.5, -0.25, 2.0] and payload[12:] == bytes([10, 20, 30])
    assert read_ply(path).comments[-1] == "scene: test"


def test_a_point_with_any_nan_or_inf_coordinate_is_skipped(tmp_path):
    points = np.array([[1, 2, 3], [np.nan, 2, 3], [1, np.inf, 3], [1, 2, np.nan], [4, 5, 6]], np.float64)
    colours = np.arange(15, dtype=np.uint8).reshape(5, 3)
    back = read_ply(write_ply(tmp_path / "p.ply", points, colours))
    np.testing.assert_array_equal(back.points, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(back.colours, [[0, 1, 2], [12, 13, 14]])


@pytest.mark.parametrize("points, colours, message", [
    (np.zeros((4, 2)), np.zeros((4, 2), np.uint8), "points must be \\(N, 3\\)"),
    (np.zeros((4, 3), np.int32), np.zeros((4, 3), np.uint8), "floating point"),
    (np.zeros((4, 3)), np.zeros((5, 3), np.uint8), "colours must have the shape"),
    (np.zeros((4, 3)), np.zeros((4, 3), np.float32), "colours must be uint8"),
])
def test_bad_arguments(tmp_path, points, colours, message):
    with pytest.raises(InvalidInputError, match=message):
        write_ply(tmp_path / "p.ply", points, colours)
    assert not (tmp_path / "p.ply").exists()


def test_multi_line_comment_is_refused(tmp_path):
    with pytest.raises(InvalidInputError, match="single lines"):
        write_ply(tmp_path / "p.ply", np.zeros((1, 3)), np.zeros((1, 3), np.uint8), comments=["a\nb"])


_GOOD_HEADER = ("ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")


@pytest.mark.parametrize("content, message", [
    (b"solid cube\n", "not a PLY file"),
    (b"ply\nformat binary_little_endian 1.0\nelement vertex 1\n", "no end_header"),
    (_GOOD_HEADER.replace("binary_little_endian", "ascii").encode() + b"1 2 3 4 5 6\n", "only binary_little_endian"),
    (_GOOD_HEADER.replace("property uchar blue\n", "property uchar blue\nelement face 1\n"
                          "property list uchar int vertex_indices\n").encode(), "one 'element vertex N'"),
    (_GOOD_HEADER.replace("float x", "double x").encode() + bytes(40), "expected vertex properties"),
    (_GOOD_HEADER.encode() + bytes(20), "truncated: 20 bytes of vertices, 30 expected"),
])
def test_other_content_raises_input_file_error(tmp_path, content, message):
    path = tmp_path / "bad.ply"
    path.write_bytes(content)
    with pytest.raises(InputFileError, match=message):
        read_ply(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        read_ply(tmp_path / "none.ply")
