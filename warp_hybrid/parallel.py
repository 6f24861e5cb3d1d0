"""The launch layer: split a pass into disjoint pieces launched from several threads.

A Warp CPU launch runs on one thread, but Warp releases the GIL while it runs, so
launching disjoint pieces of a pass from two Python threads uses both cores.  Every
per-pixel kernel takes ``row0, row_step, cols`` as its last three inputs
(``launch_pixels``): on the CPU each launch item is one row; 1-D kernels (vertices,
triangles, pixel lists) take ``start, step`` (``launch_items``), or ``start, stop,
group`` where on the CPU a launch item loops over a group of consecutive items
(``launch_groups``: kernels with big struct arguments).  On the CPU a pass is
cut into contiguous bands (of rows or items), several per thread (``band_count``; a
pixel pass on the native band threads in bands that shrink as they go, ``guided_bands``), and
each thread takes the next band not yet taken until none is left: whichever thread
was slowed (a costlier part of the image, another process on its core) simply takes
fewer bands, and neighbouring rows stay on one thread (the texels they share stay in
its cache).  On CUDA the same kernel source runs one thread per pixel or item.

Where the platform allows (``band_pool.native_band_pool``: POSIX, Warp's launch bounds as
expected) a pass's bands (``Launcher.launch_bands``, and ``Launcher.launch_staged`` for a
pass of two kernels a band with a deadline: the tracer's) run on native band threads
that stay in native code between passes, so a pass costs neither a thread's wake-up nor
Python per band.  Elsewhere, and for a deadline on an injected clock (which only Python
can read), a pool of Python threads runs them (``share_until``, ``BandLaunch``).  Within
``Launcher.overlapping`` (the renderer's frame) such a pass runs on past its call while
the caller's Python prepares the next one, which joins it first: a frame's Python
between its passes (~1 ms of a 10-16 ms frame, most of it with the caches cold from the
kernels) then overlaps the helper threads' work instead of leaving them idle.

Passes whose writes could collide (the visibility buffer) give each thread slot its own
output (inputs given per slot) and merge afterwards.  ``Launcher.profile`` (a
``launch_profile.LaunchProfile``, None by default) times every band by kernel and by
the thread that ran it.
"""

from __future__ import annotations

import bisect
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from .band_pool import (
    BAND_COLUMNS,
    COL_CPU_NS,
    COL_ITEMS,
    COL_MUST,
    COL_SLOT,
    COL_WALL_NS,
    MAX_STAGES,
    NO_DEADLINE,
    STAGE_COLUMNS,
    PackedKernel,
    input_fingerprint,
    native_band_pool,
)
from .launch_profile import LaunchProfile
from .timing import StageTimer, perf_clock

#: A kernel's leading inputs: the same for every thread, or given per thread slot.
Inputs = Sequence[Any] | Callable[[int], Sequence[Any]]
#: One launch of a band: its dimension (an int, or a tuple of one or two) and trailing integers.
Launch = tuple[Any, Sequence[int]]
#: Whether ``time.perf_counter`` (``timing.perf_clock``) reads the clock the native band
#: threads read their deadline on.
MONOTONIC_PERF_COUNTER = time.get_clock_info("perf_counter").implementation == "clock_gettime(CLOCK_MONOTONIC)"


def _launch_size(dim: Any) -> int:
    """How many launch items a launch dimension holds."""
    return int(np.prod(dim)) if not isinstance(dim, int) else dim


def _deadline_ns(deadline: float) -> int:
    """A deadline in seconds as the native band threads read it: nanoseconds, clamped to
    int64 (``NO_DEADLINE`` at or past its top, the bottom for -inf and NaN, which no
    time ends by)."""
    ns = deadline * 1e9
    if ns >= NO_DEADLINE:
        return NO_DEADLINE
    return int(ns) if ns > -NO_DEADLINE else -NO_DEADLINE


@dataclass(frozen=True)
class StagedBand:
    """One band of a staged pass (``Launcher.launch_staged``): each stage's launch, the
    items the deadline's estimate counts, and whether it runs whatever the deadline."""

    launches: Sequence[Launch]
    items: int = 0
    must: bool = True


@dataclass
class StagedRun:
    """What a staged pass ran: the first ``ran`` bands, the thread slot of each, and each
    stage's wall (and, when asked, thread CPU) seconds, (ran, stages)."""

    ran: int
    slots: list[int]
    seconds: np.ndarray
    cpu_seconds: np.ndarray


