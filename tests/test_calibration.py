"""The calibration dataclass, its JSON format, and the readers of other people's formats."""

from __future__ import annotations

import json

import numpy as np
import pytest

from stereo_obstacles.calibration import StereoCalibration, read_calibration_json, write_calibration_json
from stereo_obstacles.calibration_files import read_calibration
from stereo_obstacles.errors import CalibrationError, InputFileError

RIG = StereoCalibration(focal_px=700.0, cx_px=320.5, cy_px=240.25, baseline_m=0.12, width_px=640, height_px=480)


def test_json_round_trip(tmp_path):
    write_calibration_json(tmp_path / "c.json", RIG)
    assert read_calibration_json(tmp_path / "c.json") == RIG
    assert read_calibration(tmp_path / "c.json") == RIG
    assert json.loads((tmp_path / "c.json").read_text())["format"] == "stereo-obstacles/calibration"


@pytest.mark.parametrize("change, message", [
    ({"baseline_m": 0.0}, "baseline_m must be > 0"),
    ({"baseline_m": -0.1}, "baseline_m must be > 0"),
    ({"baseline_m": 120.0}, "implausible"),
    ({"focal_px": 0.0}, "focal_px must be > 0"),
    ({"focal_px": float("nan")}, "finite number"),
    ({"cx_px": float("inf")}, "finite number"),
    ({"width_px": 0}, "positive integer"),
    ({"height_px": 2.5}, "positive integer"),
])
def test_impossible_values_are_refused(change, message):
    fields = {**RIG.__dict__, **change}
    with pytest.raises(CalibrationError, match=message):
        StereoCalibration(**fields)


def test_image_size_check():
    RIG.check_image_size(640, 480)
    with pytest.raises(CalibrationError, match="640x480 images, the images are 320x240"):
        RIG.check_image_size(320, 240)
    StereoCalibration(focal_px=10.0, cx_px=0.0, cy_px=0.0, baseline_m=1.0).check_image_size(5, 5)


def test_a_principal_point_far_from_the_centre_is_doubted_only_without_an_image_size():
    kitti = StereoCalibration(focal_px=721.5, baseline_m=0.54, cx_px=609.6, cy_px=172.9)
    assert kitti.off_centre_doubt(1242, 375) is None
    doubt = kitti.off_centre_doubt(621, 188)                     # its images halved: distances doubled
    assert "(609.6, 172.9) px lies far from the centre of the 621x188 images" in doubt
    assert kitti.off_centre_doubt(1242, 188) is not None         # off in y alone
    sized = StereoCalibration(focal_px=721.5, baseline_m=0.54, cx_px=609.6, cy_px=172.9, width_px=621, height_px=188)
    assert sized.off_centre_doubt(621, 188) is None              # its size was checked exactly instead


def test_detect_warns_of_a_calibration_that_fits_other_images(shared_dataset, tmp_path, caplog):
    import cv2

    from stereo_obstacles.cli import main

    kitti = shared_dataset("kitti2015_000005")
    for side in ("left", "right"):
        image = cv2.imread(str(kitti / f"000005_10_{side}.png"))
        cv2.imwrite(str(tmp_path / f"{side}.png"), cv2.resize(image, (621, 188), interpolation=cv2.INTER_AREA))
    with caplog.at_level("WARNING", logger="stereo_obstacles"):
        assert main(["detect", str(tmp_path / "left.png"), str(tmp_path / "right.png"), "--calib",
                     str(kitti / "Calib.txt"), "--out", str(tmp_path / "out")]) == 0
    assert caplog.text.count("lies far from the centre of the 621x188 images") == 1   # not again by detect itself
    recorded = json.loads((tmp_path / "out" / "obstacles.json").read_text())["calibration"]
    assert (recorded["width_px"], recorded["height_px"]) == (621, 188)                # the size it was used for


def test_json_with_wrong_content_is_refused(tmp_path):
    path = tmp_path / "c.json"
    path.write_text('{"format": "stereo-obstacles/calibration", "version": 1, "focal_px": 1}')
    with pytest.raises(CalibrationError, match="lacks cx_px"):
        read_calibration(path)
    path.write_text('{"focal_px": 1')
    with pytest.raises(CalibrationError, match="is not valid JSON"):
        read_calibration(path)
    path.write_text('{"format": "something else"}')
    with pytest.raises(CalibrationError, match="is not a stereo-obstacles/calibration"):
        read_calibration(path)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        read_calibration(tmp_path / "none.txt")
    (tmp_path / "bin").write_bytes(bytes(range(256)))
    with pytest.raises(CalibrationError, match="not a text file"):
        read_calibration(tmp_path / "bin")
    (tmp_path / "prose.txt").write_text("hello world\n")
    with pytest.raises(CalibrationError, match="not a calibration format"):
        read_calibration(tmp_path / "prose.txt")


