"""Stereo pairs with ground truth from the folder layouts benchmarks ship.

:func:`load_pair` recognises a folder by its file names and returns a :class:`StereoPair`:
the left and right RGB images, the left ground-truth disparity (``float32`` pixels, NaN where
unknown), the non-occluded mask where the layout has one, and the calibration where there is
one. Layouts, tried in this order:

================== ====================================================== =================
layout             files                                                  GT scale
================== ====================================================== =================
``synthetic``      ``left.png right.png disparity.pfm nonocc.png            float (PFM)
                   calibration.json`` (``stereo-obstacles scene --out``)
``middlebury2014`` ``im0.png im1.png disp0GT.pfm|disp0.pfm calib.txt        float (PFM)
                   mask0nocc.png``
``middlebury2005`` ``view1.png view5.png disp1.png [disp5.png]``            by width, below
``middlebury2001`` ``im2 im6 disp2`` (``.png``/``.ppm``/``.pgm``) with      8 (16 for Tsukuba
``middlebury2003`` ``nonocc.png``; or Tsukuba's ``scene1.row3.col3.ppm       384x288); 2003 by
                   scene1.row3.col4.ppm truedisp.row3.col3.pgm``           width, below
``middlebury-v2``  ``imL.png imR.png groundtruth.png info.txt nonocc.png``  ``info.txt`` line 1
                   (the Middlebury v2 evaluation folders)
``opencv-sample``  ``<name>L.jpg <name>R.jpg <name>GT.png`` (OpenCV's aloe) 1
``kitti-pair``     ``<id>_left.png <id>_right.png [<id>_disp*.png           256 (16-bit PNG)
                   Calib.txt]`` (also ``.ppm``, ``.pgm``, ``.jpg``)
``kitti2015``      ``image_2/ image_3/ disp_occ_0/ disp_noc_0/              256 (16-bit PNG)
                   calib_cam_to_cam/`` (one frame per ``<id>_10.png``)
================== ====================================================== =================

A folder of ``frame_0000/``, ``frame_0001/``, ... scene folders (``stereo-obstacles scene
--frames N``) is multi-frame like a KITTI 2015 folder: :func:`list_frames` names the frames.

8-bit ground truth stores ``disparity * scale`` with 0 = unknown. The scale is not in the
files, so it is derived from the image size (pass ``gt_scale`` to override):

* Middlebury 2001 (Venus, Sawtooth, Bull, Poster, Barn1, Barn2; about 434x383): **8**, except
  Tsukuba (384x288): **16**.
* Middlebury 2003 (Teddy, Cones): **4** at quarter size (450x375), **2** at half size
  (900x750), **1** at full size (1800x1500).
* Middlebury 2005/2006 (``view1``/``view5``): **1** at full size (width >= 1000 px), **2** at
  half size (550..999 px), **3** at third size (< 550 px).
* OpenCV's ``aloeGT.png`` is full-size 2006 Aloe: **1**.

Masks are white (255) where a pixel is non-occluded and has ground truth. Where a layout has
no mask but the right-view ground truth (``disp5.png``, ``disp1.pfm``), the non-occluded mask
is derived by a left-right check: the right view must see the same disparity (within 1 px)
at ``x - d``. KITTI's ``disp_noc_0`` is itself the non-occluded region; with both
``disp_occ_0`` and ``disp_noc_0`` the former is the ground truth and the latter the mask.
Grey images (KITTI 2012, for example) are repeated into three channels.
"""

from __future__ import annotations

import logging
import math
import numbers
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from stereo_obstacles.atomic import moved_in_files
from stereo_obstacles.calibration import StereoCalibration, read_calibration_json, sized_for_images
from stereo_obstacles.calibration_files import read_calibration
from stereo_obstacles.errors import ImageMismatchError, InputFileError, InvalidInputError
from stereo_obstacles.fileio import read_image, read_kitti_disparity, read_pfm

logger = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

LR_CHECK_TOLERANCE_PX = 1.0
"""Largest left/right ground-truth disagreement for a pixel to count as non-occluded."""

