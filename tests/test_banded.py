"""Row bands grown in parallel threads: one band is the single growth, several stay close to it."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from stereo_obstacles.banded import LOWER_ROWS_COST, band_rows, match_bands
from stereo_obstacles.errors import InvalidInputError
from stereo_obstacles.growing import grow
from stereo_obstacles.matching import match
from stereo_obstacles.seeds import find_seeds
from stereo_obstacles.shifted_windows import shifted_window_check
from stereo_obstacles.similarity import prepare_similarity
from stereo_obstacles.stable_matching import stable_matching
from stereo_obstacles.subpixel import parabola_offset
from stereo_obstacles.thread_pool import run_in_threads

OPTIONS = dict(d_min=0, d_max=12, tau=0.6, mu=0.1, max_candidates=10, margin_reference="max", greedy=False)


def _layers(shape=(60, 90), seed=3):
    """Random texture at disparity 4 with a square at disparity 9 in front of it."""
    rng = np.random.default_rng(seed)
    h, w = shape
    back = rng.uniform(0, 255, (h, w + 20))
    front = rng.uniform(0, 255, (h, w + 20))
    left, right = back[:, 0:w].copy(), back[:, 4:w + 4].copy()
    left[15:45, 40:70] = front[15:45, 40:70]
    right[15:45, 31:61] = front[15:45, 40:70]
    return left.astype(np.float32), right.astype(np.float32)


def test_band_rows_cover_the_image_once():
    for h, n, overlap in [(100, 2, 16), (7, 3, 0), (5, 8, 2), (375, 4, 9)]:
        rows = band_rows(h, n, overlap)
        owned = np.concatenate([np.arange(lo, hi) for lo, hi, _, _ in rows])
        assert owned.tolist() == list(range(h))
        for lo, hi, g_lo, g_hi in rows:
            assert g_lo == max(0, lo - overlap) and g_hi == min(h, hi + overlap)
    with pytest.raises(InvalidInputError, match="n_bands"):
        band_rows(10, 0, 4)
    with pytest.raises(InvalidInputError, match="overlap"):
        band_rows(10, 2, -1)


def test_lower_bands_are_thinner_with_equal_shares_of_the_modelled_cost():
    h = 375
    for n in (2, 3, 5):
        rows = band_rows(h, n, 8)
        heights = [hi - lo for lo, hi, _, _ in rows]
        assert heights == sorted(heights, reverse=True) and heights[0] > heights[-1]
        y = np.arange(h)
        cost = 1 + (LOWER_ROWS_COST - 1) * y / (h - 1)  # the model: linear from top to bottom row
        shares = [cost[lo:hi].sum() / cost.sum() for lo, hi, _, _ in rows]
        assert max(shares) - min(shares) < 2.5 * cost.max() / cost.sum()  # equal to a row or two
    assert [r[:2] for r in band_rows(375, 2, 8)] == [(0, 202), (202, 375)]  # 54 % of the rows on top


def test_one_band_is_the_single_growth():
    left, right = _layers()
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "canny", d_min=0, d_max=12, tau=0.6, margin=0.1)
    banded = match_bands(inputs, seeds, scanned_hi=seeds.scanned_hi, n_bands=1, final_margin=0.1, **OPTIONS)
    growth = grow(inputs, seeds, scanned_hi=seeds.scanned_hi, **OPTIONS)
    won = stable_matching(growth.y, growth.x, growth.x_right, growth.similarity, left.shape, margin=0.1)
    y, x, xr, c = growth.y[won], growth.x[won], growth.x_right[won], growth.similarity[won]
    c_minus, c_plus = growth.side_similarities(y, x, x - xr)
    assert np.all(np.diff(banded.y) >= 0)  # the bands give their matches row by row
    in_rows = np.argsort(y, kind="stable")  # and, inside a row, in table order
    y, x, xr, c, c_minus, c_plus = (a[in_rows] for a in (y, x, xr, c, c_minus, c_plus))
    np.testing.assert_array_equal(banded.y, y)
    np.testing.assert_array_equal(banded.x, x)
    np.testing.assert_array_equal(banded.x_right, xr)
    np.testing.assert_array_equal(banded.similarity, c)
    np.testing.assert_array_equal(banded.offset, parabola_offset(c_minus, c, c_plus))
    assert banded.n_candidates == growth.y.shape[0] and banded.n_computed == growth.n_computed
    assert 0 < banded.growth_seconds <= banded.matched_seconds


@pytest.mark.parametrize("n_bands, overlap", [(2, 16), (3, 0), (4, 6)])
def test_several_bands_recover_the_layers(n_bands, overlap):
    left, right = _layers()
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "canny", d_min=0, d_max=12, tau=0.6, margin=0.1)
    banded = match_bands(inputs, seeds, scanned_hi=seeds.scanned_hi, n_bands=n_bands, overlap=overlap,
                         final_margin=0.1, **OPTIONS)
    keys = banded.y * 1000 + banded.x
    assert np.unique(keys).size == keys.size  # each left pixel once: bands own disjoint rows
    truth = np.where((banded.y >= 15) & (banded.y < 45) & (banded.x >= 40) & (banded.x < 70), 9, 4)
    disparity = banded.x - banded.x_right
    assert np.mean(disparity == truth) > 0.97
    assert banded.y.size > 0.8 * left.size
    # the bands find about as many matches as the single growth
    single = match_bands(inputs, seeds, scanned_hi=seeds.scanned_hi, n_bands=1, final_margin=0.1, **OPTIONS)
    assert abs(banded.y.size - single.y.size) < 0.02 * single.y.size


def test_match_bands_option_gives_the_same_accuracy():
    left, right = _layers()
    one = match(left, right, max_disparity=12, bands=1)
    two = match(left, right, max_disparity=12, bands=2)
    both = np.isfinite(one.disparity) & np.isfinite(two.disparity)
    assert both.mean() > 0.8
    assert np.mean(np.abs(one.disparity[both] - two.disparity[both]) < 1e-6) > 0.97
    assert abs(one.stats.density - two.stats.density) < 0.02
    with pytest.raises(InvalidInputError, match="bands"):
        match(left, right, max_disparity=12, bands=0)


def _checked_bands(n_bands, overlap=16):
    """The layers scene matched by bands with the shifted-window check, and without it."""
    left, right = _layers()
    inputs = prepare_similarity(left, right)
    seeds = find_seeds(inputs, left, "canny", d_min=0, d_max=12, tau=0.6, margin=0.1)
    run = dict(scanned_hi=seeds.scanned_hi, n_bands=n_bands, overlap=overlap, final_margin=0.1, **OPTIONS)
    return inputs, match_bands(inputs, seeds, shifted_windows=True, **run), match_bands(inputs, seeds, **run)


@pytest.mark.parametrize("n_bands, overlap", [(1, 16), (2, 16), (3, 0), (7, 2)])
def test_check_in_the_bands_is_the_check_of_the_whole_image(n_bands, overlap):
    inputs, checked, plain = _checked_bands(n_bands, overlap)
    keep, n_checked = shifted_window_check(inputs, plain.y, plain.x, plain.x - plain.x_right)
    assert n_checked > 0 and not keep.all()  # the square's edges are checked, and some matches fail
    np.testing.assert_array_equal(checked.y, plain.y[keep])
    np.testing.assert_array_equal(checked.x_right, plain.x_right[keep])
    np.testing.assert_array_equal(checked.offset, plain.offset[keep])
    assert (checked.n_edge_checked, checked.n_edge_rejected) == (n_checked, keep.size - keep.sum())
    assert plain.n_edge_checked == plain.n_edge_rejected == 0
    assert 0 < checked.growth_seconds <= checked.matched_seconds <= checked.checked_seconds
    assert plain.checked_seconds == plain.matched_seconds


def _within(seconds, function):
    """``function()`` on a daemon thread; fails the test when it has not ended after ``seconds``
    (a band waiting for ever must not hang the test run). Returns its result or raises its error."""
    outcome = {}

    def run():
        try:
            outcome["result"] = function()
        except BaseException as error:  # handed to the test
            outcome["error"] = error

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=seconds)
    assert not thread.is_alive(), f"still running after {seconds} s"
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]


def test_bands_run_one_after_the_other_on_a_pool_thread():
    """A call made on a pool thread runs its bands in turn on that thread: no band may wait for
    another's matches (it would wait for ever)."""
    on_pool = _within(120, lambda: run_in_threads(lambda k: _checked_bands(2)[1] if k else None, [(0,), (1,)])[1])
    direct = _checked_bands(2)[1]
    np.testing.assert_array_equal(on_pool.y, direct.y)
    np.testing.assert_array_equal(on_pool.x, direct.x)
    assert on_pool.n_edge_rejected == direct.n_edge_rejected > 0