# Bands per thread in a CPU pass, and the fewest rows / items a band holds (a launch
# costs ~20 us of Python, so tiny images and lists are not cut finer than this).
BANDS_PER_THREAD = 8
# Bands per thread on the Python pool in a pass whose rows all cost the same and which
# takes a few ms in all (the log-luminance sums, the tone map): a band's launch there is
# ~35 us of Python taken in turns under the GIL, a fifth of such a pass at 8 bands a
# thread, and even rows leave little for more bands to balance.
FEW_BANDS_PER_THREAD = 2
MIN_BAND_ROWS = 4
# A band of a pixel pass on the native band threads takes 1 / (GUIDED_SHARE * threads) of
# the rows left (``guided_bands``): 16 bands for 480 rows on two threads, the last few of
# four rows.  At eight equal bands a thread, a thread waited at the end of each pass for
# the other's last band, half a band on average (the lighting pass's bands cost a quarter
# of a millisecond).
GUIDED_SHARE = 2
MIN_BAND_ITEMS = 256
# How many band tables (and pixel passes' bands) a launcher keeps for reuse: a frame's
# passes cut the same bands every frame, and building a pass's table in Python cost about
# a third of its launch (~25 us); a launcher that meets more kinds starts again.
KEPT_TABLES = 64
# Consecutive items one CPU launch item takes in a grouped 1-D kernel (``launch_groups``):
# Warp copies a kernel's struct arguments into every launch item, about 40 ns for the
# tracer's 2.7 KB, which was 8% of the path kernel's time with one launch item an item.
ITEM_GROUP = 16


