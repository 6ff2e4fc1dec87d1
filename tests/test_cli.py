"""The command line as a whole: help, version, error reporting, ``python -m``."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import textwrap

import pytest

from stereo_obstacles import __version__, cli
from stereo_obstacles.errors import InputFileError
from stereo_obstacles.interrupts import Terminated


def test_help_lists_every_sub_command(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    assert len(commands) == len(cli.COMMAND_MODULES) > 0
    for name in commands:
        assert name in out


def test_version(capsys):
    with pytest.raises(SystemExit):
        cli.main(["--version"])
    assert __version__ in capsys.readouterr().out


def test_missing_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main([])
    assert exit_info.value.code == 2


@pytest.mark.parametrize("argv, text", [(["detect", "l.png", "r.png", "--focal", "abc", "--out", "o"],
                                         "stereo-obstacles detect: error: argument --focal: invalid float value: 'abc'"),
                                        (["detect"], "the following arguments are required: left, right, --out"),
                                        (["frobnicate"], "invalid choice: 'frobnicate'")])
def test_usage_errors_are_one_line_pointing_to_the_help(capsys, argv, text):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    err = capsys.readouterr().err
    assert exit_info.value.code == cli.EXIT_USAGE and err.count("\n") == 1
    assert text in err and err.rstrip().endswith("--help)") and "usage:" not in err


def _parser_with(handler):
    def build():
        parser = argparse.ArgumentParser(prog=cli.PROG)
        parser.add_argument("-v", "--verbose", action="count", default=0)
        parser.set_defaults(handler=handler)
        return parser
    return build


def _wrapped_by_a_kernel(interrupt: BaseException) -> SystemError:
    """The ``SystemError`` a numba kernel raises when a signal's exception lands inside it."""
    error = SystemError("CPUDispatcher(<function _grow_kernel>) returned a result with an exception set")
    error.__cause__ = interrupt
    return error


@pytest.mark.parametrize("exception, code, text", [
    (InputFileError("left.png does not exist"), cli.EXIT_ERROR, "error: left.png does not exist"),
    (KeyboardInterrupt(), cli.EXIT_INTERRUPTED, "interrupted"),
    (_wrapped_by_a_kernel(KeyboardInterrupt()), cli.EXIT_INTERRUPTED, "interrupted"),
    (Terminated(), cli.EXIT_TERMINATED, "terminated"),
    (_wrapped_by_a_kernel(Terminated()), cli.EXIT_TERMINATED, "terminated"),
    (RuntimeError("boom\nsecond line"), cli.EXIT_INTERNAL, "internal error: RuntimeError: boom second line"),
])
def test_errors_become_one_line_and_an_exit_code(monkeypatch, capsys, exception, code, text):
    def handler(args):
        raise exception
    monkeypatch.setattr(cli, "build_parser", _parser_with(handler))
    assert cli.main([]) == code
    err = capsys.readouterr().err
    assert text in err and err.count("\n") == 1 and "Traceback" not in err


def test_sigterm_removes_the_staged_report_and_exits_143(tmp_path):
    """Python's default SIGTERM exits without clean-up: a half-written report would stay hidden beside ``--out``."""
    script = textwrap.dedent("""
        import argparse, os, signal, sys, time
        from stereo_obstacles import cli
        from stereo_obstacles.atomic import staged_directory

        def handler(args):
            with staged_directory(sys.argv[1]) as stage:
                (stage / "obstacles.json").write_text("{}")
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(30)                          # never reached: the signal's handler raises

        parser = argparse.ArgumentParser()
        parser.add_argument("-v", "--verbose", action="count", default=0)
        parser.set_defaults(handler=handler)
        cli.build_parser = lambda: parser
        sys.exit(cli.main([]))
        """)
    result = subprocess.run([sys.executable, "-c", script, str(tmp_path / "report")], capture_output=True, text=True,
                            check=False, timeout=60)
    assert result.returncode == cli.EXIT_TERMINATED, result.stderr
    assert result.stderr.strip() == "stereo-obstacles: terminated"
    assert list(tmp_path.iterdir()) == []                        # neither the report nor its staging folder


