"""Moves into an output folder cut short at a chosen file, as Ctrl-C or a kill would cut them."""

from __future__ import annotations

import contextlib
import os


@contextlib.contextmanager
def move_stopped_at(monkeypatch, destination):
    """Within the block, the rename of a file onto ``destination`` raises ``KeyboardInterrupt``
    (the move into the output folder, not a write of the staged file); every other rename works."""
    real_replace = os.replace

    def stopped(src, dst):
        if os.fspath(dst) == os.fspath(destination):
            raise KeyboardInterrupt
        real_replace(src, dst)

    with monkeypatch.context() as patched:
        patched.setattr(os, "replace", stopped)
        yield
