"""Many stereo pairs at once: discovery, one job per pair, local processes or a Dask cluster, resume.

:func:`find_pairs` lists the pairs under a folder:

* the folder itself, when it is one dataset: a KITTI 2015 folder (a pair per frame), or one
  pair with a calibration file that :func:`stereo_obstacles.datasets.load_pair` recognises
  (read when the pair is run, unless ``--calib`` replaces it);
* every sub-folder that :func:`stereo_obstacles.datasets.load_pair` reads (a KITTI 2015
  folder gives one pair per frame); a sub-folder it cannot read becomes a failed pair, unless
  it holds no images at all, or is a report of this tool holding no pair (left out with a
  warning: notes, calibration files, an earlier ``detect --out``); a
  sub-folder holding several pairs of images paired by name (below) gives each of them,
  named ``<folder>_<key>``;
* image files in the folder itself paired by name: ``<key>left<rest>`` with
  ``<key>right<rest>`` (any case), or ``<key>L.<ext>`` with ``<key>R.<ext>`` where the
  letter follows a non-letter (``0001_L.png``);
* ``left/`` and ``right/`` sub-folders holding images of the same names;
* when none of the above is found, the folder itself as one pair of a layout without
  calibration that :func:`stereo_obstacles.datasets.load_pair` reads (a Middlebury 2003
  folder, OpenCV's aloe pair).

:func:`run_batch` runs :func:`process_pair` on every pair whose output folder lacks a done
file (``done.json``, written atomically after every other output of the pair), in this
process, in a pool of local processes, or on a Dask scheduler; a failing pair is recorded
with its reason and the others go on. The summary is written atomically as
``batch_summary.json``.
"""

from __future__ import annotations

import json
import logging
import os
import re
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path

from stereo_obstacles.errors import InputFileError, InvalidInputError, OutputError

__all__ = ["DONE_FILE", "SUMMARY_FILE", "SUMMARY_FORMAT", "TASKS", "BatchJob", "PairOutcome", "PairSpec",
           "check_done_settings", "find_pairs", "finished_unreported", "output_settings", "process_pair", "run_batch", "write_summary"]

logger = logging.getLogger(__name__)

TASKS = ("detect", "disparity")
"""What :func:`process_pair` can do with a pair."""

DONE_FILE = "done.json"
"""Written last in a pair's output folder; its presence means the pair is complete."""

SUMMARY_FILE = "batch_summary.json"
"""Name of the summary written in the output folder."""
SUMMARY_FORMAT = "stereo-obstacles/batch-summary"
"""``format`` of the summary: how a later run knows the file for its own."""

_IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".bmp", ".tif", ".tiff")


@dataclass(frozen=True)
class PairSpec:
    """Where one pair is: a dataset ``folder`` (with ``frame`` for KITTI) or ``left``/``right`` files."""

    name: str
    folder: str | None = None
    frame: str | None = None
    left: str | None = None
    right: str | None = None

    def __post_init__(self) -> None:
        if (self.folder is None) == (self.left is None or self.right is None):
            raise InvalidInputError(f"pair {self.name}: give either a folder or left and right files")


