"""Native band threads: every band of a pass runs once, on whichever thread takes it, with
its own dimension and trailing integers; helper threads take part at once, after they
slept and after a nap; a pass posted without waiting runs while the caller goes on and
is done before the next; closing stops them."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
import warp as wp

from warp_hybrid import band_pool
from warp_hybrid.band_pool import (
    BAND_COLUMNS,
    COL_CPU_NS,
    COL_SLOT,
    COL_WALL_NS,
    BandPool,
    PackedKernel,
    layout_matches,
)

pytestmark = pytest.mark.skipif(not layout_matches(), reason="no native band threads on this platform")


@wp.kernel
def _mark_rows(out: wp.array2d(dtype=wp.int32), mark: int, row0: int, row_step: int, cols: int):
    """Add ``mark`` to each pixel of row ``row0 + r * row_step``, columns up to ``cols``."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, out.shape[1])):
        out[y, x] = out[y, x] + mark


@wp.func_native(
    """
int* f = (int*)flags.data;
__atomic_store_n(&f[me], 1, __ATOMIC_SEQ_CST);
for (long long i = 0; i < 4000000000LL; ++i) {
    if (__atomic_load_n(&f[other], __ATOMIC_SEQ_CST)) return 1;
}
return 0;
"""
)
def _meet(flags: wp.array(dtype=wp.int32), me: int, other: int) -> int: ...


@wp.kernel
def _rendezvous(flags: wp.array(dtype=wp.int32), met: wp.array(dtype=wp.int32), me: int):
    """Raise this band's flag, then wait (a few seconds at most) for the other band's:
    ``met[me]`` is 1 when both bands ran at the same time."""
    met[me] = _meet(flags, me, 1 - me)


@wp.func_native(
    """
volatile int* f = (volatile int*)flag.data;
for (long long i = 0; i < 4000000000LL; ++i) {
    if (f[0] != 0) return 1;
}
return 0;
"""
)
def _await_flag(flag: wp.array(dtype=wp.int32)) -> int: ...


@wp.kernel
def _after_flag(flag: wp.array(dtype=wp.int32), seen: wp.array(dtype=wp.int32), band: int):
    """Wait (a few seconds at most) until the host raises ``flag``: ``seen[band]`` is 1
    when it did while this band ran."""
    seen[band] = _await_flag(flag)


@wp.kernel
def _double_rows(out: wp.array2d(dtype=wp.int32), row0: int, row_step: int, cols: int):
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, out.shape[1])):
        out[y, x] = 2 * out[y, x]


@wp.kernel
def _trailing_float(out: wp.array(dtype=wp.float32), scale: float):
    out[wp.tid()] = scale


def _bands(rows: list[tuple[int, int]], mark: int, width: int) -> np.ndarray:
    """The band table of ``_mark_rows`` over the (first, count) row spans."""
    table = np.zeros((len(rows), BAND_COLUMNS), dtype=np.int64)
    for k, (first, count) in enumerate(rows):
        table[k, :5] = (count, 1, first, 1, width)
    return table


def _blocks(kernel: wp.Kernel, inputs: list, tail: int, threads: int) -> list[PackedKernel]:
    block = PackedKernel.pack(kernel, wp.get_device("cpu"), inputs, tail)
    return [block, *(block.copy() for _ in range(1, threads))]


@pytest.mark.parametrize("threads", [2, 3])
def test_every_band_runs_once_with_its_own_dimension_and_integers(threads: int) -> None:
    """Bands of different sizes (one empty) each cover their own rows once; each row of
    the table gets the thread that ran it and, timed, its wall and CPU time."""
    height, width = 61, 7
    out = wp.zeros((height, width), dtype=wp.int32, device="cpu")
    wp.load_module(_mark_rows.module, device="cpu")
    spans = [(0, 1), (1, 20), (21, 0), (21, 3), *((24 + 4 * k, 4) for k in range(9)), (60, 1)]
    with BandPool(wp.get_device("cpu"), threads) as pool:
        for _ in range(3):  # the board is reused pass after pass
            table = _bands(spans, 1, width)
            assert pool.run([_blocks(_mark_rows, [out, 1], 3, threads)], table, timed=True) == len(spans)
            assert set(table[:, COL_SLOT]) <= set(range(threads))
            assert (table[:, COL_WALL_NS] >= 0).all() and (table[:, COL_CPU_NS] >= 0).all()
    np.testing.assert_array_equal(out.numpy(), np.full((height, width), 3, np.int32))


