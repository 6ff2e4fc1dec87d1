"""Compiled growth of correspondence seeds over the disparity space (private).

The public wrapper is :func:`stereo_obstacles.growing.grow`. The growth is bound by memory
latency (profiled: the hot instructions were the loads of the memo), so consecutive pops are
kept near each other (a coarse priority queue, see ``growing.QUEUE_BUCKETS``) and everything a
visit of a left pixel needs lives in one 32-byte record (two per cache line) of one int16
buffer ``buf``:

* pixel record ``(y * W + x) * REC``: the ``FILL`` word (bits 0-4: points stored for the
  pixel; from bit :data:`FLAG_SHIFT`: the in-T flags of the window slots), the candidate count
  and the best candidate similarity of the pixel as a left pixel, the window base ``BASE``, the
  newest overflow block (an int32 at int32 index ``rec // 2 + NEXT32``), and a window of
  :data:`WIN` similarities of the consecutive codes ``BASE .. BASE + WIN - 1`` (code
  ``d - d_min``) at ``KEY + code - BASE``, :data:`NOT_STORED` where none is stored. The first
  point stored at a pixel places the window (:data:`WIN_BELOW` codes below it): the growth
  moves in disparity steps of one, so about 94 % of a pixel's points fall in it (Teddy, Cones),
  and a look-up there is one load;
* overflow blocks after the ``H * W`` records, for the codes outside the window, taken in
  order of use: ``FILL`` (slots used), the link to the pixel's next older block, and
  :data:`SLOTS` keys ``code * 2 + in_T`` at ``KEY + j`` with their similarities at
  ``KEY + SLOTS + j``.

A stored point is named by the index of its similarity in ``buf`` (:func:`_value_index`); an
index below ``H * W * REC`` is a window slot, whose in-T flag is bit
``FLAG_SHIFT + index - rec - KEY`` of its record's ``FILL`` word; above, an overflow slot, whose
flag is bit 0 of its key.

The candidate count and best similarity of each pixel as a *right* pixel live apart, in a
compact int16 array (4 bytes a pixel): only the acceptance tests read them, and a record's
cache line for two of its words cost more than the two words it freed for the window.

Similarities are stored as int16 in steps of ``1 / QUANT`` (3e-5; :func:`quantise`), and every
decision of the growth uses the stored value, so the reference implementation reproduces it.

Every point's similarity is computed at most once; a point arriving at a pixel already
holding ``n_slots`` is computed but not stored (counted as an overflow) and can never join the
candidate table.

The candidate table T is ``t_int`` (rows ``y, x, x', next-in-bucket``) and ``t_c``, sized
``K * H * W`` (the per-pixel cap bounds it; ``np.empty`` pages are only touched as used). The
priority queue is a bucket queue over similarity quantised in ``n_buckets`` steps on
``[tau, 1]``, a linked list per bucket, LIFO inside a bucket. No array is reassigned and no
function with array arguments is called inside the loop: either makes numba emit atomic
reference counting on every iteration (measured: 4x slower growth).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import config, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from stereo_obstacles._similarity_kernel import CACHE, FASTMATH, KIND_NCC, RADIUS, UNDEFINED

REC = 16
"""int16 words per pixel record and per overflow block (32 bytes)."""
SLOTS = 4
"""Memo slots per overflow block."""
FILL, CNT_L, BEST_L, BASE, KEY = 0, 1, 2, 3, 6
"""int16 word offsets inside a record (blocks use ``FILL``, the link and the slots only)."""
COUNT_MASK = 0x1F
"""Bits of the ``FILL`` word holding the count of stored points (at most 31)."""
WIN = 10
"""Consecutive disparity codes a record stores directly (its words ``KEY .. KEY + WIN - 1``)."""
WIN_BELOW = 4
"""Codes of the window below the first point stored at the pixel."""
NOT_STORED = -32768
"""Window word of a code with no stored similarity (stored ones are in ``[-32767, 32767]``), and
the ``BASE`` of a record with none (every code then falls outside the window)."""
FLAG_SHIFT = 5
"""Bit of the in-T flag of window slot 0 in the ``FILL`` word (slot ``j``: ``FLAG_SHIFT + j``;
``FLAG_SHIFT + WIN`` bits fit the 16-bit word)."""
NEXT32 = 2
"""int32 offset of the overflow link inside a record or block (int16 words 4 and 5)."""
QUANT = 32767.0
"""Stored similarities are multiples of ``1 / QUANT``."""
STEP = 1.0 / QUANT
"""The stored int16 ``q`` stands for ``q * STEP`` (a multiplication: a division by ``QUANT`` on
every memo hit was ~15 % of the growth's time; both are monotone in ``q``, so no comparison of
stored values changes)."""
MAX_CODE = 16383
"""Largest ``d - d_min`` a key holds (``code * 2 + 1`` must fit in int16)."""
MAX_COUNT = 32767
"""Largest per-pixel candidate cap the int16 counts hold (a record's, as a left pixel; the
``right`` array's, as a right pixel)."""

# the layout above must hold together: the count must not carry into the first window flag, the
# flags must fit the word, and the link, the window and a block's keys and values the 16 words
assert COUNT_MASK < 1 << FLAG_SHIFT and FLAG_SHIFT + WIN <= 16
assert BASE < 2 * NEXT32 and 2 * NEXT32 + 2 <= KEY and KEY + WIN <= REC and KEY + 2 * SLOTS <= REC

# The 16-point disparity-space neighbourhood of (y, x, x') in 4 groups: (dy, dx, dx'); a fifth
# group, the point itself, is how a seed enters (one code path for both).
_NEIGHBOURS = np.array([
    (0, -1, -1), (0, -2, -1), (0, -1, -2),
    (0, 1, 1), (0, 2, 1), (0, 1, 2),
    (-1, 0, 0), (-1, -1, 0), (-1, 1, 0), (-1, 0, -1), (-1, 0, 1),
    (1, 0, 0), (1, -1, 0), (1, 1, 0), (1, 0, -1), (1, 0, 1),
    (0, 0, 0),
], dtype=np.int64)
_GROUP_START = np.array([0, 3, 6, 11, 16, 17], dtype=np.int64)
_SEED_GROUP = 4

N_COUNTERS = 4
COUNT_COMPUTED = 0
COUNT_OVERFLOW = 1
COUNT_BLOCKS = 2
COUNT_RESCANNED = 3
"""Counter indices: points computed, overflows, overflow blocks used, computed points that a
seed scanline search had already evaluated (so that visited points can be counted once)."""


def _prefetch_python(arr, index):
    """What :func:`_prefetch` does without the JIT (``NUMBA_DISABLE_JIT=1``): nothing, a prefetch
    only changes timing."""


if config.DISABLE_JIT:
    _prefetch = _prefetch_python
else:
    @intrinsic
    def _prefetch(typingctx, arr, index):
        """Ask the CPU to start loading the cache line of ``arr[index]`` (1-D array, no bounds check:
        a prefetch never faults)."""
        sig = types.void(arr, index)

        def codegen(context, builder, signature, args):
            array_type, index_type = signature.args
            array = context.make_array(array_type)(context, builder, args[0])
            position = context.cast(builder, args[1], index_type, types.intp)
            ptr = cgutils.get_item_pointer(context, builder, array_type, array, [position], wraparound=False)
            byte_ptr = ir.IntType(8).as_pointer()
            i32 = ir.IntType(32)
            fn_type = ir.FunctionType(ir.VoidType(), [byte_ptr, i32, i32, i32])
            fn = cgutils.get_or_insert_function(builder.module, fn_type, "llvm.prefetch.p0")
            read, keep_in_all_levels, data = (ir.Constant(i32, v) for v in (0, 3, 1))
            builder.call(fn, [builder.bitcast(ptr, byte_ptr), read, keep_in_all_levels, data])
            return context.get_dummy_value()

        return sig, codegen


def buffer_size(h, w, n_slots):
    """int16 words of the record buffer of an ``h x w`` image: records and every overflow block
    (the first point of a pixel is in its window, so at most ``n_slots - 1`` overflow)."""
    return h * w * (1 + -(-(n_slots - 1) // SLOTS)) * REC


@njit(cache=CACHE, inline="always")
def quantise(c):
    """The stored int16 form of a similarity ``c`` in [-1, 1]."""
    return np.int16(np.rint(c * QUANT))


@njit(cache=CACHE, inline="always")
def _value_index(buf, wide, rec, code, n_px):
    """Index in ``buf`` of the stored similarity of disparity ``code`` at the pixel record ``rec``:
    its window slot, or the value slot of an overflow block; -1 if none is stored."""
    off = code - buf[rec + BASE]
    if off >= 0 and off < WIN:
        return rec + KEY + off if buf[rec + KEY + off] != NOT_STORED else -1
    s = -1
    blk = wide[(rec >> 1) + NEXT32]
    while blk >= 0 and s < 0:
        base = (n_px + blk) * REC
        for j in range(buf[base + FILL]):  # no early exit: selects instead of branches
            if buf[base + KEY + j] >> 1 == code:
                s = base + KEY + SLOTS + j
        blk = wide[(base >> 1) + NEXT32]
    return s


@njit(cache=CACHE, nogil=True)
def _init_records(buf, n_px):
    """Initialise the ``n_px`` pixel records at the start of ``buf`` (bests: -1, below any tau)."""
    wide = buf.view(np.int32)
    for p in range(n_px):
        b = p * REC
        buf[b + FILL] = 0
        buf[b + CNT_L] = 0
        buf[b + BEST_L] = -32767
        buf[b + BASE] = NOT_STORED
        wide[(b >> 1) + NEXT32] = -1
        for j in range(WIN):
            buf[b + KEY + j] = NOT_STORED


@njit(cache=CACHE, fastmath=FASTMATH, nogil=True)
def _grow_kernel(lp, rp, ml, nl, mr, nr, kind, seed_y, seed_x, seed_xr, seed_c, scanned_hi, buf, d_min,
                 d_max, tau, mu, k_max, use_max, greedy, n_slots, n_buckets):
    """Grow the seeds; see ``growing.py`` for the rule and the module docstring for the data.

    ``scanned_hi[y, x]`` is the largest disparity a seed scanline search evaluated at the
    pixel (``seeds.NOT_SCANNED`` where none). ``buf`` is an int16 array of :func:`buffer_size` words. Returns the
    candidate table ``(t_y, t_x, t_xr, t_c)``, the record buffer and the counters.
    """
    h, w = ml.shape
    side = 2 * RADIUS + 1
    n_px = h * w
    _init_records(buf, n_px)
    right = np.empty(2 * n_px, np.int16)  # per right pixel: candidate count, best similarity
    for p in range(n_px):
        right[2 * p] = 0
        right[2 * p + 1] = -32767  # below any tau
    wide = buf.view(np.int32)
    flags = buf.view(np.uint16)  # FILL words: count in bits 0-4, window in-T flags above
    n_words = n_px * REC  # value indices from here on are overflow slots
    counters = np.zeros(N_COUNTERS, np.int64)
    cap = n_px * (1 if greedy else k_max)  # the per-pixel cap bounds the table
    t_int = np.empty((cap, 4), np.int32)
    t_c = np.empty(cap, np.float32)
    bucket_head = np.full(n_buckets, -1, np.int32)
    bucket_scale = (n_buckets - 1) / max(1.0 - tau, 1e-6)
    n_blocks = 0
    n_t = 0
    top = -1
    n_seeds = seed_y.shape[0]
    y = 0
    x = 0
    xr = 0
    i = -1
    while True:  # the seeds first (one point each), then pops until the queue is empty
        i += 1
        if i < n_seeds:
            y = seed_y[i]
            x = seed_x[i]
            xr = seed_xr[i]
            g_lo = _SEED_GROUP
            g_hi = _SEED_GROUP + 1
        else:
            while top >= 0 and bucket_head[top] < 0:
                top -= 1
            if top < 0:
                break
            p = bucket_head[top]
            bucket_head[top] = t_int[p, 3]
            y = t_int[p, 0]
            x = t_int[p, 1]
            xr = t_int[p, 2]
            # the records the groups on rows y - 1 and y + 1 and the cap tests on the right
            # pixels will read: their loads were the slowest of the loop (perf)
            if y > 0:
                _prefetch(buf, ((y - 1) * w + x) * REC)
                _prefetch(right, ((y - 1) * w + xr) * 2)
            if y + 1 < h:
                _prefetch(buf, ((y + 1) * w + x) * REC)
                _prefetch(right, ((y + 1) * w + xr) * 2)
            _prefetch(right, (y * w + xr) * 2)
            g_lo = 0
            g_hi = _SEED_GROUP
        for g in range(g_lo, g_hi):
            # the best point q of group g (or the seed), its similarity qc and memo word qslot
            qc = -3.0
            qslot = -1
            qy = 0
            qx = 0
            qxr = 0
            for k in range(_GROUP_START[g], _GROUP_START[g + 1]):
                py = y + _NEIGHBOURS[k, 0]
                px = x + _NEIGHBOURS[k, 1]
                pxr = xr + _NEIGHBOURS[k, 2]
                if py < 0 or py >= h or px < 0 or px >= w or pxr < 0 or pxr >= w:
                    continue
                code = px - pxr - d_min
                if code < 0 or code > d_max - d_min:
                    continue
                # memo look-up, written out (see the module docstring on calls in this loop)
                rec = (py * w + px) * REC
                n = flags[rec + FILL] & COUNT_MASK
                s = _value_index(buf, wide, rec, code, n_px)
                if s >= 0:
                    c = buf[s] * STEP
                else:
                    if i < n_seeds:
                        c = quantise(seed_c[i]) * STEP
                    else:  # same formula as _similarity_kernel._similarity (tests check they agree)
                        a = nl[py, px]
                        b = nr[py, pxr]
                        if a <= 0.0 or b <= 0.0:
                            c = UNDEFINED
                        else:
                            acc = 0.0  # one partial sum per window row: five short dependency chains
                            for ii in range(side):
                                row = 0.0
                                for jj in range(side):
                                    row += np.float64(lp[py + ii, px + jj]) * np.float64(rp[py + ii, pxr + jj])
                                acc += row
                            cov = acc * (1.0 / (side * side)) - np.float64(ml[py, px]) * np.float64(mr[py, pxr])
                            c = cov * a * b if kind == KIND_NCC else 2.0 * cov / (a + b)
                            c = quantise(min(max(c, -1.0), 1.0)) * STEP  # as stored
                        counters[COUNT_COMPUTED] += 1
                        if code + d_min <= scanned_hi[py, px]:
                            counters[COUNT_RESCANNED] += 1
                    if n < n_slots:
                        if n == 0:
                            buf[rec + BASE] = code - WIN_BELOW
                        off = code - buf[rec + BASE]
                        if off >= 0 and off < WIN:
                            s = rec + KEY + off
                        else:
                            blk = wide[(rec >> 1) + NEXT32]
                            if blk < 0 or buf[(n_px + blk) * REC + FILL] == SLOTS:  # a new newest block
                                base = (n_px + n_blocks) * REC
                                buf[base + FILL] = 0
                                wide[(base >> 1) + NEXT32] = blk
                                wide[(rec >> 1) + NEXT32] = n_blocks
                                blk = n_blocks
                                n_blocks += 1
                            base = (n_px + blk) * REC
                            j = np.int64(buf[base + FILL])  # an int16 index term overflows without the JIT
                            buf[base + FILL] = j + 1
                            buf[base + KEY + j] = code * 2
                            s = base + KEY + SLOTS + j
                        buf[s] = quantise(c)
                        flags[rec + FILL] += 1
                    else:
                        counters[COUNT_OVERFLOW] += 1
                if c > qc:
                    qc = c
                    qslot = s
                    qy = py
                    qx = px
                    qxr = pxr
            if qc < tau or qslot < 0:
                continue
            if qslot < n_words:  # a window slot: its flag is in the record's FILL word
                q_flags = qslot - (qslot & (REC - 1)) + FILL
                q_bit = 1 << (FLAG_SHIFT + (qslot & (REC - 1)) - KEY)
                if flags[q_flags] & q_bit:
                    continue
            elif buf[qslot - SLOTS] & 1:  # an overflow slot: its flag is bit 0 of its key
                continue
            rl = (qy * w + qx) * REC
            rr = (qy * w + qxr) * 2
            if greedy:
                if buf[rl + CNT_L] > 0 or right[rr] > 0:
                    continue
            else:
                if buf[rl + CNT_L] >= k_max or right[rr] >= k_max:
                    continue
                bl = buf[rl + BEST_L]
                br = right[rr + 1]
                ref = (max(bl, br) if use_max else min(bl, br)) * STEP
                if i >= n_seeds and qc + mu < ref:
                    continue
            if qslot < n_words:
                flags[q_flags] |= q_bit
            else:
                buf[qslot - SLOTS] |= 1
            t_int[n_t, 0] = qy
            t_int[n_t, 1] = qx
            t_int[n_t, 2] = qxr
            t_c[n_t] = qc
            b = min(max(int((qc - tau) * bucket_scale), 0), n_buckets - 1)
            t_int[n_t, 3] = bucket_head[b]
            bucket_head[b] = n_t
            if b > top:
                top = b
            n_t += 1
            qq = quantise(qc)
            buf[rl + BEST_L] = max(buf[rl + BEST_L], qq)
            right[rr + 1] = max(right[rr + 1], qq)
            buf[rl + CNT_L] += 1
            right[rr] += 1
    counters[COUNT_BLOCKS] = n_blocks
    return (t_int[:n_t, 0].copy(), t_int[:n_t, 1].copy(), t_int[:n_t, 2].copy(), t_c[:n_t].copy(),
            buf, counters)


@njit(cache=CACHE, nogil=True)
def _side_similarities(lp, rp, ml, nl, mr, nr, kind, buf, counters, scanned_hi, ys, xs, ds, d_min, d_max):
    """Similarities at ``d - 1`` and ``d + 1`` of matches ``(ys, xs, ds)``; NaN where out of range.

    Looked up in the memo; computed (and counted) when absent, without being stored.
    """
    n_pts = ys.shape[0]
    h, w = ml.shape
    n_px = h * w
    side = 2 * RADIUS + 1
    wide = buf.view(np.int32)
    out = np.full((2, n_pts), np.nan, np.float32)
    for i in range(n_pts):
        y = ys[i]
        x = xs[i]
        rec = (y * w + x) * REC
        for t in range(2):
            d = ds[i] - 1 + 2 * t
            xr = x - d
            if d < d_min or d > d_max or xr < 0 or xr >= w:
                continue
            code = d - d_min
            s = _value_index(buf, wide, rec, code, n_px)
            if s >= 0:
                out[t, i] = buf[s] * STEP
                continue
            a = nl[y, x]
            b = nr[y, xr]
            counters[COUNT_COMPUTED] += 1
            if d <= scanned_hi[y, x]:
                counters[COUNT_RESCANNED] += 1
            if a <= 0.0 or b <= 0.0:
                out[t, i] = UNDEFINED
                continue
            acc = 0.0  # one partial sum per window row: five short dependency chains
            for ii in range(side):
                row = 0.0
                for jj in range(side):
                    row += np.float64(lp[y + ii, x + jj]) * np.float64(rp[y + ii, xr + jj])
                acc += row
            cov = acc * (1.0 / (side * side)) - np.float64(ml[y, x]) * np.float64(mr[y, xr])
            c = cov * a * b if kind == KIND_NCC else 2.0 * cov / (a + b)
            out[t, i] = min(max(c, -1.0), 1.0)
    return out[0], out[1]