@dataclass(frozen=True)
class BatchJob:
    """One unit of work, picklable for worker processes and Dask.

    Attributes
    ----------
    pair : PairSpec
    out_dir : str
        The pair's own output folder.
    task : {"detect", "disparity"}
    config : DetectionConfig
        Options of the pipeline (``disparity`` uses its matching options).
    calib_file : str or None
        Calibration file for every pair (named in each pair's report); without it a dataset
        folder's own calibration is used, and file pairs stay uncalibrated.
    calibration : StereoCalibration or CameraPairCalibration or None
        What :func:`~stereo_obstacles.camera_calibration.read_camera_calibration` read from
        ``calib_file`` (read once by the caller, not once per pair); given with it or not at all.
    """

    pair: PairSpec
    out_dir: str
    task: str
    config: object
    calib_file: str | None = None
    calibration: object = None

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise InvalidInputError(f"task must be one of {list(TASKS)}, got {self.task!r}")
        from stereo_obstacles.calibration import StereoCalibration
        from stereo_obstacles.camera_calibration import CameraPairCalibration

        if (self.calib_file is None) != (self.calibration is None):
            raise InvalidInputError("calib_file and calibration: give both (the calibration read from the file) "
                                    "or neither")
        if self.calibration is not None and not isinstance(self.calibration,
                                                           (StereoCalibration, CameraPairCalibration)):
            raise InvalidInputError(f"calibration must be a StereoCalibration or CameraPairCalibration (as "
                                    f"read_camera_calibration returns), got {type(self.calibration).__name__}")


@dataclass(frozen=True)
class PairOutcome:
    """What happened to one pair: ``status`` is ``"done"``, ``"skipped"`` (done before) or ``"failed"``."""

    name: str
    status: str
    seconds: float = 0.0
    reason: str | None = None
    details: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()


def _side_key(stem: str) -> tuple[str, str] | None:
    """``(key, side)`` for a file stem naming a left or right image, else ``None``."""
    word = re.fullmatch(r"(.*?)(left|right)(.*)", stem, flags=re.IGNORECASE)
    if word:
        return f"{word.group(1)}\0{word.group(3)}", word.group(2).lower()
    letter = re.fullmatch(r"(.*[^A-Za-z]|)([LR])", stem)
    if letter:
        return f"{letter.group(1)}\0", "left" if letter.group(2) == "L" else "right"
    return None


def _pair_name(key: str) -> str:
    name = re.sub(r"[_\-. ]+$", "", re.sub(r"^[_\-. ]+", "", key.replace("\0", "_")))
    return re.sub(r"[_\-. ]{2,}", "_", name) or "pair"


def _image_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in _IMAGE_EXTENSIONS)


def find_pairs(input_dir: str | os.PathLike[str], *, skip: str | os.PathLike[str] | None = None) -> list[PairSpec]:
    """Every stereo pair under ``input_dir`` (see the module docstring), sorted by name; the
    folder ``skip`` (a batch's output folder inside its input folder) is left out, and a
    sub-folder on the way down to it counts only for the pairs it holds (it is not reported as a
    pair that cannot be read).

    Raises
    ------
    InputFileError
        ``input_dir`` is not a folder, or holds no pair.
    """
    from stereo_obstacles.datasets import list_frames
    from stereo_obstacles.report import holds_a_report

    root = Path(input_dir)
    if not root.is_dir():
        raise InputFileError(f"input folder {root} does not exist or is not a folder")
    pairs: list[PairSpec] = []
    skipped = None if skip is None else Path(skip).resolve()
    subfolders = sorted(p for p in root.iterdir()
                        if p.is_dir() and not p.name.startswith(".") and p.resolve() != skipped)
    sides = {p.name.lower(): p for p in subfolders if p.name.lower() in ("left", "right")}
    own = _own_frames(root) if len(sides) < 2 else ()      # the folder is a dataset: its calibration comes with it
    name = root.resolve().name
    own_pairs = [PairSpec(name if frame is None else f"{name}_{frame}", folder=str(root), frame=frame) for frame in own]
    if own and own != (None,):
        return own_pairs                                    # a KITTI 2015 folder: its sub-folders are its data
    if len(sides) == 2:
        right_names = {p.name for p in _image_files(sides["right"])}
        for left in _image_files(sides["left"]):
            if left.name in right_names:
                pairs.append(PairSpec(left.stem, left=str(left), right=str(sides["right"] / left.name)))
            else:
                logger.warning("%s has no partner in %s", left, sides["right"])
    for folder in subfolders:
        if folder in sides.values():
            continue
        named = _pairs_by_name(folder, prefix=f"{folder.name}_")
        if not named and holds_a_report(folder) and not _is_a_dataset(folder):
            logger.warning("%s holds a report of this tool and no pair: left out", folder)
            continue
        on_the_way = skipped is not None and folder.resolve() in skipped.parents    # holds the output folder
        if len(named) >= 2 or (on_the_way and named):  # several pairs side by side, not one dataset pair
            pairs.extend(named)
            continue
        try:
            frames = list_frames(folder)
        except InputFileError:
            frames = (None,)
        else:
            if frames == (None,) and not _image_files(folder) and not _is_a_dataset(folder):
                if not on_the_way:
                    logger.warning("%s holds no images and no known layout: not a pair, left out", folder)
                continue
        if on_the_way and frames == (None,) and not _is_a_dataset(folder):
            continue                   # a folder of results, not an unreadable pair
        for frame in frames:
            name = folder.name if frame is None else f"{folder.name}_{frame}"
            pairs.append(PairSpec(name, folder=str(folder), frame=frame))
    pairs.extend(own_pairs or _pairs_by_name(root, prefix="", warn=True))
    if not pairs and _is_a_dataset(root):                    # one pair of a layout without calibration
        pairs.append(PairSpec(name, folder=str(root)))      # (Middlebury 2003, OpenCV's aloe), given itself
    names = [p.name.casefold() for p in pairs]               # one output folder on a case-insensitive disk
    duplicates = sorted({p.name for p in pairs if names.count(p.name.casefold()) > 1})
    if duplicates:
        raise InputFileError(f"{root}: several pairs would share the output name(s) {', '.join(duplicates)}")
    if not pairs:
        raise InputFileError(f"{root}: no stereo pairs found (sub-folders of a known layout, <name>_left/"
                             f"<name>_right images, or left/ and right/ folders)")
    return sorted(pairs, key=lambda p: p.name)