def test_kitti_file_without_the_right_projection_names_it(tmp_path):
    projection = " ".join(["721.5", "0", "609.6", "0", "0", "721.5", "172.9", "0", "0", "0", "1", "0"])
    (tmp_path / "calib.txt").write_text(f"P_rect_02: {projection}\n")
    with pytest.raises(CalibrationError, match="with P_rect_02 but without P_rect_03"):
        read_calibration(tmp_path / "calib.txt")


def test_middlebury_2014_calib(shared_dataset):
    c = read_calibration(shared_dataset("calibration_examples") / "middlebury2014_Adirondack-perfect_calib.txt")
    assert (c.focal_px, c.cx_px, c.cy_px) == (4161.221, 1445.577, 984.686)
    assert c.baseline_m == pytest.approx(0.176252)
    assert c.doffs_px == pytest.approx(209.059)
    assert (c.width_px, c.height_px) == (2880, 1988)


def test_kitti_calib_of_frame_000005(shared_dataset):
    c = read_calibration(shared_dataset("kitti2015_000005") / "Calib.txt")
    assert c.focal_px == pytest.approx(721.5377)
    assert (c.cx_px, c.cy_px) == pytest.approx((609.5593, 172.854))
    assert c.baseline_m == pytest.approx(0.5327, abs=2e-4)
    assert c.doffs_px == 0.0 and c.width_px is None


def test_kitti_raw_cam_to_cam_agrees_with_the_frame_calib(shared_dataset):
    raw = read_calibration(shared_dataset("calibration_examples") / "kitti_raw_2011_09_26_calib_cam_to_cam.txt")
    frame = read_calibration(shared_dataset("kitti2015_000005") / "Calib.txt")
    assert raw.focal_px == frame.focal_px and raw.baseline_m == pytest.approx(frame.baseline_m)
    assert (raw.width_px, raw.height_px) == (1242, 375)


def test_q_matrix_agrees_with_p_rect(shared_dataset):
    q = read_calibration(shared_dataset("kitti2015_000005") / "Q.dat")
    p = read_calibration(shared_dataset("kitti2015_000005") / "Calib.txt")
    assert q.focal_px == pytest.approx(p.focal_px)
    assert q.baseline_m == pytest.approx(p.baseline_m, rel=1e-3)
    assert (q.cx_px, q.cy_px) == pytest.approx((p.cx_px, p.cy_px))


def test_opencv_yaml_needs_its_length_unit(shared_dataset):
    path = shared_dataset("calibration_examples") / "opencv_stereo_chessboard" / "cameraParams_from_CppStereoMatching.yml"
    with pytest.raises(CalibrationError, match="--calib-unit mm"):
        read_calibration(path)
    c = read_calibration(path, length_unit="mm")
    assert c.focal_px == pytest.approx(430.8037, rel=1e-6)
    assert c.baseline_m == pytest.approx(35999.428823379807 / 430.80372885701422 / 1000)
    assert c.doffs_px == pytest.approx(303.89015197753906 - 332.17965698242188)
    assert (c.width_px, c.height_px) == (640, 480)