_IMAGE_EXTENSIONS = (".png", ".ppm", ".pgm", ".jpg", ".jpeg")


@dataclass(frozen=True)
class StereoPair:
    """A rectified stereo pair, possibly with ground truth and calibration.

    Attributes
    ----------
    name : str
        Short name (the folder name, plus the frame for multi-frame layouts).
    left, right : numpy.ndarray
        RGB ``uint8 (H, W, 3)`` images; left pixel ``(x, y)`` matches right ``(x - d, y)``.
    gt_disparity : numpy.ndarray or None
        Left ground-truth disparity, ``float32 (H, W)`` pixels, NaN where unknown.
    nonocc : numpy.ndarray or None
        ``bool (H, W)``, true where a pixel is visible in both views and has ground truth.
    calibration : StereoCalibration or None
        Calibration of the pair, when the layout has one and it was read (``load_pair``'s
        ``with_calibration``).
    source : pathlib.Path
        The folder the pair was read from.
    layout : str
        The recognised layout (see the module docstring).
    left_file, right_file : pathlib.Path or None
        The image files read (``None`` for a pair made in memory).
    calibration_file : pathlib.Path or None
        The layout's calibration file, which ``calibration`` was read from (unless
        :func:`load_pair` was told not to read it); ``None`` without one.
    """

    name: str
    left: np.ndarray
    right: np.ndarray
    gt_disparity: np.ndarray | None
    nonocc: np.ndarray | None
    calibration: StereoCalibration | None
    source: Path
    layout: str
    left_file: Path | None = None
    right_file: Path | None = None
    calibration_file: Path | None = None

    def __post_init__(self) -> None:
        for label in ("left", "right"):
            image = getattr(self, label)
            if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 \
                    or image.shape[2] != 3:
                raise InvalidInputError(f"{label} image of {self.name} must be uint8 (H, W, 3), got "
                                        f"{getattr(image, 'dtype', type(image))} "
                                        f"{getattr(image, 'shape', '')}")
        if self.left.shape != self.right.shape:
            raise ImageMismatchError(f"{self.source}: left image is {self.left.shape[1]}x"
                                     f"{self.left.shape[0]} but right image is "
                                     f"{self.right.shape[1]}x{self.right.shape[0]}")
        shape = self.left.shape[:2]
        if self.gt_disparity is not None:
            if self.gt_disparity.dtype != np.float32 or self.gt_disparity.shape != shape:
                raise ImageMismatchError(f"{self.source}: ground truth must be float32 {shape}, "
                                         f"got {self.gt_disparity.dtype} {self.gt_disparity.shape}")
        if self.nonocc is not None:
            if self.nonocc.dtype != np.bool_ or self.nonocc.shape != shape:
                raise ImageMismatchError(f"{self.source}: non-occluded mask must be bool {shape}, "
                                         f"got {self.nonocc.dtype} {self.nonocc.shape}")
        if self.calibration is not None:
            self.calibration.check_image_size(shape[1], shape[0])

    @property
    def is_kitti(self) -> bool:
        """True for KITTI layouts, where the D1 error is the customary figure."""
        return self.layout.startswith("kitti")

    @property
    def max_gt_disparity(self) -> float | None:
        """Largest ground-truth disparity in pixels, or None without ground truth."""
        if self.gt_disparity is None or not np.isfinite(self.gt_disparity).any():
            return None
        return float(np.nanmax(self.gt_disparity))


def list_frames(folder: PathLike) -> tuple[str | None, ...]:
    """Frame names of a multi-frame folder (KITTI 2015 ``image_2/``; the ``frame_0000/``, ...
    scene folders of ``stereo-obstacles scene --frames N``), else ``(None,)``.

    Each name can be passed as ``frame`` to :func:`load_pair`.
    """
    root = _check_folder(folder)
    if (root / "image_2").is_dir() and (root / "image_3").is_dir():
        frames = tuple(sorted(p.stem for p in (root / "image_2").glob("*_10.png")))
        if not frames:
            raise InputFileError(f"{root}: KITTI folder image_2/ holds no *_10.png frame")
        return frames
    return _scene_frames(root) or (None,)