def test_a_failing_band_ends_the_call(monkeypatch):
    """A band that raises wakes the band waiting for its matches, a piece of final matching that
    raises on another thread reaches its band; the error reaches the caller."""
    from stereo_obstacles.stable_matching import RowMatching
    match_rows = RowMatching.match_rows

    def failing_on_the_pool(self, lo, hi):
        if threading.current_thread().name.startswith("gcs-band"):
            raise RuntimeError("piece failed")
        return match_rows(self, lo, hi)

    monkeypatch.setattr(RowMatching, "match_rows", failing_on_the_pool)
    with pytest.raises(RuntimeError, match="piece failed"):
        _within(120, lambda: _checked_bands(2))


def _slow_pool_band(monkeypatch):
    """The band on the pool thread grows 0.3 s later and matches each piece of rows 0.05 s
    later, so that the caller's band waits for it and sees its pieces handed out."""
    import time

    import stereo_obstacles.banded as banded
    from stereo_obstacles.stable_matching import RowMatching
    grow, match_rows = banded.grow, RowMatching.match_rows

    def on_the_pool_later(function, seconds):
        def later(*args, **kwargs):
            if threading.current_thread().name.startswith("gcs-band"):
                time.sleep(seconds)
            return function(*args, **kwargs)
        return later

    monkeypatch.setattr(banded, "grow", on_the_pool_later(grow, 0.3))
    monkeypatch.setattr(RowMatching, "match_rows", on_the_pool_later(match_rows, 0.05))