def test_opencv_image_list_is_not_a_calibration(shared_dataset, tmp_path):
    # it was told to "rectify with stereoRectify first" (user-level review, session 23)
    with pytest.raises(CalibrationError, match="no rectified projection matrices P1 and P2: not a stereo calibration"):
        read_calibration(shared_dataset("calibration_examples") / "opencv_stereo_chessboard" / "stereo_calib.xml")
    raw = tmp_path / "raw.yml"                     # the raw cameras only, where a rectified calibration is read
    raw.write_text("%YAML:1.0\n---\ncameraMatrix1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                   "   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n")
    with pytest.raises(CalibrationError, match="it describes the raw cameras .*give it with --calib to a command"):
        read_calibration(raw)


def test_opencv_xml_written_by_opencv_is_read(tmp_path):
    import cv2
    path = str(tmp_path / "rig.xml")
    storage = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    storage.write("P1", np.array([[600.0, 0, 310, 0], [0, 600, 200, 0], [0, 0, 1, 0]]))
    storage.write("P2", np.array([[600.0, 0, 310, -600 * 0.1], [0, 600, 200, 0], [0, 0, 1, 0]]))
    storage.release()
    c = read_calibration(path)
    assert (c.focal_px, c.cx_px, c.cy_px, c.baseline_m, c.doffs_px) == pytest.approx((600, 310, 200, 0.1, 0))


@pytest.mark.parametrize("image_size", [np.array([[640, 480]], np.int32), np.array((640, 480)), [640, 480]])
def test_opencv_yaml_with_its_image_size_as_a_matrix_or_a_list_is_read(tmp_path, image_size):
    # a matrix is what calibrate and Python's FileStorage.write of an array write; stereo_calib.cpp a list
    import cv2
    path = str(tmp_path / "rig.yml")
    storage = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    storage.write("P1", np.array([[600.0, 0, 310, 0], [0, 600, 200, 0], [0, 0, 1, 0]]))
    storage.write("P2", np.array([[600.0, 0, 310, -600 * 0.1], [0, 600, 200, 0], [0, 0, 1, 0]]))
    if isinstance(image_size, list):
        storage.startWriteStruct("imageSize", cv2.FileNode_SEQ)
        for value in image_size:
            storage.write("", value)
        storage.endWriteStruct()
    else:
        storage.write("imageSize", image_size)
    storage.release()
    c = read_calibration(path)
    assert (c.width_px, c.height_px, c.focal_px, c.baseline_m) == pytest.approx((640, 480, 600, 0.1))


@pytest.mark.parametrize("image_size", ["!!opencv-matrix\n   rows: 0\n   cols: 0\n   dt: i\n   data: []",
                                        "[ .nan, 120 ]", "160", "abc", "{width: 640, height: 480}", "[ [160], [120] ]",
                                        "[ 640, 480, 3 ]", "[ 160.7, 120 ]", "[ a, b ]", "[ -640, 480 ]"])
def test_an_image_size_that_is_not_two_positive_whole_numbers_is_one_clear_error(tmp_path, image_size):
    from stereo_obstacles.camera_calibration import read_camera_calibration

    matrix = "!!opencv-matrix\n   rows: {}\n   cols: {}\n   dt: d\n   data: [ {} ]\n"
    rectified = (f"P1: {matrix.format(3, 4, '600, 0, 310, 0, 0, 600, 200, 0, 0, 0, 1, 0')}"
                 f"P2: {matrix.format(3, 4, '600, 0, 310, -60, 0, 600, 200, 0, 0, 0, 1, 0')}")
    pair = (f"cameraMatrix1: {matrix.format(3, 3, '600, 0, 310, 0, 600, 200, 0, 0, 1')}"
            f"cameraMatrix2: {matrix.format(3, 3, '600, 0, 310, 0, 600, 200, 0, 0, 1')}"
            f"R: {matrix.format(3, 3, '1, 0, 0, 0, 1, 0, 0, 0, 1')}T: {matrix.format(3, 1, '-0.1, 0, 0')}")
    for body, reader in ((rectified, read_calibration), (pair, read_camera_calibration)):
        path = tmp_path / "rig.yml"
        path.write_text(f"%YAML:1.0\n---\n{body}imageSize: {image_size}\n")
        with pytest.raises(CalibrationError, match="imageSize must hold 2 positive whole numbers"):
            reader(path)


@pytest.mark.parametrize("p1", ["5", "[ 1, 2, 3 ]", "{ rows: 3 }", "abc",
                                "!!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 1, 2, 3 ]",
                                "!!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: q\n   data: [ 1, 2, 3 ]"])
def test_a_projection_that_is_not_a_matrix_is_named(tmp_path, p1):
    # "P1: 5" gave OpenCV's assertion text: "OpenCV(5.0.0) .../persistence.cpp:2294: error: (-215:Assertion
    # failed) isMap() in function 'operator[]'" (review, session 24)
    matrix = "!!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n   data: [ 600, 0, 310, -60, 0, 600, 200, 0, 0, 0, 1, 0 ]\n"
    path = tmp_path / "rig.yml"
    path.write_text(f"%YAML:1.0\n---\nP1: {p1}\nP2: {matrix}")
    with pytest.raises(CalibrationError, match=r"rig.yml: P1 must be a matrix \(!!opencv-matrix with rows, cols, dt"):
        read_calibration(path)


def test_unknown_length_unit_is_refused(tmp_path):
    with pytest.raises(CalibrationError, match="length_unit"):
        read_calibration(tmp_path / "x", length_unit="inch")


def test_a_length_unit_for_a_file_that_states_its_own_is_not_used_and_said_so(tmp_path, caplog):
    write_calibration_json(tmp_path / "c.json", RIG)
    (tmp_path / "calib.txt").write_text("cam0=[700 0 320.5; 0 700 240.25; 0 0 1]\ndoffs=0\nbaseline=120\n")
    projection = "700 0 320.5 0 0 700 240.25 0 0 0 1 0"
    shifted = "700 0 320.5 -84 0 700 240.25 0 0 0 1 0"
    (tmp_path / "kitti.txt").write_text(f"P_rect_02: {projection}\nP_rect_03: {shifted}\n")
    for name, says in (("c.json", "JSON calibration, in metres"), ("calib.txt", "Middlebury calib.txt, in millimetres"),
                       ("kitti.txt", "KITTI calibration, in metres")):
        caplog.clear()
        assert read_calibration(tmp_path / name, length_unit="mm").baseline_m == pytest.approx(0.12)
        assert f"the length unit 'mm' (--calib-unit) is not used: {tmp_path / name} is" in caplog.text
        assert says in caplog.text
        caplog.clear()
        read_calibration(tmp_path / name)
        assert caplog.text == ""
