"""Reading the project's versioned JSON documents: one set of checks and messages for all.

Each document states ``"format"`` (e.g. ``"stereo-obstacles/calibration"``) and an integer
``"version"``; a reader refuses a missing file, text that is not JSON, another format and a
version it does not know, each with one line that names the file.
"""

from __future__ import annotations

import json
import os

from stereo_obstacles import __version__
from stereo_obstacles.errors import InputFileError, StereoObstaclesError

__all__ = ["check_document", "is_document_of", "load_json_file"]


def load_json_file(path: str | os.PathLike[str], *, what: str,
                   error: type[StereoObstaclesError] = InputFileError) -> object:
    """The parsed content of the JSON file ``path`` (``what`` names it in messages, e.g. "calibration").

    Raises
    ------
    InputFileError
        The file does not exist.
    error
        The file cannot be read or is not JSON.
    """
    try:
        with open(path, encoding="utf-8") as handle:
            return json.load(handle)
    except FileNotFoundError as exc:
        raise InputFileError(f"{what} file {path} does not exist") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{what} file {path} is not valid JSON: {exc}") from exc


def check_document(data: object, *, format_name: str, version: int, source: str,
                   error: type[StereoObstaclesError] = InputFileError) -> dict:
    """``data`` as a mapping when it is a ``format_name`` document of ``version``; else ``error``."""
    if not isinstance(data, dict) or data.get("format") != format_name:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise error(f"{source} is not a {format_name} document (format: {found!r})")
    if data.get("version") != version:
        raise error(f"{source}: unsupported {format_name} version {data.get('version')!r} "
                    f"(this is stereo-obstacles {__version__}, which reads version {version})")
    return data


def is_document_of(path: str | os.PathLike[str], format_name: str) -> bool:
    """Whether ``path`` is a JSON document of ``"format": format_name`` (False for a missing,
    unreadable or other file): how the commands recognise what they wrote before, so that they
    replace or remove nothing else."""
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and data.get("format") == format_name