def _meet_in_one_pass(pool: BandPool) -> tuple[np.ndarray, np.ndarray]:
    """Run the two ``_rendezvous`` bands as one pass: (met, the slots that ran them)."""
    flags = wp.zeros(2, dtype=wp.int32, device="cpu")
    met = wp.zeros(2, dtype=wp.int32, device="cpu")
    wp.load_module(_rendezvous.module, device="cpu")
    table = np.zeros((2, BAND_COLUMNS), dtype=np.int64)
    table[:, :2] = 1
    table[:, 2] = (0, 1)
    assert pool.run([_blocks(_rendezvous, [flags, met], 1, pool.threads)], table) == 2
    return met.numpy(), table[:, COL_SLOT]


@pytest.mark.parametrize("spin_ns", [0, 60_000_000_000])
def test_a_helper_takes_part_whether_it_spun_or_slept(spin_ns: int) -> None:
    """Two bands that each wait for the other finish only if two threads run them at
    once: the helper takes one, when it is still spinning after the last pass and when
    it went to sleep at once (a posted pass wakes it)."""
    with BandPool(wp.get_device("cpu"), 2, spin_ns=spin_ns) as pool:
        for _ in range(3):
            met, slots = _meet_in_one_pass(pool)
            np.testing.assert_array_equal(met, [1, 1])
            assert sorted(slots) == [0, 1]
            time.sleep(0.02)


def test_a_nap_puts_the_helpers_to_sleep_and_a_pass_wakes_them() -> None:
    """With an hour to spin, helpers stay awake after a pass; told to nap, all of them
    sleep; the next pass still has them take part."""
    with BandPool(wp.get_device("cpu"), 3, spin_ns=3_600_000_000_000) as pool:
        _meet_in_one_pass(pool)
        time.sleep(0.05)
        assert pool.sleepers == 0
        pool.nap()
        deadline = time.monotonic() + 30.0
        while pool.sleepers < 2 and time.monotonic() < deadline:
            time.sleep(0.001)
        assert pool.sleepers == 2
        met, slots = _meet_in_one_pass(pool)
        np.testing.assert_array_equal(met, [1, 1])
        assert len(set(slots)) == 2


def test_a_wake_up_call_has_sleeping_helpers_spin_until_the_next_pass() -> None:
    """Helpers told to nap sleep; ``wake`` has every one of them up and spinning (with an
    hour to spin, none sleeps again) before any pass is posted; the next pass has them
    take part; a wake-up call where none sleeps changes nothing."""
    with BandPool(wp.get_device("cpu"), 3, spin_ns=3_600_000_000_000) as pool:
        _meet_in_one_pass(pool)
        pool.nap()
        deadline = time.monotonic() + 30.0
        while pool.sleepers < 2 and time.monotonic() < deadline:
            time.sleep(0.001)
        assert pool.sleepers == 2
        pool.wake()
        deadline = time.monotonic() + 30.0
        while pool.sleepers > 0 and time.monotonic() < deadline:
            time.sleep(0.001)
        assert pool.sleepers == 0
        pool.wake()
        time.sleep(0.05)
        assert pool.sleepers == 0
        met, slots = _meet_in_one_pass(pool)
        np.testing.assert_array_equal(met, [1, 1])
        assert len(set(slots)) == 2


def test_a_pass_posted_without_waiting_runs_while_the_caller_goes_on() -> None:
    """Posted without waiting, a pass's band waits for a flag the caller raises only after
    ``run`` returned (had ``run`` waited, the band would have given up first): it is in
    flight until ``join``, which waits for it (the seconds it waited back) and leaves its
    band timed."""
    flag = wp.zeros(1, dtype=wp.int32, device="cpu")
    seen = wp.zeros(1, dtype=wp.int32, device="cpu")
    wp.load_module(_after_flag.module, device="cpu")
    table = np.zeros((1, BAND_COLUMNS), dtype=np.int64)
    table[0, :3] = (1, 1, 0)
    with BandPool(wp.get_device("cpu"), 2) as pool:
        assert pool.join() == 0.0 and not pool.in_flight
        assert pool.run([_blocks(_after_flag, [flag, seen], 1, 2)], table, timed=True, wait=False) == 1
        assert pool.in_flight
        flag.numpy()[0] = 1
        assert pool.join() >= 0.0
        assert not pool.in_flight
        assert seen.numpy()[0] == 1
        assert table[0, COL_WALL_NS] > 0