def band_count(total: int, threads: int, minimum: int, per_thread: int = BANDS_PER_THREAD) -> int:
    """How many contiguous bands a CPU pass over ``total`` rows or items is cut into
    for ``threads`` threads: ``per_thread`` per thread, but no band under ``minimum``
    (unless that leaves fewer bands than threads), and never more bands than rows or
    items."""
    if threads <= 1:
        return 1
    return max(1, min(total, max(threads, min(threads * per_thread, total // minimum))))


def guided_bands(total: int, threads: int, minimum: int) -> list[tuple[int, int]]:
    """Contiguous bands (first, count), in order, covering 0 .. total - 1 once, that
    shrink as they go (guided scheduling): each takes ``1 / (GUIDED_SHARE * threads)``
    of what is left, none under ``minimum`` (but the last, which takes the rest).  The
    threads take them in order, so the last bands of a pass are short and the threads
    finish together even where the rows' cost differs (a sky above a mesh), without
    cutting the whole pass as finely; one band for one thread."""
    if threads <= 1:
        return [(0, total)] if total > 0 else []
    spans = []
    first = 0
    while first < total:
        left = total - first
        size = min(left, max(minimum, -(-left // (GUIDED_SHARE * threads))))
        spans.append((first, size))
        first += size
    return spans


def band(k: int, bands: int, total: int) -> tuple[int, int]:
    """Band ``k`` of ``bands`` over ``total`` rows or items: (first, count), the
    sizes differing by at most one, in order."""
    first = k * total // bands
    return first, (k + 1) * total // bands - first


class CostBands:
    """Contiguous bands over a 1-D range whose boundaries follow what the last pass of the
    same range cost: a pass whose cost piles up in a few places (the coverage pass: the
    first sixteenth of the staircase's clusters costs 8-9x the average, over half
    the pass) gets narrow bands there and wide ones elsewhere, so the
    threads taking bands finish together.  ``spans`` gives the bands for a pass,
    ``measured`` takes each band's cost afterwards (its thread's CPU time: a band's cost
    spread evenly over its items); the next pass cuts the range into bands of equal
    measured cost.  A range of another length starts again from equal bands.  Where
    the bands fall never changes what a pass computes, only which thread runs it.

    The measured cost is kept per band (its edges and the cost up to each), not per
    item: the cost up to a point of the range is then piecewise linear, and a cut is
    found by interpolating its inverse, a few microseconds for any range."""

    def __init__(self) -> None:
        """No cost measured yet: the first pass gets equal bands."""
        self._total = 0
        self._edges: list[int] = []
        self._cumulative: list[float] = []

    def spans(self, total: int, bands: int) -> list[tuple[int, int]]:
        """``bands`` contiguous bands (first, count), in order, covering 0 .. total - 1 once:
        equal (``band``) until a pass over ``total`` items was measured, then of equal
        measured cost, none empty."""
        bands = max(1, min(bands, total))
        if not self._edges or self._total != total or bands == 1:
            return [band(k, bands, total) for k in range(bands)]
        edges_in, cumulative = self._edges, self._cumulative
        edges = [0]
        for k in range(1, bands):
            # where the cost reaches the target (linear within a measured band); an item
            # goes before the cut where the cost up to its middle is below the target
            target = cumulative[-1] * k / bands
            j = min(bisect.bisect_right(cumulative, target), len(cumulative) - 1)
            low, high = cumulative[j - 1], cumulative[j]
            at = edges_in[j - 1] + (target - low) / (high - low) * (edges_in[j] - edges_in[j - 1])
            cut = math.ceil(at - 0.5)
            # none empty: after the band before, with an item left for each band after
            edges.append(min(max(cut, edges[-1] + 1), total - (bands - k)))
        edges.append(total)
        return [(edges[k], edges[k + 1] - edges[k]) for k in range(bands)]

    def measured(self, spans: Sequence[tuple[int, int]], costs: Sequence[float]) -> None:
        """What each band of ``spans`` (contiguous, in order, from 0) cost (any unit, >= 0);
        a band that cost nothing measurable keeps a little (1e-3 of the mean cost an item)
        so the next cut stays finite."""
        total = sum(count for _, count in spans)
        costs = [max(float(cost), 0.0) for cost in costs]
        floor = max(1.0e-3 * sum(costs) / total if total else 0.0, 1.0e-300)
        self._total = total
        self._edges, self._cumulative = [0], [0.0]
        for (_, count), cost in zip(spans, costs, strict=True):
            if count > 0:
                self._edges.append(self._edges[-1] + count)
                self._cumulative.append(self._cumulative[-1] + max(cost, floor * count))


def item_group(device: wp.context.Device) -> int:
    """Items per launch item of a grouped 1-D kernel on ``device``: ``ITEM_GROUP`` on the
    CPU, 1 on CUDA (one thread an item)."""
    return 1 if device.is_cuda else ITEM_GROUP


def group_launch(first: int, items: int, group: int) -> tuple[int, tuple[int, int, int]]:
    """The launch dimension and trailing inputs ``(start, stop, group)`` of a grouped 1-D
    kernel over items ``first`` .. ``first + items``: launch item ``tid`` takes items
    ``start + tid * group`` up to ``min(start + (tid + 1) * group, stop)``."""
    return -(-items // group), (first, first + items, group)


def default_thread_count(device: wp.context.Device) -> int:
    """Host threads to launch from: on a CPU device the CPUs this process may run on (its
    affinity, where the platform tells it: a container or ``taskset`` may allow fewer
    than the machine has, and a band thread spinning on a CPU it shares would slow the
    caller), at most 8; 1 on a GPU.

    ``WARP_HYBRID_THREADS`` overrides it (benchmarks use it to compare 1 vs 2).
    """
    env = os.environ.get("WARP_HYBRID_THREADS")
    if env:
        return max(1, int(env))
    if device.is_cuda:
        return 1
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(cpus or 1, 8))


def band_table(
    launches: Sequence[Sequence[Launch]], items: Sequence[int] | None, must: Sequence[bool] | None
) -> np.ndarray:
    """The native band threads' table of a pass (``band_pool.BAND_COLUMNS`` int64 a band):
    band k's per-stage launches ``launches[k]`` (dimension, trailing integers), its items
    (0 without ``items``) and whether it must run (every band without ``must``)."""
    rows = []  # built as lists: a band's row costs ~1 us, not numpy's ~1 us a slice
    for band_launches in launches:
        row = [0] * BAND_COLUMNS
        for s, (dim, ints) in enumerate(band_launches):
            c = s * STAGE_COLUMNS
            extents = (dim, 1) if isinstance(dim, int) else (*dim, 1)
            row[c], row[c + 1] = extents[0], extents[1]
            row[c + 2 : c + 2 + len(ints)] = ints
        rows.append(row)
    table = np.array(rows, dtype=np.int64)
    if items is not None:
        table[:, COL_ITEMS] = items
    table[:, COL_MUST] = 1 if must is None else must
    return table


def kept(cache: dict[tuple, Any], key: tuple, make: Callable[[], Any], limit: int = KEPT_TABLES) -> Any:
    """``cache[key]``, made by ``make()`` the first time it is asked for; a cache that holds
    ``limit`` entries starts again."""
    value = cache.get(key)
    if value is None:
        if len(cache) >= limit:
            cache.clear()
        value = cache[key] = make()
    return value


class BandLaunch:
    """The launches of one pass's bands of ``kernel``: its leading ``inputs`` (the same
    for every band; a callable gives them per thread ``slot``) are packed once per thread
    into a recorded launch (``wp.launch(..., record_cmd=True)``), and each band sets
    only its trailing integers and its dimension before it runs.  Packing the struct
    arguments costs ~17 us a launch on the CPU, about a third of a launch's Python time;
    a pass of 16 bands packs them twice.  The integers go in as they are
    (``set_param_at_index_from_ctype``: no type dispatch) and the dimension only where
    it changed, which made a band's launch 13-15 us of Python against 38 us before.  A
    pass makes its own (after a scene update or on a new buffer the arguments differ),
    and one thread slot is only ever used by one thread at a time, so the recorded
    launches are never shared between threads."""

    def __init__(
        self, launcher: Launcher, kernel: wp.Kernel, inputs: Sequence[Any] | Callable[[int], Sequence[Any]]
    ) -> None:
        """Bands of ``kernel`` on ``launcher``'s device with ``inputs`` before each band's tail."""
        self.launcher = launcher
        self.kernel = kernel
        self._inputs = inputs
        # per thread slot: the recorded launch, where its trailing integers start, its dimension
        self._recorded: dict[int, tuple[Any, int, Any]] = {}

    def _run(self, slot: int, dim: Any, tail: Sequence[int]) -> None:
        recorded = self._recorded.get(slot)
        if recorded is None:
            inputs = self._inputs(slot) if callable(self._inputs) else self._inputs
            cmd = wp.launch(self.kernel, dim=dim, inputs=[*inputs, *tail], device=self.launcher.device, record_cmd=True)
            self._recorded[slot] = (cmd, len(inputs), dim)
        else:
            cmd, tail_index, last_dim = recorded
            for i, value in enumerate(tail):
                cmd.set_param_at_index_from_ctype(tail_index + i, value)
            if dim != last_dim:  # bands of a pass differ by a row at most: mostly the same
                cmd.set_dim(dim)
                self._recorded[slot] = (cmd, tail_index, dim)
        cmd.launch()

    def __call__(self, slot: int, dim: Any, tail: Sequence[int], first: bool = True) -> None:
        """Run one band on this thread (``slot``; ``first``: the pass's first band) with
        trailing integers ``tail``, timed by kernel when the launcher profiles."""
        self.launcher.profiled(self.kernel, slot, first, lambda: self._run(slot, dim, tail))


class Launcher:
    """Runs the pieces of a pass on a few persistent threads: native band threads where the
    platform has them (``band_pool``), a pool of Python threads for the rest."""

    def __init__(self, device: wp.context.Device | str, threads: int | None = None) -> None:
        """Create a launcher for ``device`` with ``threads`` pieces per pass."""
        self.device = wp.get_device(device)
        self.threads = threads if threads is not None else default_thread_count(self.device)
        self._pool = ThreadPoolExecutor(max_workers=self.threads - 1) if self.threads > 1 else None
        self._pool_bands = native_band_pool(self.device, self.threads)
        self._bands = self._pool_bands  # None while the Python pool runs the bands
        self._loaded: set[int] = set()
        #: Per (kernel, trailing integers, stage): the last inputs' fingerprints and their blocks.
        self._packed: dict[tuple, tuple[list, list[PackedKernel]]] = {}
        #: Untimed passes' band tables by their bands, and pixel passes' bands by their shape
        #: (at most ``KEPT_TABLES`` each).
        self._tables: dict[tuple, np.ndarray] = {}
        self._pixel_bands: dict[tuple, list[Launch]] = {}
        self.profile: LaunchProfile | None = None
        #: While ``overlapping``: the frame's timer (an untimed native pass is then posted
        #: without waiting for it); else None.
        self._overlap: StageTimer | None = None
        #: The stage of ``_overlap`` that posted the pass in flight (None: none open), and
        #: what to call once it is done (``launch_bands``'s ``measured``).
        self._flight_stage: str | None = None
        self._flight_done: Callable[[], None] | None = None

    def close(self) -> None:
        """Finish the pass in flight, stop the worker threads (and let go of the arrays the
        kept blocks point to)."""
        self.join()
        self._packed.clear()
        self._tables.clear()
        self._pixel_bands.clear()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        if self._pool_bands is not None:
            self._pool_bands.close()
            self._pool_bands = self._bands = None

    @property
    def native_bands(self) -> bool:
        """Whether the bands of a pass run on the native band threads (``band_pool``):
        True where the platform has them, until set False (benchmarks compare the two,
        ``scripts/bench_bands.py``); then the Python pool runs them, as on a platform
        without them."""
        return self._bands is not None

    @native_bands.setter
    def native_bands(self, on: bool) -> None:
        if on and self._pool_bands is None:
            raise ValueError("no native band threads here (CUDA, one thread, closed, or not this platform)")
        self.join()
        if not on and self._pool_bands is not None:
            self._pool_bands.nap()
        self._bands = self._pool_bands if on else None

    @contextmanager
    def overlapping(self, timer: StageTimer) -> Iterator[None]:
        """Within: an untimed pass on the native band threads (no deadline, no profile)
        is posted without waiting for it, so the caller's Python up to the next pass (its
        checks, its buffers, its arguments) runs while the helper threads work on it;
        every call of this launcher that runs or reads anything first takes part in the
        pass in flight and waits for it (``join``), and the block's end joins it.  The
        caller must touch what a pass reads or writes only through this launcher, or
        after ``join`` (``paused`` for code that does not).  The wait a join spends is
        charged to ``timer``'s stage that posted the pass (``StageTimer.charge``), so the
        stages still add up to the wall time.  Nothing changes where the timer's clock
        is not the native threads' (an injected clock, a device sync) or without native
        band threads."""
        usable = self._bands is not None and timer.clock is perf_clock and timer.sync is None
        outer = self._overlap
        self._overlap = timer if usable else None
        try:
            yield
        finally:
            self.join()
            self._overlap = outer

    @contextmanager
    def paused(self) -> Iterator[None]:
        """Within an ``overlapping`` block: join the pass in flight, and run every pass to
        its end (for code that reads or writes a pass's data outside this launcher)."""
        self.join()
        outer = self._overlap
        self._overlap = None
        try:
            yield
        finally:
            self._overlap = outer

    @property
    def in_flight(self) -> bool:
        """Whether a pass posted within ``overlapping`` may still be running (until ``join``)."""
        return self._pool_bands is not None and self._pool_bands.in_flight

    def join(self) -> None:
        """Take part in the pass in flight (``overlapping``), if any, and wait until it is
        done, its wait charged to the stage that posted it."""
        if not self.in_flight:
            return
        done = self._landed(self._pool_bands.join())
        if done is not None:
            done()

    def _landed(self, waited: float) -> Callable[[], None] | None:
        """The pass in flight is done, after ``waited`` seconds' wait: charge them to the
        stage that posted it and return its ``then`` (for the caller to call)."""
        if self._overlap is not None and self._flight_stage is not None:
            self._overlap.charge(self._flight_stage, waited)
        done = self._flight_done
        self._flight_stage = self._flight_done = None
        return done

    def wake(self) -> None:
        """Wake the native band threads that sleep (``BandPool.wake``), before the work
        ahead of a frame's first pass; nothing on the Python pool."""
        if self._bands is not None:
            self._bands.wake()

    def __enter__(self) -> Launcher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def ensure_loaded(self, kernel: wp.Kernel) -> None:
        """Compile/load a kernel's module before threads race to do it."""
        key = id(kernel.module)
        if key not in self._loaded:
            wp.load_module(kernel.module, device=self.device)
            self._loaded.add(key)

    def _map(self, piece: Callable[[int, int], Any], n: int) -> list[Any]:
        """``piece(k, n)`` for k in 0..n-1: piece 0 on the calling thread, the others on
        the pool (handing a piece to a pool thread and waiting for it costs 40-160 us, the
        threads' wake-ups, more on a virtual machine; the caller would only wait).  Every
        piece runs before any exception propagates."""
        self.join()
        if n <= 1 or self._pool is None:
            return [piece(k, n) for k in range(n)]
        if self._pool_bands is not None:
            self._pool_bands.nap()  # the pool threads need the cores the band threads spin on
        futures = [self._pool.submit(piece, k, n) for k in range(1, n)]
        try:
            first = piece(0, n)
        finally:
            rest = [f.result() for f in futures]
        return [first, *rest]

    def launch_pixels(
        self,
        kernel: wp.Kernel,
        height: int,
        width: int,
        inputs: Sequence[Any],
        rows: tuple[int, int] | None = None,
        bands_per_thread: int = BANDS_PER_THREAD,
    ) -> None:
        """Launch a per-pixel kernel in the shape this device wants, from one source.

        The kernel's last three inputs must be ``row0: int, row_step: int, cols: int``;
        its launch item ``(r, c)`` (``wp.tid()``) handles image row ``row0 + r * row_step``,
        columns ``c * cols`` up to ``min((c + 1) * cols, width)``.  On the CPU an item is a
        whole row (``cols = width``; the big struct arguments are copied once per row,
        not per pixel) and the rows go out in bands (module docstring); on CUDA an item
        is one pixel (``cols = 1``), one thread each.  ``rows`` (first, stop): only those
        rows of the ``height`` (default: all of them).  ``bands_per_thread``: how finely
        the Python pool cuts the rows (``FEW_BANDS_PER_THREAD`` for a short pass of even
        rows, where a band's Python would cost more than the balance gains); the native
        band threads, whose bands cost about a microsecond each, always take shrinking
        bands (``guided_bands``).
        """
        first, stop = (0, height) if rows is None else (max(0, rows[0]), min(height, rows[1]))
        count = stop - first
        if count <= 0 or width <= 0:
            return
        self.ensure_loaded(kernel)
        if self.device.is_cuda:
            self.launch(kernel, 0, (count, width), [*inputs, first, 1, 1])
            return

        native = self._bands is not None

        def launches() -> list[Launch]:
            if native:
                spans = guided_bands(count, self.threads, MIN_BAND_ROWS)
            else:
                bands = band_count(count, self.threads, MIN_BAND_ROWS, bands_per_thread)
                spans = [band(k, bands, count) for k in range(bands)]
            return [((rows, 1), (first + row0, 1, width)) for row0, rows in spans]

        key = (first, count, width, "guided" if native else bands_per_thread)
        self.launch_bands(kernel, inputs, kept(self._pixel_bands, key, launches))

    def launch_items(
        self, kernel: wp.Kernel, count: int, inputs: Sequence[Any], min_band_items: int = MIN_BAND_ITEMS
    ) -> None:
        """Launch a 1-D kernel over ``count`` items split across threads.

        The kernel's last two inputs must be ``start: int, step: int``; thread ``tid``
        handles item ``start + tid * step`` (on the CPU, bands of consecutive items, none
        under ``min_band_items``; see ``launch_slots``).
        """
        if count <= 0:
            return
        self.ensure_loaded(kernel)
        if self.device.is_cuda:
            self.launch(kernel, 0, count, [*inputs, 0, 1])
            return

        bands = band_count(count, self.threads, min_band_items)
        spans = [band(k, bands, count) for k in range(bands)]
        self.launch_bands(kernel, inputs, [(items, (start, 1)) for start, items in spans])

    def launch_groups(
        self, kernel: wp.Kernel, count: int, inputs: Sequence[Any], min_band_items: int = MIN_BAND_ITEMS
    ) -> None:
        """Launch a grouped 1-D kernel over ``count`` items split across threads: its last
        three inputs must be ``start: int, stop: int, group: int`` (``group_launch``; the
        group is ``item_group(device)``), so on the CPU one launch item loops over a
        group of consecutive items and its struct arguments are copied once a group.
        Bands as in ``launch_items``."""
        self._launch_grouped(kernel, count, inputs, min_band_items, slotted=False)

    def launch_slots(
        self, kernel: wp.Kernel, count: int, inputs: Sequence[Any], min_band_items: int = MIN_BAND_ITEMS
    ) -> None:
        """Launch a grouped 1-D kernel that accumulates per thread: the last four inputs
        must be ``slot: int, start: int, stop: int, group: int`` (``group_launch``).  On
        the CPU the items go out in bands like ``launch_items``'s (none under
        ``min_band_items``: a kernel that does a few ns of work per item is cut no finer
        than one band per thread with a large one), and each band adds into the ``slot``
        of the thread that runs it (0 .. threads - 1), so no two threads ever add to the
        same slot (Warp's CPU atomics are plain read-modify-writes).  On CUDA one launch
        (slot 0) covers every item and the adds are atomic."""
        self._launch_grouped(kernel, count, inputs, min_band_items, slotted=True)

    def _launch_grouped(
        self, kernel: wp.Kernel, count: int, inputs: Sequence[Any], min_band_items: int, slotted: bool
    ) -> None:
        """The bands of a grouped kernel (``launch_groups``); with ``slotted`` the thread's
        slot (0 on CUDA) goes before each band's ``start, stop, group``."""
        if count <= 0:
            return
        self.ensure_loaded(kernel)
        group = item_group(self.device)
        if self.device.is_cuda:
            dim, tail = group_launch(0, count, group)
            self.launch(kernel, 0, dim, [*inputs, *((0,) if slotted else ()), *tail])
            return

        bands = band_count(count, self.threads, min_band_items)
        spans = [group_launch(*band(k, bands, count), group) for k in range(bands)]
        # a slotted band adds into the slot of the thread that runs it: a leading input per thread
        self.launch_bands(kernel, (lambda slot: [*inputs, slot]) if slotted else inputs, spans)

    def launch_bands(
        self,
        kernel: wp.Kernel,
        inputs: Inputs,
        bands: Sequence[Launch],
        timed: bool = False,
        measured: Callable[[list[float]], None] | None = None,
    ) -> list[float] | None:
        """Run one CPU pass of ``kernel`` cut into ``bands``: band k launches over dimension
        ``bands[k][0]`` (an int, or a tuple of one or two) with inputs ``[*inputs,
        *bands[k][1]]`` (``inputs``: the same for every band, or a callable giving them
        per thread slot; the trailing integers int32), each thread taking the next band
        left (``launch_staged`` with one stage).  Returns each band's thread CPU seconds
        with ``timed``, else None.  ``measured``: given them once the pass is done (where
        it runs on past this call, ``overlapping``, when it is joined)."""
        if not bands:
            if measured is not None:
                measured([])
            return [] if timed else None
        clocked = timed or measured is not None
        if self._bands is not None:
            self.ensure_loaded(kernel)
            if clocked or self.profile is not None:  # (its times are read back: a table of its own)
                table = band_table([[launch] for launch in bands], None, None)
            else:
                table = self._kept_table(bands)
            costs = (lambda: (table[:, COL_CPU_NS] * 1e-9).tolist()) if clocked else None
            then = (lambda: measured(costs())) if measured is not None else None
            self._native_pass([(kernel, inputs)], [len(bands[0][1])], table, timed, then=then)
            return costs() if timed else None
        staged = self.launch_staged([(kernel, inputs)], [StagedBand((launch,)) for launch in bands], cpu=clocked)
        seconds = staged.cpu_seconds[:, 0].tolist()
        if measured is not None:
            measured(seconds)
        return seconds if timed else None

    def launch_staged(
        self,
        stages: Sequence[tuple[wp.Kernel, Inputs]],
        bands: Sequence[StagedBand],
        timer: StageTimer | None = None,
        deadline: float | None = None,
        cpu: bool = False,
    ) -> StagedRun:
        """Run the bands of a CPU pass made of ``stages`` (kernel, inputs as in
        ``launch_bands``; at most ``band_pool.MAX_STAGES``): band k runs
        ``bands[k].launches[s]`` of each stage s in order (a dimension of size 0 skips
        one), each thread taking the next band left.  With a ``deadline`` (seconds on
        ``timer``'s clock), a band not marked ``must`` runs only if ``timer.now()`` plus
        its items at the mean wall time an item of the bands done so far ends by the
        deadline; the first it refuses stops the pass there (a prefix of the bands
        runs).  On the native band threads where the timer's clock is the monotonic
        ``timing.perf_clock`` with no device sync (or no deadline is asked), else on the
        Python pool.  Returns which bands ran, on which thread, and each stage's wall
        seconds (and thread CPU seconds with ``cpu``)."""
        count = len(bands)
        if not 1 <= len(stages) <= MAX_STAGES or any(len(b.launches) != len(stages) for b in bands):
            raise ValueError(f"{len(stages)} stages (at most {MAX_STAGES}), and every band one launch a stage")
        if count == 0:
            return StagedRun(0, [], np.zeros((0, len(stages))), np.zeros((0, len(stages))))
        for kernel, _inputs in stages:
            self.ensure_loaded(kernel)
        native_clock = deadline is None or (
            MONOTONIC_PERF_COUNTER and timer is not None and timer.clock is perf_clock and timer.sync is None
        )
        if self._bands is not None and native_clock:
            deadline_ns = None if deadline is None else _deadline_ns(deadline)
            table = band_table([b.launches for b in bands], [b.items for b in bands], [b.must for b in bands])
            # timed: the run reports every stage's wall seconds
            ran = self._native_pass(stages, [len(ints) for _dim, ints in bands[0].launches], table, True, deadline_ns)
            n = len(stages)
            return StagedRun(
                ran,
                table[:ran, COL_SLOT].tolist(),
                table[:ran, COL_WALL_NS : COL_WALL_NS + n] * 1e-9,
                table[:ran, COL_CPU_NS : COL_CPU_NS + n] * 1e-9,
            )
        return self._python_staged(stages, bands, timer, deadline, cpu)

    def _python_staged(
        self,
        stages: Sequence[tuple[wp.Kernel, Inputs]],
        bands: Sequence[StagedBand],
        timer: StageTimer | None,
        deadline: float | None,
        cpu: bool,
    ) -> StagedRun:
        """``launch_staged`` on the Python pool (``share_until``): the deadline asked on
        ``timer``'s clock (``timing.perf_clock`` without one), the stages' wall seconds
        on the real clock after the timer's device sync, as the tracer has always timed
        its bands (an injected clock is then read only in band order, under the lock,
        whatever the threads' interleaving)."""
        runs = [BandLaunch(self, kernel, inputs) for kernel, inputs in stages]
        now = timer.now if timer is not None else perf_clock
        sync = timer.sync if timer is not None else None

        def mark() -> float:
            if sync is not None:
                sync()
            return time.perf_counter()

        seconds = np.zeros((len(bands), len(stages)))
        cpu_seconds = np.zeros((len(bands), len(stages)))
        slots = [0] * len(bands)
        done = {"items": 0, "seconds": 0.0}

        def proceed(k: int) -> bool:
            band = bands[k]
            if deadline is None or band.must:
                return True
            per_item = done["seconds"] / done["items"] if done["items"] > 0 else 0.0
            return now() + band.items * per_item <= deadline

        def job(k: int, slot: int) -> None:
            band = bands[k]
            last = mark()  # one reading before the band and one after each stage
            for s, (run, (dim, tail)) in enumerate(zip(runs, band.launches, strict=True)):
                start_cpu = time.thread_time() if cpu else 0.0
                if _launch_size(dim) > 0:
                    run(slot, dim, tail, k == 0)
                reading = mark()
                seconds[k, s], last = reading - last, reading
                if cpu:
                    cpu_seconds[k, s] = time.thread_time() - start_cpu
            slots[k] = slot
            with lock:
                done["items"] += band.items
                done["seconds"] += float(seconds[k].sum())

        lock = threading.Lock()
        ran = self.share_until(job, len(bands), proceed)
        return StagedRun(ran, slots[:ran], seconds[:ran], cpu_seconds[:ran])

    def _pack(self, kernel: wp.Kernel, inputs: Inputs, tail: int, stage: int) -> list[PackedKernel]:
        """Each thread's argument block for ``kernel`` at ``stage`` of a pass: packed once
        and copied, or, for inputs given per thread slot, packed per thread; the blocks of
        the last pass that gave this kernel at this stage the same inputs (the same
        ``band_pool.input_fingerprint``) as they are, since a frame passes most kernels
        what it passed the frame before, and packing (Warp's own, in Python) cost about
        0.15 ms a kernel."""
        given = [inputs(slot) for slot in range(self.threads)] if callable(inputs) else [inputs]
        prints = [input_fingerprint(slot_inputs) for slot_inputs in given]
        key = (kernel, tail, stage)
        known = self._packed.get(key)
        if known is not None and None not in prints and known[0] == prints:
            return known[1]
        if callable(inputs):
            blocks = [PackedKernel.pack(kernel, self.device, slot_inputs, tail) for slot_inputs in given]
        else:
            block = PackedKernel.pack(kernel, self.device, inputs, tail)
            blocks = [block, *(block.copy() for _ in range(1, self.threads))]
        if None not in prints:
            self._packed[key] = (prints, blocks)
        return blocks

    def _kept_table(self, bands: Sequence[Launch]) -> np.ndarray:
        """The band table of an untimed one-stage pass cut into ``bands``: the one built
        for the same bands before (nothing reads its written-back columns), else a new
        one, kept."""
        return kept(self._tables, tuple(bands), lambda: band_table([[launch] for launch in bands], None, None))

    def _native_pass(
        self,
        stages: Sequence[tuple[wp.Kernel, Inputs]],
        tails: Sequence[int],
        table: np.ndarray,
        timed: bool,
        deadline_ns: int | None = None,
        then: Callable[[], None] | None = None,
    ) -> int:
        """One pass on the native band threads over the band table ``table``
        (``band_table``), stage s's kernel taking ``tails[s]`` trailing integers; returns
        how many bands ran (the table gets each band's thread and, timed, profiled or
        with ``then``, its times).  ``then()`` runs once the pass is done: within
        ``overlapping`` a pass with no deadline, not ``timed`` (whose times the caller
        reads at once) and not profiled runs on past this call, until it is joined."""
        blocks = [self._pack(kernel, inputs, tail, s) for s, ((kernel, inputs), tail) in enumerate(zip(stages, tails))]
        profile = self.profile
        if self._overlap is not None and not timed and profile is None and deadline_ns is None:
            # (the pass in flight, if any, is finished natively right before this one is posted)
            finishing = self.in_flight
            count = self._bands.run(blocks, table, then is not None, wait=False)
            last_done = self._landed(self._bands.finished_s) if finishing else None
            self._flight_stage = self._overlap.current
            self._flight_done = then
            if last_done is not None:  # (while this pass runs)
                last_done()
            return count
        self.join()
        ran = self._bands.run(blocks, table, timed or then is not None or profile is not None, deadline_ns)
        if profile is not None:
            for k, row in enumerate(table[:ran].tolist()):
                for s, (kernel, _inputs) in enumerate(stages):
                    wall, cpu = row[COL_WALL_NS + s] * 1e-9, row[COL_CPU_NS + s] * 1e-9
                    profile.record(kernel.key, row[COL_SLOT], wall, cpu, k == 0)
        if then is not None:
            then()
        return ran

    def share_until(
        self, job: Callable[[int, int], None], bands: int, proceed: Callable[[int], bool] | None = None
    ) -> int:
        """Run ``job(k, slot)`` for the bands k = 0, 1, ... in order, each thread (``slot``)
        taking the next band left; before a band is taken ``proceed(k)`` is asked (None:
        every band runs), under a lock and so in band order, and the first False stops
        every thread before band k.  Returns how many bands ran: always bands 0 .. n - 1,
        a prefix (a band taken is always run)."""
        lock = threading.Lock()
        state = {"next": 0, "stopped": False}

        def take() -> int | None:
            with lock:
                k = state["next"]
                if state["stopped"] or k >= bands:
                    return None
                if proceed is not None and not proceed(k):
                    state["stopped"] = True
                    return None
                state["next"] = k + 1
                return k

        def worker(slot: int, _workers: int) -> None:
            while (k := take()) is not None:
                job(k, slot)

        self._map(worker, min(self.threads, bands))
        return state["next"]

    def launch(self, kernel: wp.Kernel, slot: int, dim: Any, inputs: list[Any], first: bool = True) -> None:
        """One ``wp.launch`` on this thread (a band of a pass, on thread ``slot``;
        ``first``: the pass's first band), timed by kernel when profiling."""
        self.join()
        self.profiled(kernel, slot, first, lambda: wp.launch(kernel, dim=dim, inputs=inputs, device=self.device))

    def profiled(self, kernel: wp.Kernel, slot: int, first: bool, run: Callable[[], None]) -> None:
        """``run()`` (a launch of ``kernel`` on thread ``slot``), timed into ``profile``
        under the kernel's name when one is attached (on CUDA until the device is done)."""
        profile = self.profile
        if profile is None:
            run()
            return
        start, cpu = time.perf_counter(), time.thread_time()
        run()
        if self.device.is_cuda:
            wp.synchronize_device(self.device)
        profile.record(kernel.key, slot, time.perf_counter() - start, time.thread_time() - cpu, first)