def _own_frames(root: Path) -> tuple[str | None, ...]:
    """The frames of ``root`` when it is itself a dataset folder: a KITTI 2015 folder, or one
    pair with a calibration file that :func:`stereo_obstacles.datasets.load_pair` recognises (read
    when the pair is run, unless ``--calib`` replaces it; not
    several name-paired files; one pair without a calibration stays a file pair); else ``()``.
    A folder of ``frame_*`` scene folders is not one: each of those is a pair."""
    from stereo_obstacles.datasets import list_frames, load_pair
    from stereo_obstacles.errors import StereoObstaclesError

    if (root / "image_2").is_dir() and (root / "image_3").is_dir():
        return list_frames(root)
    if len(_pairs_by_name(root, prefix="")) > 1 or list_frames(root) != (None,):
        return ()
    try:
        with _collected_warnings():               # said when the pair is run, not also when it is found
            return (None,) if load_pair(root, with_calibration=False).calibration_file is not None else ()
    except StereoObstaclesError:
        return ()


def _is_a_dataset(folder: Path) -> bool:
    """Whether :func:`stereo_obstacles.datasets.load_pair` reads ``folder`` (it reads the images; a
    calibration that does not parse fails the pair when it is run, with its reason)."""
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.errors import StereoObstaclesError

    try:
        with _collected_warnings():               # said when the pair is run, not also when it is found
            load_pair(folder, with_calibration=False)
    except StereoObstaclesError:
        return False
    return True


def _pairs_by_name(folder: Path, *, prefix: str, warn: bool = False) -> list[PairSpec]:
    """The image files of ``folder`` paired by name (module docstring), each named ``prefix``
    plus its key; with ``warn``, a file without its partner is logged."""
    found: dict[str, dict[str, Path]] = {}
    for path in _image_files(folder):
        keyed = _side_key(path.stem)
        if keyed is None:
            continue
        key, side = keyed
        found.setdefault(key + path.suffix.lower(), {})[side] = path
    pairs = []
    for key, by_side in sorted(found.items()):
        if set(by_side) == {"left", "right"}:
            pairs.append(PairSpec(_pair_name(prefix + os.path.splitext(key)[0]), left=str(by_side["left"]),
                                  right=str(by_side["right"])))
        elif warn:
            logger.warning("%s has no %s partner", next(iter(by_side.values())),
                           "right" if "left" in by_side else "left")
    return pairs