@pytest.mark.parametrize("threads", [2, 3])
def test_the_next_pass_starts_after_the_one_in_flight(threads: int) -> None:
    """A pass that doubles what the pass before it, posted without waiting, wrote sees
    all of it, whether it is waited for or posted without waiting too (the pass in flight
    finished natively right before it is posted); closing finishes the pass in flight."""
    height, width = 97, 5
    out = wp.zeros((height, width), dtype=wp.int32, device="cpu")
    wp.load_module(_mark_rows.module, device="cpu")
    spans = [(4 * k, 4) for k in range(24)] + [(96, 1)]
    double = np.zeros((len(spans), BAND_COLUMNS), dtype=np.int64)
    double[:, :5] = _bands(spans, 0, width)[:, :5]
    pool = BandPool(wp.get_device("cpu"), threads)
    for k in range(3):
        pool.run([_blocks(_mark_rows, [out, 1], 3, threads)], _bands(spans, 1, width), wait=False)
        pool.run([_blocks(_double_rows, [out], 3, threads)], double, wait=k == 1)
        assert pool.in_flight == (k != 1) and pool.finished_s >= 0.0
    pool.run([_blocks(_mark_rows, [out, 1], 3, threads)], _bands(spans, 1, width), wait=False)
    pool.close()
    np.testing.assert_array_equal(out.numpy(), np.full((height, width), 15, np.int32))  # ((1*2+1)*2+1)*2+1


def test_a_pass_with_a_deadline_is_always_waited_for() -> None:
    with BandPool(wp.get_device("cpu"), 2) as pool:
        out = wp.zeros((1, 1), dtype=wp.int32, device="cpu")
        wp.load_module(_mark_rows.module, device="cpu")
        with pytest.raises(ValueError, match="deadline"):
            pool.run([_blocks(_mark_rows, [out, 1], 3, 2)], _bands([(0, 1)], 1, 1), deadline_ns=0, wait=False)


def test_closing_stops_the_helpers() -> None:
    def helpers() -> set[threading.Thread]:
        return {t for t in threading.enumerate() if t.name.startswith("warp-hybrid-band-")}

    before = helpers()
    pool = BandPool(wp.get_device("cpu"), 3)
    started = helpers() - before
    assert len(started) == 2
    pool.close()
    pool.close()  # idempotent
    assert not any(t.is_alive() for t in started)


def test_a_trailing_input_must_be_int32() -> None:
    out = wp.zeros(4, dtype=wp.float32, device="cpu")
    wp.load_module(_trailing_float.module, device="cpu")
    with pytest.raises(TypeError, match="scale is c_float, not int32"):
        PackedKernel.pack(_trailing_float, wp.get_device("cpu"), [out], 1)


def test_the_board_holds_bands_up_to_its_limit() -> None:
    with BandPool(wp.get_device("cpu"), 2) as pool:
        with pytest.raises(ValueError, match="bands"):
            pool.run([[]], np.zeros((band_pool.MAX_BANDS + 1, BAND_COLUMNS), dtype=np.int64))
        with pytest.raises(ValueError, match="threads"):
            BandPool(wp.get_device("cpu"), band_pool.MAX_THREADS + 1)


def test_a_pool_collected_without_closing_stops_its_helpers() -> None:
    import gc

    before = {t for t in threading.enumerate() if t.name.startswith("warp-hybrid-band-")}
    pool = BandPool(wp.get_device("cpu"), 2)
    started = {t for t in threading.enumerate() if t.name.startswith("warp-hybrid-band-")} - before
    assert len(started) == 1
    del pool
    gc.collect()
    assert not any(t.is_alive() for t in started)


def test_the_probe_pass_passes_here_and_a_failed_probe_falls_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """The probe pass writes what ``wp.launch`` would on this Warp; where it would not, the
    launcher gets no native band threads, with a warning, and its passes still run."""
    with BandPool(wp.get_device("cpu"), 2) as pool:
        assert band_pool.probe_pool(pool)
    monkeypatch.setattr(band_pool, "probe_pool", lambda pool: False)
    with pytest.warns(RuntimeWarning, match="native band threads disabled"):
        assert band_pool.native_band_pool(wp.get_device("cpu"), 2) is None