def test_an_interrupt_after_taking_another_bands_piece_ends_the_call(monkeypatch):
    """Ctrl-C may land after a thread has taken a piece of another band's final matching and
    before it runs it: the band waiting for that piece must not wait for ever."""
    from stereo_obstacles.banded import _SharedWork
    _slow_pool_band(monkeypatch)
    caller = {}

    def interrupted_help(self):
        if threading.current_thread() is not caller["thread"]:
            return help_others(self)
        with self._changed:
            assert self._changed.wait_for(lambda: any(owner == 1 for owner, _ in self._pending), timeout=30)
            assert self._take(1) is not None  # a piece of band 1's final matching, now never run
        raise KeyboardInterrupt("Ctrl-C after taking a piece")

    help_others = _SharedWork.help_others
    monkeypatch.setattr(_SharedWork, "help_others", interrupted_help)

    def run():
        caller["thread"] = threading.current_thread()
        return _checked_bands(2)

    with pytest.raises(KeyboardInterrupt, match="after taking a piece"):
        _within(60, run)


def test_an_interrupt_while_marking_a_band_done_ends_the_call(monkeypatch):
    from stereo_obstacles.banded import _SharedWork
    _slow_pool_band(monkeypatch)
    set_state = _SharedWork.set_state

    def interrupted_set_state(self, band, state):
        if state == "done" and band == 0:
            raise KeyboardInterrupt("Ctrl-C while marking band 0 done")
        return set_state(self, band, state)

    monkeypatch.setattr(_SharedWork, "set_state", interrupted_set_state)
    with pytest.raises(KeyboardInterrupt, match="marking band 0 done"):
        _within(60, lambda: _checked_bands(2))