def _load(job: BatchJob):
    """``(left, right, calibration, inputs)`` of a job's pair: the images (rectified first when
    ``--calib`` describes the raw cameras, as ``calibrate`` writes them), grey ones kept for the
    disparity task."""
    from stereo_obstacles.datasets import load_pair
    from stereo_obstacles.fileio import read_image
    from stereo_obstacles.image_pairs import check_pair_of_files
    from stereo_obstacles.rectification import rig_for_images

    pair = job.pair
    if pair.folder is not None:
        stereo = load_pair(pair.folder, frame=pair.frame, with_calibration=job.calib_file is None)
        left, right, calibration = stereo.left, stereo.right, stereo.calibration
        inputs = {"folder": pair.folder, "frame": pair.frame, "layout": stereo.layout, "left": str(stereo.left_file),
                  "right": str(stereo.right_file),
                  "calibration": None if stereo.calibration_file is None else str(stereo.calibration_file)}
    else:
        mode = "color" if job.task == "detect" else "any"     # the matcher takes grey pairs too
        left, right = read_image(pair.left, mode=mode), read_image(pair.right, mode=mode)
        check_pair_of_files(left, right, pair.left, pair.right, channels=job.task == "detect")
        calibration = None
        inputs = {"left": pair.left, "right": pair.right, "calibration": None}
    inputs["rectification"] = None                       # the keys detect records, filled as it fills them
    if job.calib_file is not None:
        inputs["calibration"] = job.calib_file
        calibration, rectification = rig_for_images(job.calibration, left.shape[1], left.shape[0])
        if rectification is not None:
            left, right = rectification.apply(left, right)
            inputs["rectification"] = rectification.report(job.calib_file)
    return left, right, calibration, inputs


def _run_task(job: BatchJob) -> dict:
    """Do the job's task, writing its outputs; returns details for the summary."""
    import numpy as np

    from stereo_obstacles.atomic import staged_directory
    from stereo_obstacles.colorize import colorize_disparity
    from stereo_obstacles.fileio import write_image, write_pfm
    from stereo_obstacles.matching import match, warn_if_range_cut_off

    left, right, calibration, inputs = _load(job)
    if job.task == "detect":
        from stereo_obstacles.commands.detect import run_detection

        result = run_detection(left, right, calibration, job.config, job.out_dir, inputs=inputs)
        nearest = result.obstacles.obstacles[0] if result.obstacles.obstacles else None
        return {"obstacles": len(result.obstacles.obstacles), "density": result.density,
                "nearest_distance_m": nearest.distance_m if nearest is not None else None, "inputs": inputs}
    result = match(left, right, **job.config.matching.to_kwargs())
    warn_if_range_cut_off(result.disparity, result.stats.d_max,
                          default_limit=job.config.matching.max_disparity is None)
    with staged_directory(job.out_dir) as stage:
        write_pfm(stage / "disparity.pfm", result.disparity)
        write_image(stage / "disparity_picture.png", colorize_disparity(result.disparity, 0, result.stats.d_max))
    finite = result.disparity[np.isfinite(result.disparity)]
    return {"density": result.stats.density, "median_disparity_px": float(np.median(finite)) if finite.size else None,
            "inputs": inputs}


