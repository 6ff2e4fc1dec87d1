"""The shared checks of parameter fields."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass

import numpy as np
import pytest

from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.calibration import StereoCalibration
from stereo_obstacles.field_checks import check_integers, check_numbers, check_positive, check_types
from stereo_obstacles.pipeline import DetectionConfig
from stereo_obstacles.synthetic.render import RenderOptions
from stereo_obstacles.synthetic.rig import RightCameraError, StereoRig
from stereo_obstacles.synthetic.scene import Lighting


@dataclass
class _Fields:
    size: object = 5
    share: object = 0.5


@pytest.mark.parametrize("share", [-0.1, 1.5, float("nan"), float("inf"), True, "0.5", None])
def test_numbers_outside_their_range_or_not_numbers_fail(share):
    with pytest.raises(InvalidInputError, match=r"share must be in \[0.0, 1.0\], got"):
        check_numbers(_Fields(share=share), (("share", 0.0, 1.0),))


@pytest.mark.parametrize("size, odd, message", [
    (4, True, "an odd integer"), (0, False, "an integer"), (2.0, False, "an integer"), (True, False, "an integer"),
    (np.uint8(0), False, "an integer"), (np.float64(5.0), False, "an integer"),
])
def test_integers_outside_their_range_even_or_not_integers_fail(size, odd, message):
    with pytest.raises(InvalidInputError, match=f"size must be {message} in \\[1, 9\\], got"):
        check_integers(_Fields(size=size), (("size", 1, 9),), odd=odd)


def test_valid_fields_pass():
    check_numbers(_Fields(), (("share", 0.0, 1.0),))
    check_integers(_Fields(), (("size", 1, 9),), odd=True)
    check_integers(_Fields(size=4), (("size", 1, 9),))
    check_numbers(_Fields(share=np.float32(0.25)), (("share", 0.0, 1.0),))      # NumPy numbers too
    check_positive(_Fields(share=1e-9), ("share",))


@pytest.mark.parametrize("share", [0.0, -1.0, float("nan"), float("inf"), True, "1", None])
def test_positive_numbers_only(share):
    with pytest.raises(InvalidInputError, match="share must be a finite number > 0, got"):
        check_positive(_Fields(share=share), ("share",))


def test_a_nested_field_of_the_wrong_type_fails():
    with pytest.raises(InvalidInputError, match="share must be int, got float"):
        check_types(_Fields(), (("share", int),))
    check_types(_Fields(), (("size", int),))


def test_a_nested_field_may_be_none_when_allowed():
    check_types(_Fields(share=None), (("share", float),), allow_none=True)
    with pytest.raises(InvalidInputError, match="share must be float, got NoneType"):
        check_types(_Fields(share=None), (("share", float),))
    with pytest.raises(InvalidInputError, match="size must be float or None, got int"):
        check_types(_Fields(), (("size", float),), allow_none=True)


def test_is_whole_number_takes_python_and_numpy_integers_but_no_bool_or_float():
    from stereo_obstacles.field_checks import is_whole_number

    assert all(is_whole_number(v) for v in (0, -3, 2 ** 70, np.int32(5), np.uint8(1)))
    assert not any(is_whole_number(v) for v in (True, np.bool_(True), 1.0, np.float32(2), "3", None))


def test_numpy_scalars_are_replaced_by_python_numbers_of_the_same_value():
    fields = _Fields(size=np.uint8(5), share=np.float32(0.25))
    check_integers(fields, (("size", 1, 9),))        # a uint8 cannot overflow in sizes computed from it now
    check_numbers(fields, (("share", 0.0, 1.0),))
    assert type(fields.size) is int and fields.size == 5
    assert type(fields.share) is float and fields.share == 0.25


def _numeric_fields(instance, path=()):
    """(path, value) of every number field, and tuple of numbers, of a dataclass and the
    dataclasses nested in it."""
    for field in dataclasses.fields(instance):
        value = getattr(instance, field.name)
        if dataclasses.is_dataclass(value):
            yield from _numeric_fields(value, path + (field.name,))
        elif _is_number(value) or (isinstance(value, tuple) and value and all(_is_number(v) for v in value)):
            yield path + (field.name,), value


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _numpy_forms(value):
    """The NumPy forms a value taken from an array can have: scalars of each width, a 0-d array,
    a tuple of NumPy scalars."""
    if isinstance(value, tuple):
        return [tuple(np.int64(v) if isinstance(v, int) else np.float32(v) for v in value)]
    if isinstance(value, int):
        return [np.int64(value), np.int32(value), np.array(value)]
    return [np.float64(value), np.float32(value), np.longdouble(value), np.array(value)]


def _replaced(instance, path, value):
    if len(path) == 1:
        return dataclasses.replace(instance, **{path[0]: value})
    return dataclasses.replace(instance, **{path[0]: _replaced(getattr(instance, path[0]), path[1:], value)})


_OPTIONS = [DetectionConfig(), StereoCalibration(focal_px=554.0, cx_px=319.5, cy_px=239.5, baseline_m=0.12,
                                                 width_px=640, height_px=480), RenderOptions(),
            StereoRig(640, 480, focal_px=500.0), RightCameraError((0.5, 0.0, 0.0)), Lighting()]


@pytest.mark.parametrize("options", _OPTIONS, ids=lambda o: type(o).__name__)
def test_every_option_takes_a_numpy_number_and_stays_json_ready(options):
    """A value taken from an array (a focal length ``K[0, 0]`` of a float32 matrix, a size of an
    int64 array, a tuple of thresholds) is the number it holds: accepted where the Python number
    is, hashable, and written to JSON (the resolved configuration in obstacles.json, a
    calibration file) as that number."""
    fields = list(_numeric_fields(options))
    assert len(fields) >= 2
    for path, value in fields:
        for numpy_form in _numpy_forms(value):
            made = _replaced(options, path, numpy_form)
            hash(made)
            written = json.loads(json.dumps(dataclasses.asdict(made)))
            for name in path:
                written = written[name]
            assert written == pytest.approx(list(value) if isinstance(value, tuple) else value, rel=1e-6), path
