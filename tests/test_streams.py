"""Frame sources: video pairs, image sequences, side-by-side video, cameras, and how they are chosen."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from _stream_frames import FPS, N_FRAMES, SIZE, frames, write_side_by_side, write_sequences, write_videos
from stereo_obstacles import streams
from stereo_obstacles.errors import ImageMismatchError, InputFileError, InvalidInputError
from stereo_obstacles.streams import (CameraPairSource, ImageSequenceSource, SideBySideSource, VideoPairSource,
                                      open_source)


def _close(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(np.abs(a.astype(np.float64) - b.astype(np.float64))))


def test_image_sequences_paired_by_name_are_exact(tmp_path):
    left_dir, right_dir = write_sequences(tmp_path)
    with ImageSequenceSource(left_dir, right_dir, fps=FPS) as source:
        got = list(source)
    assert source.total_frames == N_FRAMES
    assert [f.index for f in got] == list(range(N_FRAMES))
    assert [f.timestamp_s for f in got] == pytest.approx([i / FPS for i in range(N_FRAMES)])
    for frame, pair in zip(got, frames()):
        assert frame.left.dtype == np.uint8 and frame.left.shape == (SIZE[1], SIZE[0], 3)
        np.testing.assert_array_equal(frame.left, pair.left)
        np.testing.assert_array_equal(frame.right, pair.right)
    assert got[2].name == "0002"


def test_image_sequences_with_other_names_are_paired_by_order(tmp_path):
    left_dir, right_dir = write_sequences(tmp_path, left_name="cam0_{:d}.png", right_name="cam1_{:d}.png")
    got = list(open_source([str(left_dir), str(right_dir)]))
    assert len(got) == N_FRAMES
    np.testing.assert_array_equal(got[3].right, frames()[3].right)


def test_image_sequences_accept_glob_patterns(tmp_path):
    left_dir, right_dir = write_sequences(tmp_path)
    got = list(open_source([str(left_dir / "000[0-1].png"), str(right_dir / "000[0-1].png")]))
    assert len(got) == 2


def test_image_sequences_of_different_counts_are_refused(tmp_path):
    left_dir, right_dir = write_sequences(tmp_path, left_name="l{:d}.png", right_name="r{:d}.png")
    (right_dir / "r3.png").unlink()
    with pytest.raises(ImageMismatchError, match=r"holds 4 images but .* holds 3"):
        ImageSequenceSource(left_dir, right_dir)


def test_a_frame_missing_on_one_side_of_named_sequences_is_refused(tmp_path):
    # by position, every frame after the gap would meet the wrong right image (found by a review)
    left_dir, right_dir = write_sequences(tmp_path)
    (right_dir / "0001.png").rename(right_dir / "0009.png")
    with pytest.raises(ImageMismatchError, match=r"share 3 image names but not all .*0001\.png and .*0009\.png"):
        ImageSequenceSource(left_dir, right_dir)


def test_files_of_one_stem_and_two_endings_are_paired_by_their_whole_names(tmp_path):
    # 0000.png and 0000.jpg on both sides were refused with an empty file name (found by a review)
    left_dir, right_dir = write_sequences(tmp_path)
    for folder in (left_dir, right_dir):
        for path in sorted(folder.iterdir())[:2]:
            cv2.imwrite(str(path.with_suffix(".jpg")), cv2.imread(str(path)))
    got = list(ImageSequenceSource(left_dir, right_dir))
    assert len(got) == N_FRAMES + 2
    assert [f.name for f in got[:4]] == ["0000.jpg", "0000.png", "0001.jpg", "0001.png"]     # one output folder each


def test_per_camera_timestamps_that_meet_by_chance_are_paired_by_order(tmp_path):
    # one name of four in common was refused as "share 1 image names but not all" (review)
    left_dir, right_dir = write_sequences(tmp_path, left_name="{:d}.png", right_name="{:d}.png")
    for i, stamp in enumerate((1650000000100, 1650000000133, 1650000000167, 1650000000200)):
        (left_dir / f"{i}.png").rename(left_dir / f"{stamp}.png")
        (right_dir / f"{i}.png").rename(right_dir / f"{stamp + (0 if i == 2 else 3)}.png")
    got = list(ImageSequenceSource(left_dir, right_dir))
    assert len(got) == N_FRAMES
    np.testing.assert_array_equal(got[3].right, frames()[3].right)


def test_a_pattern_over_one_folder_per_frame_keeps_the_frames_in_order(tmp_path):
    # the layout `scene --frames` writes: frame_*/left.png; sorted by file name alone, the frames
    # came in folder-listing order, all named "left"
    left_dir, right_dir = write_sequences(tmp_path)
    for i in range(N_FRAMES):
        folder = tmp_path / "seq" / f"frame_{i:04d}"
        folder.mkdir(parents=True)
        (left_dir / f"{i:04d}.png").rename(folder / "left.png")
        (right_dir / f"{i:04d}.png").rename(folder / "right.png")
    got = list(open_source([str(tmp_path / "seq" / "frame_*" / "left.png"),
                            str(tmp_path / "seq" / "frame_*" / "right.png")]))
    assert [f.name for f in got] == [f"frame_{i:04d}_left" for i in range(N_FRAMES)]
    for frame, pair in zip(got, frames()):
        np.testing.assert_array_equal(frame.left, pair.left)
        np.testing.assert_array_equal(frame.right, pair.right)


def test_pairing_by_order_warns_when_the_frame_numbers_disagree(tmp_path, caplog):
    left_dir, right_dir = write_sequences(tmp_path, left_name="cam0_{:d}.png", right_name="cam1_{:d}.png")
    (right_dir / "cam1_1.png").rename(right_dir / "cam1_7.png")
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        ImageSequenceSource(left_dir, right_dir)
    assert "cam0_1.png goes with" in caplog.text and "cam1_2.png" in caplog.text
    for folder, left_name, right_name in (("agreeing", "cam0_{:d}.png", "cam1_{:d}.png"),
                                          ("camera_last", "{:04d}_cam0.png", "{:04d}_cam1.png"),
                                          ("offset", "left_{:04d}.png", "right_1{:03d}.png")):
        caplog.clear()
        left_dir, right_dir = write_sequences(tmp_path / folder, left_name=left_name, right_name=right_name)
        with caplog.at_level("WARNING", logger="stereo_obstacles"):
            ImageSequenceSource(left_dir, right_dir)
        assert caplog.text == "", folder
    # per-camera timestamps (ms) a little apart are in step; the reviewer's names warned
    assert streams.first_out_of_step(["1650000000100.png", "1650000000133.png", "1650000000167.png"],
                                      ["1650000000102.png", "1650000000134.png", "1650000000170.png"]) is None
    assert streams.first_out_of_step(["1650000000100.png", "1650000000133.png", "1650000000167.png"],
                                      ["1650000000102.png", "1650000000170.png", "1650000000200.png"]) == 1
    # seconds with a fraction (TUM): read whole, not as whole seconds then a fraction (review)
    left = [f"{1305031102.9 + k / 30:.6f}.png" for k in range(12)]
    right = [f"{1305031102.885 + k / 30:.6f}.png" for k in range(12)]
    assert streams.first_out_of_step(left, right) is None
    assert streams.first_out_of_step(left[:11], right[:5] + right[6:]) == 5
    # ROS's seconds_nanoseconds, the right camera 4 ms late across a second (review)
    left = [f"left_1680000000_{n:03d}000000.png" for n in (900, 933, 966, 999)]
    right = [f"right_1680000000_{n:03d}000000.png" for n in (904, 937, 970)] + ["right_1680000001_003000000.png"]
    assert streams.first_out_of_step(left, right) is None
    assert streams.first_out_of_step(left[:3], right[:1] + right[2:]) == 1


def test_image_sequence_errors(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputFileError, match="no image files"):
        ImageSequenceSource(tmp_path / "empty", tmp_path / "empty")
    with pytest.raises(InputFileError, match="missing does not exist"):
        ImageSequenceSource(tmp_path / "missing", tmp_path / "missing")
    (tmp_path / "one.txt").write_text("x")
    with pytest.raises(InputFileError, match="one.txt: not a folder and not a glob"):
        ImageSequenceSource(tmp_path / "one.txt", tmp_path / "empty")
    with pytest.raises(InvalidInputError, match="fps"):
        ImageSequenceSource(tmp_path / "empty", tmp_path / "empty", fps=0)


def test_video_pair_reads_frames_in_step(tmp_path):
    left, right = write_videos(tmp_path)
    source = open_source([str(left), str(right)])
    assert isinstance(source, VideoPairSource) and source.total_frames == N_FRAMES
    assert source.fps == pytest.approx(FPS)
    got = list(source)
    assert len(got) == N_FRAMES
    for frame, pair in zip(got, frames()):
        assert frame.left.shape == pair.left.shape
        assert _close(frame.left, pair.left) < 6 and _close(frame.right, pair.right) < 6
        assert _close(frame.left, pair.right) > _close(frame.left, pair.left)   # not swapped
    assert got[1].timestamp_s == pytest.approx(1 / FPS)


def test_video_pair_with_different_frame_counts_is_refused(tmp_path):
    left, right = write_videos(tmp_path, right_frames=N_FRAMES - 1)
    with pytest.raises(ImageMismatchError, match=r"has 4 frames but .* has 3"):
        VideoPairSource(left, right)


def test_a_missing_source_is_named_not_taken_for_an_image_sequence(tmp_path):
    # a typo in the right video's name said "left image sequence L: not a folder and not a glob
    # pattern" of the left video, which exists (review, session 24)
    left, _ = write_videos(tmp_path)
    with pytest.raises(InputFileError, match=r"^\S*missing.avi does not exist \(a video file, a folder of images"):
        open_source([str(left), str(tmp_path / "missing.avi")])
    (tmp_path / "broken.avi").symlink_to(tmp_path / "nowhere.avi")           # a dangling link too (review)
    with pytest.raises(InputFileError, match=r"^\S*broken.avi does not exist"):
        open_source([str(left), str(tmp_path / "broken.avi")])
    with pytest.raises(InputFileError, match=r"left image sequence \S*nodir does not exist"):
        open_source([str(tmp_path / "nodir"), str(tmp_path)], kind="images")


def test_missing_or_broken_video(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        VideoPairSource(tmp_path / "a.avi", tmp_path / "b.avi")
    broken = tmp_path / "broken.avi"
    broken.write_bytes(b"not a video at all")
    with pytest.raises(InputFileError, match="cannot be opened as a video"):
        SideBySideSource(broken)
    # a folder given as the one side-by-side video was "video file F does not exist" (review, session 23)
    (tmp_path / "seq" / "frame_0000").mkdir(parents=True)
    (tmp_path / "seq" / "frame_0000" / "left.png").write_bytes(b"")
    with pytest.raises(InputFileError, match=r"seq is a folder, not a video file; .*'.*seq/frame_\*/left.png'"):
        SideBySideSource(tmp_path / "seq")


def test_side_by_side_video_is_split_in_halves(tmp_path):
    source = open_source([str(write_side_by_side(tmp_path / "sbs.avi"))])
    assert isinstance(source, SideBySideSource)
    got = list(source)
    assert len(got) == N_FRAMES
    for frame, pair in zip(got, frames()):
        assert frame.left.shape == (SIZE[1], SIZE[0], 3)
        assert _close(frame.left, pair.left) < 6 and _close(frame.right, pair.right) < 6


def test_side_by_side_video_of_odd_width_is_refused(monkeypatch):
    class OddCapture:          # OpenCV's writers round widths down, so no real file has an odd width
        released = False

        def get(self, prop):
            return 321.0 if prop == cv2.CAP_PROP_FRAME_WIDTH else 0.0

        def release(self):
            OddCapture.released = True

    monkeypatch.setattr(streams, "_open_video", lambda path: OddCapture())
    with pytest.raises(ImageMismatchError, match="frame width 321 is odd"):
        SideBySideSource("sbs.avi")
    assert OddCapture.released


def test_open_source_checks_arguments(tmp_path):
    with pytest.raises(InvalidInputError, match="kind must be one of"):
        open_source(["a"], kind="tape")
    with pytest.raises(InvalidInputError, match="takes two arguments"):
        open_source(["a"], kind="videos")
    with pytest.raises(InvalidInputError, match="device index"):
        open_source(["a", "b"], kind="cameras")
    with pytest.raises(InvalidInputError, match="must differ"):
        CameraPairSource(3, 3)


def test_missing_cameras_are_reported(tmp_path):
    with pytest.raises(InputFileError, match="camera 98 cannot be opened"):
        open_source(["98", "99"])
