"""The launch layer covers every pixel/item exactly once, whatever the thread count, and
shares the bands of a pass among its threads by who is free."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
import warp as wp

from warp_hybrid import band_pool, parallel
from warp_hybrid.parallel import (
    BANDS_PER_THREAD,
    FEW_BANDS_PER_THREAD,
    GUIDED_SHARE,
    ITEM_GROUP,
    KEPT_TABLES,
    BandLaunch,
    CostBands,
    Launcher,
    StagedBand,
    band,
    band_count,
    default_thread_count,
    group_launch,
    guided_bands,
    item_group,
)
from warp_hybrid.timing import StageTimer


@pytest.fixture(params=["native", "python"])
def band_threads(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Which threads run a CPU pass's bands: the native band threads (``band_pool``), or
    the Python pool (as on a platform without them)."""
    if request.param == "python":
        monkeypatch.setattr(parallel, "native_band_pool", lambda device, threads: None)
    elif not band_pool.layout_matches():
        pytest.skip("no native band threads on this platform")
    return request.param


@wp.kernel
def _count_pixels(
    out: wp.array2d(dtype=wp.int32), item_cols: wp.array2d(dtype=wp.int32), row0: int, row_step: int, cols: int
):
    """Count the visits of each pixel; record the ``cols`` of the item that visited it."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, out.shape[1])):
        out[y, x] = out[y, x] + 1
        item_cols[y, x] = cols


@wp.kernel
def _count_items(out: wp.array(dtype=wp.int32), start: int, step: int):
    i = start + wp.tid() * step
    out[i] = out[i] + 1


@pytest.mark.parametrize("per_thread", [BANDS_PER_THREAD, FEW_BANDS_PER_THREAD])
@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize(("height", "width"), [(1, 1), (2, 5), (7, 3), (48, 33), (481, 2)])
def test_launch_pixels_covers_each_pixel_once(
    device: str, band_threads: str, threads: int, height: int, width: int, per_thread: int
) -> None:
    out = wp.zeros((height, width), dtype=wp.int32, device=device)
    item_cols = wp.zeros((height, width), dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_pixels(_count_pixels, height, width, [out, item_cols], bands_per_thread=per_thread)
    np.testing.assert_array_equal(out.numpy(), np.ones((height, width), np.int32))
    # the device's shape: a whole row per launch item on the CPU, one pixel on CUDA
    expected_cols = 1 if wp.get_device(device).is_cuda else width
    np.testing.assert_array_equal(item_cols.numpy(), np.full((height, width), expected_cols, np.int32))


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("rows", [(0, 48), (5, 6), (17, 40), (-3, 9), (30, 99), (20, 20)])
def test_launch_pixels_covers_only_the_rows_asked(
    device: str, band_threads: str, threads: int, rows: tuple[int, int]
) -> None:
    height, width = 48, 9
    out = wp.zeros((height, width), dtype=wp.int32, device=device)
    item_cols = wp.zeros((height, width), dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_pixels(_count_pixels, height, width, [out, item_cols], rows=rows)
    expected = np.zeros((height, width), np.int32)
    expected[max(rows[0], 0) : min(rows[1], height)] = 1
    np.testing.assert_array_equal(out.numpy(), expected)


def test_passes_on_one_launcher_cover_what_each_asks(device: str, band_threads: str) -> None:
    """One launcher runs many passes in a row, as a renderer's frames do: pixel passes over
    more shapes of rows than it keeps band tables for (``KEPT_TABLES``), the same shapes
    again (their kept tables), timed passes between them (tables of their own, whose
    times come back); each pass covers exactly the rows it asks for, once."""
    height, width = 40, 7
    out = wp.zeros((height, width), dtype=wp.int32, device=device)
    item_cols = wp.zeros((height, width), dtype=wp.int32, device=device)
    marks = wp.zeros(1000, dtype=wp.int32, device=device)
    shapes = [(first, first + size) for size in (1, 5, 13) for first in range(0, height - size, 1)]
    assert len(shapes) > KEPT_TABLES
    with Launcher(device, 2) as launcher:
        for sweep in range(2):
            for k, rows in enumerate(shapes):
                out.zero_()
                launcher.launch_pixels(_count_pixels, height, width, [out, item_cols], rows=rows)
                expected = np.zeros((height, width), np.int32)
                expected[rows[0] : rows[1]] = 1
                np.testing.assert_array_equal(out.numpy(), expected, err_msg=f"sweep {sweep}, rows {rows}")
                if k % 7 == 0 and not wp.get_device(device).is_cuda:
                    times = launcher.launch_bands(
                        _count_items, [marks], [(250, (0, 1)), (250, (250, 1)), (500, (500, 1))], timed=True
                    )
                    assert len(times) == 3 and all(t >= 0.0 for t in times)
    if not wp.get_device(device).is_cuda:
        assert (marks.numpy() == marks.numpy()[0]).all() and marks.numpy()[0] > 0


def test_launch_pixels_skips_empty_images(device: str) -> None:
    out = wp.zeros((1, 1), dtype=wp.int32, device=device)
    with Launcher(device, 2) as launcher:
        launcher.launch_pixels(_count_pixels, 0, 1, [out, out])
        launcher.launch_pixels(_count_pixels, 1, 0, [out, out])
    assert out.numpy()[0, 0] == 0


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("count", [1, 5, 100, 9001])
def test_launch_items_covers_each_item_once(device: str, band_threads: str, threads: int, count: int) -> None:
    out = wp.zeros(count, dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_items(_count_items, count, [out])
    np.testing.assert_array_equal(out.numpy(), np.ones(count, np.int32))


@wp.kernel
def _count_grouped_items(
    out: wp.array(dtype=wp.int32), launch_item: wp.array(dtype=wp.int32), start: int, stop: int, group: int
):
    """Count the visits of each item; record which launch item (band start + tid) visited it."""
    first = start + wp.tid() * group
    for i in range(first, wp.min(first + group, stop)):
        out[i] = out[i] + 1
        launch_item[i] = first


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("count", [1, 15, 16, 17, 100, 9001])
def test_launch_groups_covers_each_item_once_in_groups(
    device: str, band_threads: str, threads: int, count: int
) -> None:
    """Every item once; on the CPU consecutive items share a launch item, at most
    ``ITEM_GROUP`` of them (a band's last group may be short), on CUDA one each."""
    out = wp.zeros(count, dtype=wp.int32, device=device)
    launch_item = wp.full(count, -1, dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_groups(_count_grouped_items, count, [out, launch_item])
    np.testing.assert_array_equal(out.numpy(), np.ones(count, np.int32))
    firsts = launch_item.numpy()
    group = item_group(wp.get_device(device))
    assert group == (1 if wp.get_device(device).is_cuda else ITEM_GROUP)
    sizes = np.bincount(firsts)[np.unique(firsts)]
    assert sizes.max() <= group
    assert np.all(np.diff(firsts) >= 0)  # each group is a run of consecutive items
    if group > 1 and count >= group * threads * BANDS_PER_THREAD:
        assert np.median(sizes) == group  # most launch items take a whole group


@wp.kernel
def _count_into_slots(
    sums: wp.array(dtype=wp.int32),
    item_slot: wp.array(dtype=wp.int32),
    slot: int,
    start: int,
    stop: int,
    group: int,
):
    """Add each item into its thread's slot; record which slot counted it."""
    first = start + wp.tid() * group
    for i in range(first, wp.min(first + group, stop)):
        wp.atomic_add(sums, slot, 1)
        item_slot[i] = item_slot[i] + slot + 1


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("count", [1, 17, 9001, 200_000])
def test_launch_slots_counts_each_item_once_into_a_thread_slot(
    device: str, band_threads: str, threads: int, count: int
) -> None:
    """Every item lands once, in one slot of the threads' (slot 0 alone on CUDA), and
    the slots add up to the items."""
    sums = wp.zeros(threads, dtype=wp.int32, device=device)
    item_slot = wp.zeros(count, dtype=wp.int32, device=device)
    with Launcher(device, threads) as launcher:
        launcher.launch_slots(_count_into_slots, count, [sums, item_slot], min_band_items=16)
    slots = item_slot.numpy() - 1
    assert slots.min() >= 0 and slots.max() < threads  # each item counted once, by a real slot
    if wp.get_device(device).is_cuda:
        assert (slots == 0).all()
    np.testing.assert_array_equal(sums.numpy(), np.bincount(slots, minlength=threads))
    assert int(sums.numpy().sum()) == count


@pytest.mark.parametrize(("first", "items", "group"), [(0, 1, 16), (7, 16, 16), (7, 17, 16), (100, 33, 4), (3, 5, 1)])
def test_group_launch_covers_the_band_and_no_more(first: int, items: int, group: int) -> None:
    dim, (start, stop, g) = group_launch(first, items, group)
    assert (start, stop, g) == (first, first + items, group)
    covered = [i for tid in range(dim) for i in range(start + tid * g, min(start + (tid + 1) * g, stop))]
    assert covered == list(range(first, first + items))
    assert (dim - 1) * group < items  # no launch item without an item


@wp.kernel
def _mark_items(out: wp.array(dtype=wp.int32), mark: int, start: int, step: int):
    out[start + wp.tid() * step] = mark


def _counting_launches(monkeypatch: pytest.MonkeyPatch, kernel: wp.Kernel) -> list[bool]:
    """Make every ``wp.launch`` call of ``kernel`` append whether it only recorded the launch."""
    calls: list[bool] = []
    real = wp.launch

    def launch(*args, **kwargs):
        if (args[0] if args else kwargs["kernel"]) is kernel:
            calls.append(bool(kwargs.get("record_cmd", False)))
        return real(*args, **kwargs)

    monkeypatch.setattr(wp, "launch", launch)
    return calls


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_a_pass_packs_its_arguments_once_per_thread(
    device: str, band_threads: str, threads: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bands of a pass reuse one recorded launch per thread: each band runs with its
    own start and size (every item once), and the arguments are packed by as many
    ``wp.launch`` calls as threads took bands, however many bands there are."""
    count = 9001
    out = wp.zeros(count, dtype=wp.int32, device=device)
    calls = _counting_launches(monkeypatch, _count_items)
    with Launcher(device, threads) as launcher:
        launcher.launch_items(_count_items, count, [out])
    np.testing.assert_array_equal(out.numpy(), np.ones(count, np.int32))
    is_cuda = wp.get_device(device).is_cuda
    assert 1 <= len(calls) <= (1 if is_cuda else threads)
    assert all(calls) != is_cuda  # the CPU's bands record; CUDA's one launch does not


@wp.struct
class _Marks:
    out: wp.array(dtype=wp.int32)
    mark: wp.vec2i


@wp.kernel
def _mark_through_struct(marks: _Marks, scale: int, start: int, step: int):
    marks.out[start + wp.tid() * step] = marks.mark[0] * scale + marks.mark[1]


def test_a_kernel_is_packed_again_only_when_its_inputs_change(monkeypatch: pytest.MonkeyPatch) -> None:
    """On the native band threads a pass given what the pass before gave the same kernel
    reuses its packed blocks; a struct's field changed in place, another array in it or
    another number packs again, and every pass marks what its inputs say."""
    if not band_pool.layout_matches():
        pytest.skip("no native band threads on this platform")
    count = 3000
    calls = _counting_launches(monkeypatch, _mark_through_struct)
    a = wp.zeros(count, dtype=wp.int32, device="cpu")
    b = wp.zeros(count, dtype=wp.int32, device="cpu")
    marks = _Marks()
    marks.out = a
    marks.mark = wp.vec2i(1, 0)
    with Launcher("cpu", 2) as launcher:
        assert launcher.native_bands

        def run(scale: int, expect: wp.array, value: int, packed: bool) -> None:
            before = len(calls)
            launcher.launch_items(_mark_through_struct, count, [marks, scale])
            assert (len(calls) > before) == packed
            np.testing.assert_array_equal(expect.numpy(), np.full(count, value, np.int32))

        run(1, a, 1, True)
        run(1, a, 1, False)  # the same inputs: the blocks as they were
        marks.mark = wp.vec2i(2, 0)  # a field changed in place
        run(1, a, 2, True)
        run(3, a, 6, True)  # another number
        marks.out = b  # another array in the struct
        run(3, b, 6, True)
        run(3, b, 6, False)
        marks.mark = wp.vec2i(2, 5)  # a nested value (the vector's second lane)
        run(3, b, 11, True)


def test_band_launch_takes_each_threads_own_inputs(device: str) -> None:
    """Inputs given per thread slot reach the bands that thread runs, and only those;
    a second pass over another array packs its own arguments (nothing from the first)."""
    count, bands = 4000, 16
    with Launcher(device, 2) as launcher:
        for out in (wp.zeros(count, dtype=wp.int32, device=device), wp.zeros(count, dtype=wp.int32, device=device)):
            run = BandLaunch(launcher, _mark_items, lambda slot, out=out: [out, slot + 1])
            ran: dict[int, int] = {}

            def job(k: int, slot: int, run: BandLaunch = run, ran: dict[int, int] = ran) -> None:
                first, items = band(k, bands, count)
                ran[k] = slot
                run(slot, items, (first, 1), k == 0)

            launcher.share_until(job, bands)
            marks = out.numpy()
            for k, slot in ran.items():
                first, items = band(k, bands, count)
                np.testing.assert_array_equal(marks[first : first + items], slot + 1)
            assert sorted(ran) == list(range(bands))


def _tile(spans: list[tuple[int, int]], total: int) -> None:
    """``spans`` are contiguous, in order, none empty, and cover 0..total-1 once."""
    assert spans[0][0] == 0 and all(n > 0 for _, n in spans)
    assert all(a[0] + a[1] == b[0] for a, b in zip(spans, spans[1:], strict=False))
    assert spans[-1][0] + spans[-1][1] == total


@pytest.mark.parametrize(("total", "bands"), [(1, 1), (7, 3), (480, 16), (481, 16), (5, 5)])
def test_bands_tile_the_range_in_order(total: int, bands: int) -> None:
    """Bands are contiguous, in order, cover 0..total-1 once and differ by at most one."""
    parts = [band(k, bands, total) for k in range(bands)]
    _tile(parts, total)
    assert max(n for _, n in parts) - min(n for _, n in parts) <= 1


def test_band_count_follows_the_threads_and_the_minimum_band() -> None:
    assert band_count(480, 1, 4) == 1  # one thread: one launch
    assert band_count(480, 2, 4) == 2 * BANDS_PER_THREAD
    assert band_count(20, 2, 4) == 5  # no band under 4 rows
    assert band_count(5, 2, 4) == 2  # but at least one band per thread
    assert band_count(1, 3, 4) == 1  # and never more bands than rows
    assert band_count(100, 2, 256) == 2
    assert band_count(480, 2, 4, per_thread=2) == 4  # a short pass of even rows: fewer launches
    assert band_count(6, 2, 4, per_thread=2) == 2


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("stop_at", [0, 1, 7, 40, None])
def test_share_until_runs_a_prefix_and_asks_in_band_order(threads: int, stop_at: int | None) -> None:
    """``proceed`` is asked band by band in order; every band before the first refusal
    runs exactly once, none after it, and the count returned is that prefix's length."""
    bands = 40
    ran: list[int] = []
    asked: list[int] = []
    lock = threading.Lock()

    def job(k: int, slot: int) -> None:
        assert 0 <= slot < threads
        with lock:
            ran.append(k)

    def proceed(k: int) -> bool:
        asked.append(k)  # called under the launcher's lock
        return stop_at is None or k < stop_at

    with Launcher("cpu", threads) as launcher:
        n = launcher.share_until(job, bands, proceed)
    expected = bands if stop_at is None else min(stop_at, bands)
    assert n == expected
    assert sorted(ran) == list(range(expected))
    assert asked == list(range(expected + (0 if stop_at is None or stop_at >= bands else 1)))


def test_a_free_thread_takes_the_bands_a_busy_one_cannot() -> None:
    """Thread 0's first band blocks until thread 1 has run every other band: thread 0
    runs at most that one band, and every band runs once."""
    bands = 16
    ran: list[tuple[int, int]] = []
    lock = threading.Lock()
    others_done = threading.Event()

    def launch_band(k: int, slot: int) -> None:
        if slot == 0:
            assert others_done.wait(timeout=30.0)
        with lock:
            ran.append((k, slot))
            if slot == 1 and len(ran) >= bands - 1:  # all but the band thread 0 holds, if any
                others_done.set()

    with Launcher("cpu", 2) as launcher:
        launcher.share_until(launch_band, bands)
    assert sorted(k for k, _ in ran) == list(range(bands))
    assert sum(1 for _, slot in ran if slot == 0) <= 1


def test_share_until_propagates_a_bands_exception(device: str) -> None:
    """A band's exception reaches the caller; the launcher serves the next pass."""

    def job(k: int, slot: int) -> None:
        if k == 1:
            raise ValueError("band 1 failed")

    with Launcher(device, 2) as launcher:
        with pytest.raises(ValueError, match="band 1 failed"):
            launcher.share_until(job, 4)
        assert launcher.share_until(lambda k, slot: None, 4) == 4


def test_share_until_runs_slot_zero_on_the_calling_thread() -> None:
    """Slot 0 is the caller's thread and the others the pool's; when a band on the caller
    fails, the other threads still run every band they take before the error reaches the
    caller."""
    ran: dict[int, list[int]] = {0: [], 1: [], 2: []}
    threads: dict[int, set[threading.Thread]] = {0: set(), 1: set(), 2: set()}
    lock = threading.Lock()
    caller_in, others_done = threading.Event(), threading.Event()

    def job(k: int, slot: int) -> None:
        with lock:
            threads[slot].add(threading.current_thread())
        if slot == 0:
            caller_in.set()
            assert others_done.wait(timeout=30.0)  # let the pool take the rest first
            raise ValueError("caller's band failed")
        assert caller_in.wait(timeout=30.0)  # the caller holds a band before the pool goes on
        with lock:
            ran[slot].append(k)
            if sum(len(v) for v in ran.values()) >= 15:  # all but the band the caller holds
                others_done.set()

    with Launcher("cpu", 3) as launcher, pytest.raises(ValueError, match="caller's band failed"):
        launcher.share_until(job, 16)
    assert threads[0] == {threading.main_thread()}
    assert threading.main_thread() not in threads[1] | threads[2]
    assert len(ran[1]) + len(ran[2]) == 15


def test_a_launch_profile_times_every_piece_by_kernel(device: str, band_threads: str) -> None:
    """Attached, the profile counts each launch once and times each of its pieces (its
    bands, by the thread that ran them) under the kernel's name; detached, it records
    nothing more."""
    from warp_hybrid.launch_profile import LaunchProfile

    out = wp.zeros((64, 32), dtype=wp.int32, device=device)
    cols = wp.zeros((64, 32), dtype=wp.int32, device=device)
    items = wp.zeros(100, dtype=wp.int32, device=device)

    with Launcher(device, 2) as launcher:
        profile = LaunchProfile()
        launcher.profile = profile
        for _ in range(3):
            launcher.launch_pixels(_count_pixels, 64, 32, [out, cols])
        launcher.launch_items(_count_items, 100, [items])
        launcher.profile = None
        launcher.launch_items(_count_items, 100, [items])
    slots = {0} if wp.get_device(device).is_cuda else {0, 1}
    pixels, listed = profile.kernels[_count_pixels.key], profile.kernels[_count_items.key]
    assert (pixels.launches, listed.launches) == (3, 1)
    # bands go to whichever thread is free, so either thread may have run them all
    assert set(pixels.piece_ms) <= slots and set(listed.piece_ms) <= slots
    assert pixels.ms > 0.0 and pixels.cpu_ms >= 0.0 and 0.0 < pixels.balance <= 1.0
    rows = profile.rows(frames=1)
    assert [r["kernel"] for r in rows] == sorted(
        profile.kernels, key=lambda n: -max(profile.kernels[n].piece_ms.values())
    )
    assert all(r["cpu_ms"] >= 0.0 for r in rows)
    np.testing.assert_array_equal(items.numpy(), np.full(100, 2, np.int32))


def test_cost_bands_start_equal_then_cut_at_equal_measured_cost() -> None:
    """Before any measurement the bands are ``band``'s; after one, each band of the next
    pass holds the same measured cost to within one item's."""
    bands = CostBands()
    total, count = 4096, 16
    first = bands.spans(total, count)
    assert first == [band(k, count, total) for k in range(count)]
    # the staircase's shape: the first sixteenth costs 8x, the rest little
    item_cost = np.where(np.arange(total) < total // 16, 8.0, 0.1)
    bands.measured(first, [item_cost[a : a + n].sum() for a, n in first])
    second = bands.spans(total, count)
    _tile(second, total)
    costs = np.array([item_cost[a : a + n].sum() for a, n in second])
    assert costs.max() - costs.min() <= item_cost.max() + 1e-9
    assert second[0][1] < total // 64  # narrow where the cost is
    # measured again at equal costs, the bands stay where they are
    bands.measured(second, costs)
    assert bands.spans(total, count) == second


@pytest.mark.parametrize(("total", "count"), [(1, 4), (5, 5), (6, 5), (100, 16), (4105, 16)])
def test_cost_bands_never_leave_a_band_empty(total: int, count: int) -> None:
    """However the cost piles up (all on the first item, all on the last, some zero),
    every band holds at least one item and they tile the range; more bands than items
    give one item a band."""
    for weights in ([1.0] + [0.0] * (total - 1), [0.0] * (total - 1) + [1.0], [0.0] * total):
        bands = CostBands()
        spans = bands.spans(total, count)
        bands.measured(spans, [sum(weights[a : a + n]) for a, n in spans])
        spans = bands.spans(total, count)
        _tile(spans, total)
        assert len(spans) == min(total, count)


def test_cost_bands_start_again_for_another_range() -> None:
    """A measurement over one length says nothing about another: equal bands again."""
    bands = CostBands()
    spans = bands.spans(100, 4)
    bands.measured(spans, [9.0, 1.0, 1.0, 1.0])
    assert bands.spans(100, 4) != spans
    assert bands.spans(120, 4) == [band(k, 4, 120) for k in range(4)]


def test_launch_bands_runs_each_band_once_and_times_it(band_threads: str) -> None:
    """The bands of one pass, each over its own items (sizes differing, one empty), run
    once each; timed, each band's thread CPU seconds come back in band order."""
    count = 5000
    out = wp.zeros(count, dtype=wp.int32, device="cpu")
    spans = [(0, 1), (1, 0), (1, 999), (1000, 4000)]
    with Launcher("cpu", 2) as launcher:
        costs = launcher.launch_bands(_count_items, [out], [(items, (first, 1)) for first, items in spans], timed=True)
        assert launcher.launch_bands(_count_items, [out], [(count, (0, 1))]) is None
    np.testing.assert_array_equal(out.numpy(), np.full(count, 2, np.int32))
    assert costs is not None and len(costs) == len(spans)
    assert all(c >= 0.0 for c in costs) and costs[3] > 0.0


@wp.kernel
def _double_marks(src: wp.array(dtype=wp.int32), dst: wp.array(dtype=wp.int32), start: int, step: int):
    i = start + wp.tid() * step
    dst[i] = 2 * src[i]


def _staged_bands(count: int, bands: int, must: int) -> list[StagedBand]:
    """``bands`` bands over ``count`` items, each marking its items then doubling the
    marks; the first ``must`` run whatever the deadline."""
    out = []
    for k in range(bands):
        first, items = band(k, bands, count)
        out.append(StagedBand(((items, (first, 1)), (items, (first, 1))), items, must=k < must))
    return out


def test_launch_staged_runs_a_bands_stages_in_order(band_threads: str) -> None:
    """Each band runs its first stage, then its second over what the first wrote (the
    stages of a band run on one thread in order); every band runs, with each stage's
    time and the thread that ran it."""
    count, bands = 3000, 12
    src = wp.zeros(count, dtype=wp.int32, device="cpu")
    dst = wp.zeros(count, dtype=wp.int32, device="cpu")
    with Launcher("cpu", 2) as launcher:
        run = launcher.launch_staged(
            [(_count_items, [src]), (_double_marks, [src, dst])], _staged_bands(count, bands, 0), cpu=True
        )
    np.testing.assert_array_equal(dst.numpy(), np.full(count, 2, np.int32))
    assert run.ran == bands and set(run.slots) <= {0, 1} and len(run.slots) == bands
    assert run.seconds.shape == run.cpu_seconds.shape == (bands, 2)
    assert (run.seconds >= 0.0).all() and (run.cpu_seconds >= 0.0).all()


@pytest.mark.parametrize("deadline", [float("-inf"), -1.0, float("nan")])
def test_a_passed_deadline_runs_only_the_bands_that_must(band_threads: str, deadline: float) -> None:
    """With the deadline behind the clock (or one no time ends by), the bands marked
    ``must`` run and the pass stops at the first other band: a prefix, nothing after it."""
    count, bands, must = 3000, 12, 3
    src = wp.zeros(count, dtype=wp.int32, device="cpu")
    dst = wp.zeros(count, dtype=wp.int32, device="cpu")
    timer = StageTimer()
    with Launcher("cpu", 2) as launcher:
        run = launcher.launch_staged(
            [(_count_items, [src]), (_double_marks, [src, dst])],
            _staged_bands(count, bands, must),
            timer,
            timer.now() + deadline if deadline == -1.0 else deadline,
        )
    assert run.ran == must
    end = band(must - 1, bands, count)[0] + band(must - 1, bands, count)[1]
    expected = np.zeros(count, np.int32)
    expected[:end] = 2
    np.testing.assert_array_equal(dst.numpy(), expected)


def test_a_deadline_far_ahead_runs_every_band(band_threads: str) -> None:
    count, bands = 3000, 12
    src = wp.zeros(count, dtype=wp.int32, device="cpu")
    dst = wp.zeros(count, dtype=wp.int32, device="cpu")
    timer = StageTimer()
    for deadline in (timer.now() + 3600.0, float("inf")):
        with Launcher("cpu", 2) as launcher:
            run = launcher.launch_staged(
                [(_count_items, [src]), (_double_marks, [src, dst])], _staged_bands(count, bands, 1), timer, deadline
            )
        assert run.ran == bands
    np.testing.assert_array_equal(src.numpy(), np.full(count, 2, np.int32))


def test_an_injected_clock_decides_the_deadline_on_the_python_threads() -> None:
    """A timer on another clock than ``perf_clock`` (a test's fake clock) is asked once
    before each band that need not run, in band order (the bands' own times are the real
    clock's): it reads 0 for the first two such bands, then far past the deadline."""
    count, bands = 3000, 12
    src = wp.zeros(count, dtype=wp.int32, device="cpu")
    ticks: list[int] = []

    def clock() -> float:
        ticks.append(1)
        return 0.0 if len(ticks) <= 2 else 1.0e9

    with Launcher("cpu", 1) as launcher:
        run = launcher.launch_staged(
            [(_count_items, [src]), (_count_items, [src])],
            _staged_bands(count, bands, 1),
            StageTimer(clock=clock),
            10.0,
        )
    assert run.ran == 3 and len(ticks) == 3  # band 0 must run; bands 1, 2 fit; band 3 does not
    assert src.numpy()[: band(2, bands, count)[0] + band(2, bands, count)[1]].min() == 2
    # on two threads too: a clock stopped at 0 never passes a deadline 10 s after it (the
    # monotonic clock, seconds since boot, would)
    with Launcher("cpu", 2) as launcher:
        run = launcher.launch_staged(
            [(_count_items, [src]), (_count_items, [src])],
            _staged_bands(count, bands, 1),
            StageTimer(clock=lambda: 0.0),
            10.0,
        )
    assert run.ran == bands


def test_default_threads_follow_the_cpus_this_process_may_run_on(monkeypatch: pytest.MonkeyPatch) -> None:
    """One thread a CPU of the process's affinity (not the machine's count), at most 8;
    ``WARP_HYBRID_THREADS`` overrides it."""
    cpu = wp.get_device("cpu")
    monkeypatch.delenv("WARP_HYBRID_THREADS", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {5}, raising=False)
    assert default_thread_count(cpu) == 1
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(3)), raising=False)
    assert default_thread_count(cpu) == 3
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(64)), raising=False)
    assert default_thread_count(cpu) == 8
    monkeypatch.setenv("WARP_HYBRID_THREADS", "2")
    assert default_thread_count(cpu) == 2


