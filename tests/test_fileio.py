"""Round trips and error cases of every reader and writer in stereo_obstacles.fileio."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from stereo_obstacles import fileio
from stereo_obstacles.errors import InputFileError, InvalidInputError, OutputError

shapes = st.tuples(st.integers(1, 17), st.integers(1, 19))


def _float_maps():
    """float32 maps of positive disparities with some NaN."""
    values = st.one_of(st.floats(0.125, 250.0, width=32), st.just(float("nan")))
    return shapes.flatmap(lambda s: hnp.arrays(np.float32, s, elements=values))


@settings(max_examples=40, deadline=None)
@given(_float_maps())
def test_pfm_round_trip_keeps_values_and_nan(tmp_path_factory, disparity):
    path = tmp_path_factory.mktemp("pfm") / "d.pfm"
    fileio.write_pfm(path, disparity)
    back = fileio.read_pfm(path)
    assert back.dtype == np.float32 and back.shape == disparity.shape
    np.testing.assert_array_equal(np.isnan(back), np.isnan(disparity))
    np.testing.assert_array_equal(back[~np.isnan(back)], disparity[~np.isnan(disparity)])


def test_pfm_is_bottom_to_top_little_endian_with_inf_invalid(tmp_path):
    d = np.array([[1.0, np.nan], [3.0, 4.0]], dtype=np.float32)
    path = fileio.write_pfm(tmp_path / "d.pfm", d)
    raw = path.read_bytes()
    header, payload = raw[:len(b"Pf\n2 2\n-1.0\n")], raw[len(b"Pf\n2 2\n-1.0\n"):]
    assert header == b"Pf\n2 2\n-1.0\n"
    rows = np.frombuffer(payload, dtype="<f4").reshape(2, 2)
    np.testing.assert_array_equal(rows[0], [3.0, 4.0])  # the bottom row comes first
    assert rows[1, 0] == 1.0 and np.isposinf(rows[1, 1])


def test_pfm_big_endian_is_read(tmp_path):
    d = np.arange(6, dtype=">f4").reshape(2, 3)
    (tmp_path / "b.pfm").write_bytes(b"Pf\n3 2\n1.0\n" + np.flipud(d).tobytes())
    np.testing.assert_array_equal(fileio.read_pfm(tmp_path / "b.pfm"), d.astype(np.float32))


@pytest.mark.parametrize("content, message", [
    (b"", "empty"),
    (b"P6\n2 2\n255\n" + bytes(12), "not a PFM"),
    (b"Pf\n4 4\n-1.0\n" + bytes(10), "truncated"),
    (b"PF\n1 1\n-1.0\n" + bytes(12), "3-channel"),
])
def test_bad_pfm_files_raise_input_file_error(tmp_path, content, message):
    path = tmp_path / "bad.pfm"
    path.write_bytes(content)
    with pytest.raises(InputFileError, match=message):
        fileio.read_pfm(path)


@settings(max_examples=40, deadline=None)
@given(_float_maps())
def test_kitti_png_round_trip_within_quantisation(tmp_path_factory, disparity):
    path = tmp_path_factory.mktemp("kitti") / "d.png"
    fileio.write_kitti_disparity(path, disparity)
    back = fileio.read_kitti_disparity(path)
    np.testing.assert_array_equal(np.isnan(back), np.isnan(disparity))
    valid = ~np.isnan(disparity)
    assert np.all(np.abs(back[valid] - disparity[valid]) <= 0.5 / 256 + 1e-4)


def test_kitti_png_stores_d_times_256_and_zero_for_invalid(tmp_path):
    path = fileio.write_kitti_disparity(tmp_path / "d.png", np.array([[1.5, np.nan]], np.float32))
    raw = fileio.read_image(path)
    assert raw.dtype == np.uint16 and raw.tolist() == [[384, 0]]


def test_kitti_png_rejects_disparity_it_cannot_hold(tmp_path):
    with pytest.raises(InvalidInputError, match="does not fit a KITTI PNG"):
        fileio.write_kitti_disparity(tmp_path / "d.png", np.array([[300.0]], np.float32))
    assert not list(tmp_path.iterdir())


def test_eight_bit_png_is_not_a_kitti_disparity(tmp_path):
    fileio.write_image(tmp_path / "g.png", np.zeros((3, 3), np.uint8))
    with pytest.raises(InputFileError, match="not a KITTI disparity"):
        fileio.read_kitti_disparity(tmp_path / "g.png")


@settings(max_examples=30, deadline=None)
@given(_float_maps())
def test_npy_round_trip_is_exact(tmp_path_factory, disparity):
    path = tmp_path_factory.mktemp("npy") / "d.npy"
    fileio.write_disparity(path, disparity)
    np.testing.assert_array_equal(fileio.read_disparity(path), disparity)


def test_npy_reader_rejects_pickles_and_wrong_shapes(tmp_path):
    np.save(tmp_path / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InputFileError, match="not a valid .npy"):
        fileio.read_npy(tmp_path / "obj.npy")
    np.save(tmp_path / "cube.npy", np.zeros((2, 2, 2), np.float32))
    with pytest.raises(InputFileError, match="2-D float"):
        fileio.read_npy(tmp_path / "cube.npy")


@pytest.mark.parametrize("suffix", [".npy", ".pfm", ".png"])
def test_depth_round_trip(tmp_path, suffix):
    depth = np.array([[0.5, 12.345], [np.nan, 65.0]], dtype=np.float32)
    back = fileio.read_depth(fileio.write_depth(tmp_path / f"z{suffix}", depth))
    tolerance = 0.0005 if suffix == ".png" else 0.0
    np.testing.assert_array_equal(np.isnan(back), np.isnan(depth))
    assert np.nanmax(np.abs(back - depth)) <= tolerance


@settings(max_examples=25, deadline=None)
@given(shapes.flatmap(lambda s: hnp.arrays(np.uint8, s + (3,))))
def test_colour_png_round_trip_keeps_rgb_order(tmp_path_factory, rgb):
    path = tmp_path_factory.mktemp("img") / "c.png"
    fileio.write_image(path, rgb)
    np.testing.assert_array_equal(fileio.read_image(path), rgb)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from([np.uint8, np.uint16]).flatmap(lambda t: shapes.flatmap(lambda s: hnp.arrays(t, s))))
def test_grey_png_round_trip_8_and_16_bit(tmp_path_factory, grey):
    path = tmp_path_factory.mktemp("img") / "g.png"
    fileio.write_image(path, grey)
    back = fileio.read_image(path)
    assert back.dtype == grey.dtype
    np.testing.assert_array_equal(back, grey)


def test_read_image_channel_order_is_rgb(tmp_path):
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[..., 0] = 200  # red
    fileio.write_image(tmp_path / "red.png", rgb)
    assert fileio.read_image(tmp_path / "red.png", mode="color")[0, 0].tolist() == [200, 0, 0]


def test_read_image_drops_alpha(tmp_path):
    import cv2
    bgra = np.zeros((2, 2, 4), np.uint8)
    bgra[..., 2], bgra[..., 3] = 50, 255
    cv2.imwrite(str(tmp_path / "a.png"), bgra)
    assert fileio.read_image(tmp_path / "a.png").shape == (2, 2, 3)
    assert fileio.read_image(tmp_path / "a.png")[0, 0].tolist() == [50, 0, 0]


def test_grey_image_is_refused_where_colour_is_needed(tmp_path):
    fileio.write_image(tmp_path / "g.png", np.full((4, 4), 7, np.uint8))
    with pytest.raises(InputFileError, match="grey image"):
        fileio.read_image(tmp_path / "g.png", mode="color")
    fileio.write_image(tmp_path / "g3.png", np.full((4, 4, 3), 7, np.uint8))
    with pytest.raises(InputFileError, match="grey image stored as colour"):
        fileio.read_image(tmp_path / "g3.png", mode="color")


def test_colour_image_read_as_grey(tmp_path):
    fileio.write_image(tmp_path / "c.png", np.full((4, 5, 3), 100, np.uint8))
    grey = fileio.read_image(tmp_path / "c.png", mode="gray")
    assert grey.shape == (4, 5) and grey.dtype == np.uint8 and int(grey[0, 0]) == 100


@pytest.mark.parametrize("make, message", [
    (lambda p: None, "does not exist"),
    (lambda p: p.write_bytes(b""), "empty"),
    (lambda p: p.write_text("hello, not an image"), "not an image"),
    (lambda p: p.mkdir(), "is a folder"),
])
def test_bad_image_files_raise_input_file_error_naming_the_file(tmp_path, make, message):
    path = tmp_path / "left.png"
    make(path)
    with pytest.raises(InputFileError, match=message) as info:
        fileio.read_image(path)
    assert "left.png" in str(info.value)


def test_truncated_png_is_refused(tmp_path):
    path = fileio.write_image(tmp_path / "full.png", np.random.default_rng(0).integers(0, 255, (64, 64, 3), np.uint8))
    cut = tmp_path / "cut.png"
    cut.write_bytes(path.read_bytes()[:200])
    with pytest.raises(InputFileError, match="not an image"):
        fileio.read_image(cut)


def test_labels_round_trip_and_validation(tmp_path):
    labels = np.arange(12, dtype=np.uint8).reshape(3, 4)
    np.testing.assert_array_equal(fileio.read_labels(fileio.write_labels(tmp_path / "l.png", labels)), labels)
    with pytest.raises(OutputError, match="lossless"):
        fileio.write_labels(tmp_path / "l.jpg", labels)
    with pytest.raises(InvalidInputError, match="uint8"):
        fileio.write_labels(tmp_path / "l.png", labels.astype(np.int32))


def test_unknown_extensions_are_refused(tmp_path):
    d = np.ones((2, 2), np.float32)
    with pytest.raises(OutputError, match=".npy, .pfm or .png"):
        fileio.write_disparity(tmp_path / "d.txt", d)
    with pytest.raises(InputFileError, match=".npy, .pfm or .png"):
        fileio.read_disparity(tmp_path / "d.txt")
    with pytest.raises(OutputError, match="unknown image extension"):
        fileio.write_image(tmp_path / "x.xyz", np.zeros((2, 2), np.uint8))


def test_writers_refuse_integer_maps(tmp_path):
    with pytest.raises(InvalidInputError, match="floating point"):
        fileio.write_pfm(tmp_path / "d.pfm", np.ones((2, 2), np.int32))