def _scene_frames(root: Path) -> tuple[str, ...]:
    """The ``frame_*`` sub-folders of ``root`` that hold a rendered scene (``scene.json``), sorted."""
    return tuple(sorted(p.name for p in root.glob("frame_*") if (p / "scene.json").is_file()))


def load_pair(folder: PathLike, *, frame: str | None = None,
              gt_scale: float | None = None, with_calibration: bool = True) -> StereoPair:
    """Read the stereo pair in ``folder``, recognising its layout (see the module docstring).

    Parameters
    ----------
    folder
        Dataset folder.
    frame
        Frame name in a multi-frame layout (see :func:`list_frames`); required there.
    gt_scale
        Override the divisor of 8-bit ground truth (``disparity = value / gt_scale``).
    with_calibration
        ``False``: the layout's calibration file is not read (``calibration`` stays ``None``,
        ``calibration_file`` still names it), for a caller that brings its own calibration; a
        broken or mismatched file in the folder then does not fail the pair.

    Returns
    -------
    StereoPair

    Raises
    ------
    InputFileError
        The folder does not exist, its layout is not recognised, or a file is missing or
        unreadable.
    ImageMismatchError
        Images, ground truth or mask differ in size.
    CalibrationError
        The calibration does not parse or is for another image size (``with_calibration``).
    """
    pair = _recognised_pair(_check_folder(folder), frame, gt_scale)
    return _with_calibration(pair) if with_calibration else pair


def _recognised_pair(root: Path, frame: str | None, gt_scale: float | None) -> StereoPair:
    """The pair of ``root`` in the first layout that recognises it, its calibration not yet read
    (``calibration_file`` names the layout's file when it exists)."""
    if gt_scale is not None and (isinstance(gt_scale, bool) or not isinstance(gt_scale, numbers.Real)
                                 or not math.isfinite(gt_scale) or gt_scale <= 0):
        raise InvalidInputError(f"gt_scale must be a finite number > 0, got {gt_scale!r}")
    if (root / "image_2").is_dir() and (root / "image_3").is_dir():
        if frame is None:
            raise InvalidInputError(f"{root} holds several KITTI frames; pass frame= "
                                    f"(one of list_frames(folder))")
        return _load_kitti2015(root, frame)
    scene_frames = _scene_frames(root)
    if frame is not None and frame in scene_frames:
        return _recognised_pair(_check_folder(root / frame), None, gt_scale)
    if scene_frames:           # "no layout recognised" and "holds a single pair" said it wrongly (API review)
        wrong = "" if frame is None else f", and no frame {frame!r}"
        raise InvalidInputError(f"{root} holds {len(scene_frames)} rendered frames ({scene_frames[0]}, ...){wrong}: "
                                f"give one frame's folder ({root / scene_frames[0]}), or frame= one of "
                                f"list_frames(folder)")
    if frame is not None:
        raise InvalidInputError(f"{root} holds a single pair; frame={frame!r} does not apply")
    _refuse_cut_short(root)
    for loader in (_load_synthetic, _load_middlebury2014, _load_middlebury2005,
                   _load_middlebury2001_2003, _load_middlebury_v2, _load_opencv_sample,
                   _load_kitti_pair):
        pair = loader(root, gt_scale)
        if pair is not None:
            logger.debug("%s: %s layout", root, pair.layout)
            return pair
    raise InputFileError(
        f"{root}: no stereo pair layout recognised (expected left.png/right.png, im0/im1, "
        f"view1/view5, im2/im6, imL/imR, <name>L/<name>R, <id>_left/<id>_right, or KITTI "
        f"image_2/image_3)")


