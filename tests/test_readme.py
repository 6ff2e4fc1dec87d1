"""The README's Python example runs as written on the pair its quick-start command writes, and
prints what the README shows."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

from stereo_obstacles.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"


def _section_blocks(section: str) -> list[str]:
    text = README.read_text(encoding="utf-8")
    body = text.split(f"## {section}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```\w*\n(.*?)```", body, flags=re.DOTALL)


def test_the_python_example_prints_what_the_readme_shows(tmp_path, monkeypatch):
    code, shown = _section_blocks("Python API")[:2]
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--out", "demo_out"]) == 0                 # the quick start's pair
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code, "README.md", "exec"), {})
    assert printed.getvalue() == shown