def test_a_truncated_image_is_one_line_without_opencvs_own_warning(tmp_path):
    import cv2
    import numpy as np

    image = tmp_path / "left.png"
    cv2.imwrite(str(image), np.random.default_rng(0).integers(0, 255, (60, 80, 3), dtype=np.uint8))
    image.write_bytes(image.read_bytes()[:2000])
    result = subprocess.run([sys.executable, "-m", "stereo_obstacles", "detect", str(image), str(image),
                             "--uncalibrated", "--out", str(tmp_path / "out")], capture_output=True, text=True,
                            check=False, timeout=120)
    assert result.returncode == cli.EXIT_ERROR
    assert result.stderr.count("\n") == 1 and "is not an image OpenCV can decode" in result.stderr


def test_python_dash_m_runs_the_same_command():
    result = subprocess.run([sys.executable, "-m", "stereo_obstacles", "--version"],
                            capture_output=True, text=True, check=False)
    assert result.returncode == 0 and __version__ in result.stdout


def test_every_reference_option_states_the_default_it_uses():
    from stereo_obstacles.reference_area import DEFAULT_REFERENCE_AREA, ReferenceArea

    commands = next(a for a in cli.build_parser()._actions
                    if isinstance(a, argparse._SubParsersAction)).choices
    helps = {name: action.help % {} for name, sub in commands.items() for action in sub._actions
             if "--reference" in action.option_strings}
    assert {"detect", "segment", "demo", "video", "batch"} <= set(helps)
    stated = {name: text.rsplit(" ", 1)[-1].rstrip(")") for name, text in helps.items()}
    for name, value in stated.items():
        assert ReferenceArea.parse(value) == DEFAULT_REFERENCE_AREA, (name, helps[name])


NUMBA_CACHE_IN_USE = os.environ.get("NUMBA_DISABLE_JIT", "0") == "0" and os.environ.get(
    "STEREO_OBSTACLES_NUMBA_CACHE", "1") != "0"


@pytest.mark.skipif(not NUMBA_CACHE_IN_USE, reason="numba's JIT or the kernel cache is switched off here")
def test_a_cold_numba_cache_is_announced_and_a_warm_one_is_not(tmp_path, capsys):
    """The first run after installing compiles for about half a minute: it says so instead of looking hung."""
    from stereo_obstacles.commands._compile_notice import announce_compilation, kernels_cached
    from stereo_obstacles.pipeline import warm_up

    code = ("from stereo_obstacles.commands._compile_notice import announce_compilation, kernels_cached\n"
            "print(kernels_cached())\n"
            "announce_compilation()\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}             # an empty cache: a fresh install
    cold = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                          timeout=120)
    assert cold.stdout.split() == ["False"] and cold.stderr.count("compiling the numba kernels first") == 1
    warm_up()                                                           # this process's cache, filled
    assert kernels_cached() is True
    announce_compilation()
    assert capsys.readouterr().err == ""


@pytest.mark.skipif(not NUMBA_CACHE_IN_USE, reason="numba's JIT or the kernel cache is switched off here")
def test_every_sentinel_kernel_exists_and_is_cached_by_numba():
    import importlib

    from stereo_obstacles.commands._compile_notice import SENTINEL_KERNELS

    for module_name, name in SENTINEL_KERNELS:
        kernel = getattr(importlib.import_module(f"stereo_obstacles.{module_name}"), name)
        assert kernel._cache._cache_file is not None, (module_name, name)     # @njit(cache=True)


@pytest.mark.parametrize("option, value", [("--max-distance", "-1"), ("--corridor-width", "0"),
                                           ("--max-distance", "nan"), ("--corridor-width", "wide")])
def test_a_length_option_out_of_range_is_named_by_its_option(tmp_path, capsys, option, value):
    """The error named the configuration's field (max_distance_m), not the option the user typed."""
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["detect", "l.png", "r.png", "--out", str(tmp_path / "o"), option, value])
    assert exit_info.value.code == 2
    assert f"argument {option}: expected metres > 0" in capsys.readouterr().err