def _refuse_cut_short(root: Path) -> None:
    """:class:`InputFileError` when files of ``root`` are those of a move into it (or into the
    sequence folder above it) that was cut short: they may be of two runs (a scene's images of one
    seed beside another's ground truth, a rectified left image beside an earlier right one)."""
    mixed = moved_in_files(root) | {name.split("/", 1)[1] for name in moved_in_files(root.parent)
                                    if name.startswith(f"{root.name}/")}
    if mixed:
        shown = ", ".join(sorted(mixed)[:3]) + (", ..." if len(mixed) > 3 else "")
        raise InputFileError(f"{root}: the writing of its files was cut short ({shown} may be of another run than "
                             f"the rest); write them again")


# --- layouts ---------------------------------------------------------------------------------

def _load_synthetic(root: Path, gt_scale: float | None) -> StereoPair | None:
    if not ((root / "left.png").is_file() and (root / "right.png").is_file()):
        return None
    gt = _optional(root / "disparity.pfm", read_pfm)
    return _make_pair(root, root.name, "synthetic", root / "left.png", root / "right.png", gt,
                      _optional(root / "nonocc.png", _read_mask), root / "calibration.json")


def _load_middlebury2014(root: Path, gt_scale: float | None) -> StereoPair | None:
    if not ((root / "im0.png").is_file() and (root / "im1.png").is_file()):
        return None
    gt_file = _first_existing(root, ("disp0GT.pfm", "disp0.pfm"))
    gt = read_pfm(gt_file) if gt_file else None
    nonocc = _optional(root / "mask0nocc.png", _read_mask)
    if nonocc is None and gt is not None:
        right_gt = _optional(_first_existing(root, ("disp1GT.pfm", "disp1.pfm")), read_pfm)
        nonocc = _lr_check_mask(gt, right_gt) if right_gt is not None else None
    return _make_pair(root, root.name, "middlebury2014", root / "im0.png", root / "im1.png", gt,
                      nonocc, root / "calib.txt")


def _load_middlebury2005(root: Path, gt_scale: float | None) -> StereoPair | None:
    left, right = _find_image(root, "view1"), _find_image(root, "view5")
    if left is None or right is None:
        return None
    gt = nonocc = None
    gt_file = _find_image(root, "disp1")
    if gt_file is not None:
        width = _image_size(left)[0]
        scale = gt_scale or (1 if width >= 1000 else 2 if width >= 550 else 3)
        gt = _read_scaled_gt(gt_file, scale)
        right_file = _find_image(root, "disp5")
        if right_file is not None:
            nonocc = _lr_check_mask(gt, _read_scaled_gt(right_file, scale))
    return _make_pair(root, root.name, "middlebury2005", left, right, gt, nonocc, None)


def _load_middlebury2001_2003(root: Path, gt_scale: float | None) -> StereoPair | None:
    left, right = _find_image(root, "im2"), _find_image(root, "im6")
    gt_file = _find_image(root, "disp2")
    if left is None or right is None:
        left, right = _find_image(root, "scene1.row3.col3"), _find_image(root, "scene1.row3.col4")
        gt_file = _find_image(root, "truedisp.row3.col3")
    if left is None or right is None:
        return None
    width, height = _image_size(left)
    layout = "middlebury2001" if width < 445 else "middlebury2003"
    gt = None
    if gt_file is not None:
        gt = _read_scaled_gt(gt_file, gt_scale or _middlebury_scale(root, width, height))
    return _make_pair(root, root.name, layout, left, right, gt,
                      _optional(root / "nonocc.png", _read_mask), None)


def _load_middlebury_v2(root: Path, gt_scale: float | None) -> StereoPair | None:
    if not ((root / "imL.png").is_file() and (root / "imR.png").is_file()):
        return None
    gt = None
    if (root / "groundtruth.png").is_file():
        scale = gt_scale or _info_scale(root / "info.txt")
        if scale is None:
            scale = _middlebury_scale(root, *_image_size(root / "imL.png"))
        gt = _read_scaled_gt(root / "groundtruth.png", scale)
    return _make_pair(root, root.name, "middlebury-v2", root / "imL.png", root / "imR.png", gt,
                      _optional(root / "nonocc.png", _read_mask), None)