class _WarningCollector(logging.Handler):
    """Keeps the messages of the package's warnings instead of printing them."""

    def __init__(self) -> None:
        super().__init__(level=logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


@contextmanager
def _collected_warnings() -> Iterator[list[str]]:
    """Collect the package's warnings during one pair, so that they reach the user with the
    pair's name (:func:`run_batch` logs them) instead of unnamed, from whichever worker ran it."""
    package_logger = logging.getLogger("stereo_obstacles")
    collector = _WarningCollector()
    propagate = package_logger.propagate
    package_logger.addHandler(collector)
    package_logger.propagate = False
    try:
        yield collector.messages
    finally:
        package_logger.removeHandler(collector)
        package_logger.propagate = propagate


def process_pair(job: BatchJob) -> PairOutcome:
    """Run one job; any failure is returned as a ``"failed"`` outcome with its reason, never raised.

    On success the pair's ``done.json`` (task, seconds, details, warnings) is written last,
    atomically. The package's warnings during the job are returned in the outcome.
    """
    from stereo_obstacles.atomic import write_text_atomic
    from stereo_obstacles.obstacle_json import jsonable

    start = time.perf_counter()
    with _collected_warnings() as warnings:
        try:
            details = jsonable(_run_task(job))
            seconds = time.perf_counter() - start
            write_text_atomic(Path(job.out_dir) / DONE_FILE, json.dumps(
                {"name": job.pair.name, "task": job.task, "seconds": round(seconds, 4), **details,
                 "warnings": warnings, "settings": output_settings(job)}, indent=1) + "\n")
        except Exception as exc:  # noqa: BLE001 - a batch reports every failure and goes on
            reason = f"{type(exc).__name__}: {' '.join(str(exc).split()) or type(exc).__name__}"
            outcome = PairOutcome(job.pair.name, "failed", time.perf_counter() - start, reason,
                                  warnings=tuple(warnings))
        else:
            outcome = PairOutcome(job.pair.name, "done", seconds, None, details, tuple(warnings))
    if outcome.status == "failed":
        logger.debug("pair %s failed: %s", job.pair.name, outcome.reason)
    return outcome


def finished_unreported(pending: Iterable[BatchJob], outcomes: Iterable[PairOutcome]) -> list[PairOutcome]:
    """Outcomes for the ``pending`` jobs (those without a done file when the run started) that
    have none in ``outcomes`` but wrote their done file since: pairs a stopped batch did not wait
    for (a second Ctrl-C, SIGTERM) finish anyway, and the summary must count them. Read back from
    each ``done.json``."""
    reported = {o.name for o in outcomes}
    found = []
    for job in pending:
        done = Path(job.out_dir) / DONE_FILE
        if job.pair.name in reported or not done.is_file():
            continue
        try:
            record = json.loads(done.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue                                # unreadable: not this tool's done file
        if not isinstance(record, dict):
            continue
        details = {k: v for k, v in record.items() if k not in ("name", "task", "seconds", "warnings", "settings")}
        seconds = record.get("seconds", 0.0)
        found.append(PairOutcome(job.pair.name, "done", float(seconds) if isinstance(seconds, (int, float)) else 0.0,
                                 None, details, tuple(record.get("warnings", ()))))
    return found


def _ignore_sigint() -> None:
    """Worker start-up: Ctrl-C is the parent's to handle (it stops handing out pairs)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local_results(jobs: list[BatchJob], workers: int, should_stop: Callable[[], bool]) -> Iterable[PairOutcome]:
    if workers == 1:
        for job in jobs:
            yield process_pair(job)
            if should_stop():
                return
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=_ignore_sigint) as pool:
        futures = [pool.submit(process_pair, job) for job in jobs]

        def cancel() -> None:
            for future in futures:
                future.cancel()            # only those not started: the others finish
        try:
            yield from _until_stopped(as_completed(futures), cancel, should_stop)
        finally:
            cancel()


def _dask_results(jobs: list[BatchJob], scheduler: str, should_stop: Callable[[], bool]) -> Iterable[PairOutcome]:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise InvalidInputError("--scheduler needs Dask: pip install 'stereo-obstacles[dask]'") from exc
    try:
        client = Client(scheduler, timeout=30)
    except (OSError, TimeoutError, ValueError) as exc:  # ValueError: an address Dask cannot parse
        raise InputFileError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
    with client:
        futures = client.map(process_pair, jobs, pure=False)
        try:
            yield from _until_stopped(as_completed(futures), lambda: client.cancel(futures), should_stop)
        finally:
            client.cancel(futures)


def _until_stopped(completed: Iterable, cancel: Callable[[], object],
                   should_stop: Callable[[], bool]) -> Iterator[PairOutcome]:
    """The outcomes of the ``completed`` futures; once ``should_stop()`` says so, ``cancel()`` the
    ones not started and go on with those already running, so that every pair that finishes (and
    wrote its done file) is reported."""
    stopping = False
    for future in completed:
        if future.cancelled():
            continue
        yield future.result()
        if not stopping and should_stop():
            stopping = True
            cancel()


def run_batch(jobs: list[BatchJob], *, workers: int = 1, scheduler: str | None = None,
              on_outcome: Callable[[PairOutcome], None] | None = None,
              should_stop: Callable[[], bool] | None = None) -> list[PairOutcome]:
    """Run every job whose output folder has no done file; return one outcome per job.

    Parameters
    ----------
    jobs : list of BatchJob
    workers : int
        Local processes (1: in this process). Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); the jobs run on its workers, which
        must see the same input and output paths.
    on_outcome : callable, optional
        Called with each outcome as it arrives (skipped pairs first).
    should_stop : callable, optional
        Asked after each finished pair; when it returns True no further pair is started,
        pairs not yet started are cancelled, those already running are waited for (local
        processes), and the outcomes are returned. Dask cannot tell a running task from a
        queued one: its cancel reaches running tasks too, which finish anyway; those done by
        the time the outcomes are returned are read back from their done files, later ones are
        not in the outcomes (a rerun skips them).

    Returns
    -------
    list of PairOutcome
        Skipped pairs, then the others in order of completion (unfinished pairs have no
        outcome and no done file).
    """
    if int(workers) != workers or workers < 1:
        raise InvalidInputError(f"workers must be an integer >= 1, got {workers}")
    outcomes: list[PairOutcome] = []

    def record(outcome: PairOutcome) -> None:
        for message in outcome.warnings:
            logger.warning("%s: %s", outcome.name, message)
        outcomes.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)

    todo = []
    for job in jobs:
        if (Path(job.out_dir) / DONE_FILE).is_file():
            record(PairOutcome(job.pair.name, "skipped", 0.0, "done in an earlier run"))
        else:
            todo.append(job)
    if todo:
        stop = should_stop or (lambda: False)
        for outcome in _dask_results(todo, scheduler, stop) if scheduler else _local_results(todo, int(workers), stop):
            record(outcome)
        for outcome in finished_unreported(todo, outcomes):     # those Dask had running when it cancelled them
            record(outcome)
    return outcomes


def output_settings(job: BatchJob) -> dict:
    """What a job's outputs depend on besides its pair, as JSON values: the task, the calibration
    it was given (its values, not its file's name: the same file named from another folder is
    the same) and the options the task uses (``disparity``: the matching options only; a rectified
    rig's calibration plays no part in it), the matcher's with its defaults filled in (``--seeds
    sobel`` is the default). Stored in each pair's done file, and compared when a batch goes on in
    the same output folder (:func:`check_done_settings`)."""
    from inspect import Parameter, signature

    from stereo_obstacles.camera_calibration import CameraPairCalibration
    from stereo_obstacles.matching import match
    from stereo_obstacles.obstacle_json import jsonable
    from stereo_obstacles.pipeline import pipeline_match_kwargs

    match_defaults = {name: parameter.default for name, parameter in signature(match).parameters.items()
                      if parameter.default is not Parameter.empty}
    if job.task == "detect":
        calibration, options = job.calibration, job.config.to_dict()
        options["matching"] = {**match_defaults, **pipeline_match_kwargs(job.config.matching)}
    else:
        calibration = job.calibration if isinstance(job.calibration, CameraPairCalibration) else None
        options = {"matching": {**match_defaults, **job.config.matching.to_kwargs()}}
    settings = {"task": job.task, "calibration": None if calibration is None else calibration.to_dict(),
                "options": options}
    return json.loads(json.dumps(jsonable(settings)))


def check_done_settings(jobs: Iterable[BatchJob]) -> None:
    """Refuse to go on when pairs' done files record other :func:`output_settings` than their
    jobs': they would be skipped as done and kept, as if made with these. Done files without
    settings (written before they were recorded) are not checked.

    Raises
    ------
    OutputError
        Counting such pairs, naming the first few and what differs (for the options, which ones).
    """
    stale: list[str] = []
    differing: list[str] = []
    unknown_before = False
    for job in jobs:
        try:
            recorded = json.loads((Path(job.out_dir) / DONE_FILE).read_text(encoding="utf-8")).get("settings")
        except (OSError, ValueError, AttributeError):
            continue
        if not isinstance(recorded, dict):
            continue
        now = output_settings(job)
        these = [key for key in ("task", "calibration") if recorded.get(key) != now[key]]
        if "task" not in these:                  # another task's options are not comparable
            paths = _differing_paths(recorded.get("options"), now["options"])
            these += [f"option {path}" for path in paths]
            unknown_before = unknown_before or any(_lacks(recorded.get("options"), path) for path in paths)
        if these:
            stale.append(job.out_dir)
            differing += [key for key in these if key not in differing]
    if stale:
        shown = ", ".join(stale[:3]) + (f" and {len(stale) - 3} more" if len(stale) > 3 else "")
        older = " (or by a version of this tool without some of these options)" if unknown_before else ""
        raise OutputError(f"{len(stale)} pair(s) were done with another {', '.join(differing)}{older} ({shown}): they "
                          f"would be skipped as done; use another --out, or delete them to redo them")


def _lacks(options, path: str) -> bool:
    """Whether the nested mapping ``options`` has no value at the dotted ``path`` (an option the
    version that wrote it did not have)."""
    for key in path.split("."):
        if not isinstance(options, dict) or key not in options:
            return True
        options = options[key]
    return False


def _differing_paths(before, now, prefix: str = "") -> list[str]:
    """Dotted paths (``obstacles.max_distance_m``) of the values that differ between two nested
    JSON mappings; the path of the whole when either is not a mapping."""
    if before == now:
        return []
    if not (isinstance(before, dict) and isinstance(now, dict)):
        return [prefix or "options"]
    return [path for key in sorted(before.keys() | now.keys())
            for path in _differing_paths(before.get(key), now.get(key), f"{prefix}.{key}" if prefix else key)]


def write_summary(out_dir: str | os.PathLike[str], outcomes: list[PairOutcome], *, seconds: float,
                  interrupted: bool, settings: dict) -> Path:
    """Write ``batch_summary.json`` atomically: counts, throughput, and every pair's status and reason."""
    from stereo_obstacles import __version__
    from stereo_obstacles.atomic import write_text_atomic

    counts = {status: sum(o.status == status for o in outcomes) for status in ("done", "skipped", "failed")}
    summary = {"format": SUMMARY_FORMAT, "version": 1, "package_version": __version__,
               "interrupted": interrupted, "seconds": round(seconds, 3), "counts": counts,
               "pairs_per_second": round(counts["done"] / seconds, 4) if seconds > 0 else None,
               "settings": settings, "pairs": [asdict(o) for o in sorted(outcomes, key=lambda o: o.name)]}
    return write_text_atomic(Path(out_dir) / SUMMARY_FILE, json.dumps(summary, indent=1) + "\n")