def test_native_bands_switch_off_and_on() -> None:
    """A launcher with native band threads runs its passes on the Python pool while they
    are switched off, and on them again after (every pixel once each time); one without
    them refuses to switch on."""
    height, width = 48, 9
    out = wp.zeros((height, width), dtype=wp.int32, device="cpu")
    cols = wp.zeros((height, width), dtype=wp.int32, device="cpu")
    with Launcher("cpu", 2) as launcher:
        assert launcher.native_bands == band_pool.layout_matches()
        if launcher.native_bands:
            for on in (False, True):
                launcher.native_bands = on
                assert launcher.native_bands == on
                launcher.launch_pixels(_count_pixels, height, width, [out, cols])
            np.testing.assert_array_equal(out.numpy(), np.full((height, width), 2, np.int32))
    with Launcher("cpu", 1) as one, pytest.raises(ValueError, match="no native band threads"):
        one.native_bands = True


@pytest.mark.parametrize("threads", [1, 2, 3, 8])
@pytest.mark.parametrize("total", [0, 1, 3, 4, 9, 480, 481, 1080])
def test_guided_bands_tile_the_range_and_shrink(threads: int, total: int) -> None:
    """Guided bands cover 0..total-1 once, in order; each takes 1 / (GUIDED_SHARE *
    threads) of the rows left (none under the minimum but the last), so they never grow."""
    parts = guided_bands(total, threads, 4)
    if total == 0:
        assert parts == []
        return
    _tile(parts, total)
    if threads == 1:
        assert parts == [(0, total)]
        return
    sizes = [n for _, n in parts]
    assert all(a >= b for a, b in zip(sizes, sizes[1:]))
    for first, n in parts[:-1]:
        left = total - first
        assert n == max(4, -(-left // (GUIDED_SHARE * threads)))


def test_guided_bands_of_a_frame() -> None:
    """480 rows on two threads: a quarter of the rows first, four-row bands at the end."""
    sizes = [n for _, n in guided_bands(480, 2, 4)]
    assert sizes == [120, 90, 68, 51, 38, 29, 21, 16, 12, 9, 7, 5, 4, 4, 4, 2]


@wp.kernel
def _double_items(out: wp.array(dtype=wp.int32), start: int, step: int):
    i = start + wp.tid() * step
    out[i] = 2 * out[i]


def test_overlapping_passes_run_on_past_their_call_and_in_order(band_threads: str) -> None:
    """Within ``overlapping`` a pass runs on past its call on the native band threads (in
    flight until the next call joins it), and every pass still sees all of the one before;
    the block's end joins the last; ``paused`` runs a pass to its end; the stages add up."""
    count = 20000
    out = wp.zeros(count, dtype=wp.int32, device="cpu")
    timer = StageTimer()
    native = band_threads == "native"
    with Launcher("cpu", 2) as launcher:
        with launcher.overlapping(timer):
            with timer.stage("mark"):
                launcher.launch_items(_count_items, count, [out])
                assert launcher.in_flight == native
            with timer.stage("double"):
                launcher.launch_items(_double_items, count, [out])
                launcher.launch_items(_count_items, count, [out])
            with launcher.paused():
                launcher.launch_items(_double_items, count, [out])
                assert not launcher.in_flight
            launcher.launch_items(_count_items, count, [out])
        assert not launcher.in_flight
    np.testing.assert_array_equal(out.numpy(), np.full(count, 7, np.int32))  # ((1*2+1)*2)+1
    assert set(timer.stages_ms) == {"mark", "double"} and min(timer.stages_ms.values()) >= 0.0


def test_an_injected_clock_keeps_every_pass_waited_for() -> None:
    """The waits a pass in flight costs are charged on the timer's clock, so a timer on
    an injected clock (or with a device sync) keeps every pass waited for."""
    if not band_pool.layout_matches():
        pytest.skip("no native band threads on this platform")
    out = wp.zeros(1000, dtype=wp.int32, device="cpu")
    with Launcher("cpu", 2) as launcher:
        for timer in (StageTimer(clock=lambda: 0.0), StageTimer(sync=lambda: None)):
            with launcher.overlapping(timer):
                launcher.launch_items(_count_items, 1000, [out])
                assert not launcher.in_flight
    np.testing.assert_array_equal(out.numpy(), np.full(1000, 2, np.int32))


def test_measured_costs_come_once_the_pass_is_done(band_threads: str) -> None:
    """``launch_bands``'s ``measured`` gets each band's thread CPU seconds: at once where
    the pass is waited for, at its join where it runs on (``overlapping``)."""
    count = 6000
    out = wp.zeros(count, dtype=wp.int32, device="cpu")
    spans = [(0, 1000), (1000, 0), (1000, 5000)]
    got: list[list[float]] = []
    with Launcher("cpu", 2) as launcher:
        launcher.launch_bands(_count_items, [out], [(n, (first, 1)) for first, n in spans], measured=got.append)
        assert len(got) == 1
        with launcher.overlapping(StageTimer()):
            launcher.launch_bands(_count_items, [out], [(n, (first, 1)) for first, n in spans], measured=got.append)
            assert len(got) == (1 if band_threads == "native" else 2)
        assert len(got) == 2
    np.testing.assert_array_equal(out.numpy(), np.full(count, 2, np.int32))
    for costs in got:
        assert len(costs) == len(spans) and min(costs) >= 0.0 and costs[2] > 0.0