def _load_opencv_sample(root: Path, gt_scale: float | None) -> StereoPair | None:
    for left in sorted(root.iterdir()):
        match = re.fullmatch(r"(.+)L(\.(?:jpg|jpeg|png))", left.name, flags=re.IGNORECASE)
        if match is None:
            continue
        right = root / f"{match.group(1)}R{match.group(2)}"
        if not right.is_file():
            continue
        gt_file = root / f"{match.group(1)}GT.png"
        gt = _read_scaled_gt(gt_file, gt_scale or 1) if gt_file.is_file() else None
        return _make_pair(root, root.name, "opencv-sample", left, right, gt, None, None)
    return None


def _load_kitti_pair(root: Path, gt_scale: float | None) -> StereoPair | None:
    lefts = sorted(p for p in root.glob("*_left.*") if p.suffix.lower() in _IMAGE_EXTENSIONS)
    if not lefts:
        return None
    if len(lefts) > 1:
        raise InputFileError(f"{root}: several *_left images ({lefts[0].name}, {lefts[1].name}, ...); one pair per "
                             f"folder expected")
    stem = lefts[0].stem[:-len("_left")]
    right = root / f"{stem}_right{lefts[0].suffix}"
    if not right.is_file():
        raise InputFileError(f"{root}: {right.name} is missing beside {lefts[0].name}")
    gts = sorted(root.glob(f"{stem}_disp*.png"))
    gt = nonocc = None
    if gts:
        occ = [p for p in gts if "occ" in p.stem and "noc" not in p.stem]
        noc = [p for p in gts if "noc" in p.stem]
        gt = read_kitti_disparity((occ or gts)[0])
        if occ and noc:
            nonocc = np.isfinite(read_kitti_disparity(noc[0]))
    return _make_pair(root, root.name, "kitti-pair", lefts[0], right, gt, nonocc,
                      _first_existing(root, ("Calib.txt", "calib.txt", "calib_cam_to_cam.txt")))


def _load_kitti2015(root: Path, frame: str) -> StereoPair:
    left = root / "image_2" / f"{frame}.png"
    if not left.is_file():
        raise InputFileError(f"{root}: frame {frame!r} not found ({left} is missing)")
    occ = _optional(root / "disp_occ_0" / f"{frame}.png", read_kitti_disparity)
    noc = _optional(root / "disp_noc_0" / f"{frame}.png", read_kitti_disparity)
    gt = occ if occ is not None else noc
    nonocc = np.isfinite(noc) if occ is not None and noc is not None else None
    sequence = frame.split("_")[0]
    calib_file = _first_existing(root, (f"calib_cam_to_cam/{sequence}.txt", f"calib/{sequence}.txt",
                                        "calib_cam_to_cam.txt"))
    return _make_pair(root, f"{root.name}/{frame}", "kitti2015", left,
                      root / "image_3" / f"{frame}.png", gt, nonocc, calib_file)


# --- helpers ---------------------------------------------------------------------------------

def _check_folder(folder: PathLike) -> Path:
    root = Path(folder)
    if not root.exists():
        raise InputFileError(f"dataset folder {root} does not exist")
    if not root.is_dir():
        raise InputFileError(f"dataset {root} is not a folder")
    return root


def _make_pair(root: Path, name: str, layout: str, left_file: Path, right_file: Path,
               gt: np.ndarray | None, nonocc: np.ndarray | None, calibration_file: Path | None) -> StereoPair:
    """The pair of ``left_file`` and ``right_file``, without calibration; ``calibration_file`` is
    kept when that file exists (:func:`_with_calibration` reads it)."""
    if calibration_file is not None and not calibration_file.is_file():
        calibration_file = None
    left = _read_rgb(left_file)
    right = _read_rgb(right_file)
    h, w = left.shape[:2]
    for what, array in (("ground truth", gt), ("non-occluded mask", nonocc)):
        if array is not None and array.shape != (h, w):
            raise ImageMismatchError(f"{root}: {what} is {array.shape[1]}x{array.shape[0]} but "
                                     f"the images are {w}x{h}")
    if nonocc is not None and gt is not None:
        nonocc = nonocc & np.isfinite(gt)
    return StereoPair(name=name, left=left, right=right, gt_disparity=gt, nonocc=nonocc,
                      calibration=None, source=root, layout=layout, left_file=left_file,
                      right_file=right_file, calibration_file=calibration_file)


