"""Interrupts: a SIGTERM held back until a unit of work is done."""

from __future__ import annotations

import os
import signal

import pytest

from stereo_obstacles.interrupts import TerminationDeferred, Terminated


def _raise_terminated(signum, frame):
    raise Terminated


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or os.name != "posix", reason="POSIX signals")
def test_a_sigterm_in_the_block_is_delivered_when_it_ends():
    # video wrote a frame's JSON line and video frame, and then was stopped before its report and its count
    previous = signal.signal(signal.SIGTERM, _raise_terminated)       # as the command line installs it
    done = []
    try:
        with pytest.raises(Terminated):
            with TerminationDeferred():
                os.kill(os.getpid(), signal.SIGTERM)
                done.append("the rest of the frame")
        assert done == ["the rest of the frame"]
        assert signal.getsignal(signal.SIGTERM) is _raise_terminated  # the handler is back
        with TerminationDeferred():                                     # nothing held: nothing raised
            done.append("next")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert done == ["the rest of the frame", "next"]
