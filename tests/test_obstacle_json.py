"""The obstacles JSON document: schema, round trip, version check, the uncalibrated case."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _obstacle_scene import RIG, detection

from stereo_obstacles import __version__
from stereo_obstacles.errors import InputFileError, InvalidInputError
from stereo_obstacles.obstacle_json import (
    OBSTACLES_FORMAT, obstacles_to_dict, read_obstacles_json, write_obstacles_json)
from stereo_obstacles.obstacles import Obstacle

DETECTION = detection()


def test_document_states_format_units_frame_and_calibration():
    doc = obstacles_to_dict(DETECTION.calibrated, RIG)
    assert doc["format"] == OBSTACLES_FORMAT and doc["version"] == 1
    assert doc["units"] == "metres" and "metres" in doc["units_note"]
    assert doc["frame"]["x"] == "right" and doc["frame"]["y"] == "down" and doc["frame"]["z"].startswith("forward")
    assert doc["calibration"]["focal_px"] == 350.0 and doc["calibration"]["baseline_m"] == 0.12
    assert doc["image_size_px"] == {"width": 320, "height": 240}
    assert doc["run"] == {"package_version": __version__}


def test_obstacles_nearest_first_with_every_field_and_rejections_and_corridor():
    doc = obstacles_to_dict(DETECTION.calibrated, RIG)
    distances = [o["distance_m"] for o in doc["obstacles"]]
    assert distances == sorted(distances) and distances == pytest.approx([4.0, 5.0, 8.0], rel=0.01)
    assert set(doc["obstacles"][0]) == set(Obstacle.__dataclass_fields__)
    assert doc["obstacles"][0]["box_px"] == [150, 138, 200, 225]
    assert len(doc["rejected"]) == 1 and "flat on the ground" in doc["rejected"][0]["reason"]
    assert doc["corridor"] == {"width_m": 1.0, "nearest_obstacle_id": 1, "free_distance_m": 4.0}


def test_the_scan_lists_a_range_and_an_id_per_sector_and_says_what_they_mean():
    scan = obstacles_to_dict(DETECTION.calibrated, RIG)["scan"]
    assert set(scan) == {"sector_deg", "first_bearing_deg", "field_of_view_deg", "ranges_m", "obstacle_ids", "note"}
    assert scan["sector_deg"] == 1.0 and len(scan["ranges_m"]) == len(scan["obstacle_ids"]) > 10
    assert None in scan["ranges_m"] and 1 in scan["obstacle_ids"]
    assert "positive to the right" in scan["note"] and "sqrt(x^2 + z^2)" in scan["note"]


def test_a_scan_of_the_first_version_without_its_field_of_view_reads_as_covering_its_sectors(tmp_path):
    doc = obstacles_to_dict(DETECTION.calibrated, RIG)
    del doc["scan"]["field_of_view_deg"]
    scan = read_obstacles_json(_write(tmp_path, doc)).scan
    assert scan.ranges_m == DETECTION.calibrated.scan.ranges_m
    assert scan.field_of_view_deg == (scan.first_bearing_deg, scan.first_bearing_deg + len(scan.ranges_m))


def test_a_document_written_before_the_scan_reads_without_one(tmp_path):
    doc = obstacles_to_dict(DETECTION.calibrated, RIG)
    del doc["scan"]
    record = read_obstacles_json(_write(tmp_path, doc))
    assert record.scan is None and record.obstacles == DETECTION.calibrated.obstacles


def test_write_read_round_trip_keeps_everything(tmp_path):
    config = {"tau": 0.6, "out": Path("/tmp/x"), "k": np.int64(10), "ratio": np.float32(0.5), "bad": float("nan")}
    path = write_obstacles_json(tmp_path / "obstacles.json", DETECTION.calibrated, RIG, config=config,
                                timings_s={"matching": 0.25}, inputs={"left": "l.png", "right": "r.png"})
    json.loads(path.read_text(encoding="utf-8"))  # strict JSON: NaN was written as null
    record = read_obstacles_json(path)
    assert record.obstacles == DETECTION.calibrated.obstacles
    assert record.rejected == DETECTION.calibrated.rejected
    assert record.corridor == DETECTION.calibrated.corridor
    assert record.scan == DETECTION.calibrated.scan and record.scan is not None
    assert record.calibration == RIG and record.calibrated
    assert record.image_size_px == (320, 240)
    assert record.run["config"] == {"tau": 0.6, "out": "/tmp/x", "k": 10, "ratio": 0.5, "bad": None}
    assert record.run["timings_s"] == {"matching": 0.25}
    assert record.run["inputs"]["left"] == "l.png" and record.run["package_version"] == __version__


def test_uncalibrated_document_says_pixels_and_has_no_calibration(tmp_path):
    path = write_obstacles_json(tmp_path / "o.json", DETECTION.uncalibrated, None)
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["calibration"] is None and doc["units"] == "pixels"
    assert "No calibration" in doc["units_note"] and "pixels" in doc["units_note"]
    assert all(o["distance_m"] is None and o["disparity_px"] > 0 for o in doc["obstacles"])
    assert doc["corridor"] is None and doc["scan"] is None
    record = read_obstacles_json(path)
    assert record.obstacles == DETECTION.uncalibrated.obstacles and not record.calibrated


def _write(tmp_path, doc) -> Path:
    path = tmp_path / "doc.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(format="stereo-obstacles/calibration"), "is not a stereo-obstacles/obstacles document"),
    (lambda d: d.update(version=2), "unsupported .* version 2"),
    (lambda d: d.pop("obstacles"), "lacks 'obstacles'"),
    (lambda d: d["obstacles"][0].update(speed=3), "unknown fields speed"),
    (lambda d: d["obstacles"][0].pop("id"), "obstacles\\[0\\]"),
    (lambda d: d["calibration"].update(baseline_m=-1), "baseline_m must be > 0"),
    (lambda d: d.update(image_size_px={"width": 3}), "lacks 'height'"),
    (lambda d: d.update(scan=[1.0]), "scan is not an object"),
    (lambda d: d["scan"].update(speed=3), "scan has unknown fields speed"),
    (lambda d: d["scan"]["ranges_m"].pop(), "one value per sector"),
    (lambda d: d["scan"].update(ranges_m="x" * 50), "one value per sector"),
    (lambda d: d["scan"].update(sector_deg=-1), "sector_deg must be"),
    (lambda d: d["scan"]["ranges_m"].__setitem__(d["scan"]["obstacle_ids"].index(1), -2.0), "ranges_m must be"),
    (lambda d: d["scan"]["obstacle_ids"].__setitem__(d["scan"]["obstacle_ids"].index(1), 999),
     r"scan names obstacles the document does not list: \[999\]"),
    (lambda d: d.update(calibration=None), "a scan needs a calibration"),
])
def test_bad_documents_raise_input_file_error(tmp_path, change, message):
    doc = obstacles_to_dict(DETECTION.calibrated, RIG)
    change(doc)
    with pytest.raises(InputFileError, match=message):
        read_obstacles_json(_write(tmp_path, doc))


def test_missing_and_non_json_files(tmp_path):
    with pytest.raises(InputFileError, match="does not exist"):
        read_obstacles_json(tmp_path / "nope.json")
    (tmp_path / "bad.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(InputFileError, match="not valid JSON"):
        read_obstacles_json(tmp_path / "bad.json")
    with pytest.raises(InputFileError, match="not a stereo-obstacles/obstacles document"):
        read_obstacles_json(_write(tmp_path, [1, 2]))


def test_bad_arguments():
    with pytest.raises(InvalidInputError, match="obstacle_list must be an ObstacleList"):
        obstacles_to_dict(DETECTION.calibrated.obstacles, RIG)
    with pytest.raises(InvalidInputError, match="calibration must be a StereoCalibration"):
        obstacles_to_dict(DETECTION.calibrated, {"focal_px": 1})
    with pytest.raises(InvalidInputError, match="cannot store a object"):
        obstacles_to_dict(DETECTION.calibrated, RIG, config={"x": object()})