def _with_calibration(pair: StereoPair) -> StereoPair:
    """``pair`` with the calibration read from its ``calibration_file`` (a scene's own JSON, any
    format :func:`~stereo_obstacles.calibration_files.read_calibration` knows elsewhere), the image
    size filled in when the file does not give it."""
    if pair.calibration_file is None:
        return pair
    reader = read_calibration_json if pair.layout == "synthetic" else read_calibration
    h, w = pair.left.shape[:2]
    return replace(pair, calibration=sized_for_images(reader(pair.calibration_file), w, h, source=pair.source))


def _read_rgb(path: Path) -> np.ndarray:
    image = read_image(path, mode="any")
    if image.dtype != np.uint8:
        raise InputFileError(f"{path}: 8-bit images expected, got {image.dtype}")
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)
    return image


def _read_scaled_gt(path: Path, scale: float) -> np.ndarray:
    raw = read_image(path, mode="gray")  # applies a palette, as the Middlebury PNGs need
    gt = raw.astype(np.float32) / np.float32(scale)
    gt[raw == 0] = np.nan
    return gt


def _read_mask(path: Path) -> np.ndarray:
    return read_image(path, mode="gray") == 255


def _lr_check_mask(gt_left: np.ndarray, gt_right: np.ndarray) -> np.ndarray:
    """Pixels whose left GT disparity the right-view GT confirms at ``x - d`` (non-occluded)."""
    h, w = gt_left.shape
    xs = np.arange(w)[None, :] - np.nan_to_num(gt_left, nan=-1.0e6)
    xr = np.rint(xs).astype(np.int64)
    inside = np.isfinite(gt_left) & (xr >= 0) & (xr < w)
    rows = np.broadcast_to(np.arange(h)[:, None], (h, w))
    seen = np.full((h, w), np.nan, dtype=np.float32)
    seen[inside] = gt_right[rows[inside], xr[inside]]
    with np.errstate(invalid="ignore"):
        return inside & (np.abs(seen - gt_left) <= LR_CHECK_TOLERANCE_PX)


def _middlebury_scale(root: Path, width: int, height: int) -> int:
    """GT divisor of an 8-bit Middlebury 2001/2003 map from the image size (module docstring)."""
    if (width, height) == (384, 288):
        return 16
    if width < 445:
        return 8
    ratio = 4 * 450 / width
    for scale in (4, 2, 1):
        if abs(ratio - scale) <= 0.1 * scale:
            return scale
    raise InputFileError(f"{root}: cannot tell the ground-truth scale of {width}x{height} "
                         f"Middlebury images; pass gt_scale")


def _info_scale(path: Path) -> float | None:
    if not path.is_file():
        return None
    first = path.read_text(encoding="ascii", errors="replace").split()
    try:
        scale = float(first[0])
    except (IndexError, ValueError) as exc:
        raise InputFileError(f"{path}: first line must be the ground-truth scale") from exc
    if not math.isfinite(scale) or scale <= 0:
        raise InputFileError(f"{path}: ground-truth scale must be > 0, got {scale}")
    return scale


def _find_image(root: Path, stem: str) -> Path | None:
    return _first_existing(root, tuple(stem + ext for ext in _IMAGE_EXTENSIONS))


def _first_existing(root: Path, names: tuple[str, ...]) -> Path | None:
    for name in names:
        if (root / name).is_file():
            return root / name
    return None


def _optional(path: Path | None, reader):
    return reader(path) if path is not None and path.is_file() else None


def _image_size(path: Path) -> tuple[int, int]:
    image = read_image(path, mode="any")
    return image.shape[1], image.shape[0]


__all__ = ["LR_CHECK_TOLERANCE_PX", "StereoPair", "list_frames", "load_pair"]
