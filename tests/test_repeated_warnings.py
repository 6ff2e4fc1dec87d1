"""Each warning once over a run of many pairs."""

from __future__ import annotations

import logging

from stereo_obstacles.commands._repeated_warnings import _OncePerMessage, each_warning_once, repeats_note


def test_the_once_per_warning_filter_passes_other_levels_and_new_warnings():
    once = _OncePerMessage()

    def record(level, msg, *args):
        return logging.LogRecord("stereo_obstacles.x", level, __file__, 1, msg, args, None)

    assert once.filter(record(logging.WARNING, "range cut off at %d px", 64))
    assert not once.filter(record(logging.WARNING, "range cut off at %d px", 32))      # same warning, new numbers
    assert once.filter(record(logging.WARNING, "another warning"))
    assert once.filter(record(logging.INFO, "GCS: %d seeds", 10)) and once.filter(record(logging.INFO, "GCS: %d seeds", 9))
    assert once.filter(record(logging.ERROR, "x")) and once.filter(record(logging.ERROR, "x"))
    assert once.repeats == 1


def test_each_warning_once_filters_the_root_handlers_within_the_block_only():
    root = logging.getLogger()
    handler = logging.Handler()
    seen = []
    handler.emit = seen.append
    root.addHandler(handler)
    log = logging.getLogger("test_repeated_warnings")                  # a level of its own: other tests set theirs
    log.setLevel(logging.WARNING)
    try:
        with each_warning_once() as repeats:
            for value in (1, 2, 3):
                log.warning("scale %g raised", value)
        assert [r.getMessage() for r in seen] == ["scale 1 raised"] and repeats() == 2
        log.warning("scale %g raised", 4)                         # after the block: every one again
        with each_warning_once(enabled=False) as repeats:       # -v: nothing held back
            log.warning("scale %g raised", 5)
        assert len(seen) == 3 and repeats() == 0
    finally:
        root.removeHandler(handler)
    assert repeats_note(0) == "" and repeats_note(2) == "2 repeats of the warnings above not shown"
