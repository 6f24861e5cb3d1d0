"""The launch layer: split a pass into disjoint pieces launched from several threads.

A Warp CPU launch runs on one thread, but Warp releases the GIL while it runs, so
launching disjoint pieces of a pass from two Python threads uses both cores.  Every
per-pixel kernel takes ``row0, row_step, cols`` as its last three inputs
(``launch_pixels``): on the CPU each launch item is one row, the rows
``row0, row0 + row_step, ...`` of a piece (interleaved rows balance the load better
than bands); on CUDA the same kernel source runs one thread per pixel.  1-D kernels
(vertices, triangles, pixel lists) take ``start, step`` (``launch_items``).

Passes whose writes could collide (the visibility buffer) use ``Launcher.run`` with
one output buffer per piece and merge them afterwards.  ``Launcher.profile`` (a
``launch_profile.LaunchProfile``, None by default) times every piece by kernel.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import warp as wp

from .launch_profile import LaunchProfile


def default_thread_count(device: wp.context.Device) -> int:
    """Host threads to launch from: the CPU count on a CPU device, 1 on a GPU.

    ``WARP_HYBRID_THREADS`` overrides it (benchmarks use it to compare 1 vs 2).
    """
    env = os.environ.get("WARP_HYBRID_THREADS")
    if env:
        return max(1, int(env))
    if device.is_cuda:
        return 1
    return max(1, min(os.cpu_count() or 1, 8))


class Launcher:
    """Runs the pieces of a pass on a small persistent thread pool."""

    def __init__(self, device: wp.context.Device | str, threads: int | None = None) -> None:
        """Create a launcher for ``device`` with ``threads`` pieces per pass."""
        self.device = wp.get_device(device)
        self.threads = threads if threads is not None else default_thread_count(self.device)
        self._pool = ThreadPoolExecutor(max_workers=self.threads) if self.threads > 1 else None
        self._loaded: set[int] = set()
        self.profile: LaunchProfile | None = None

    def close(self) -> None:
        """Stop the worker threads."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

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

    def run(self, piece: Callable[[int, int], Any], pieces: int | None = None) -> list[Any]:
        """Call ``piece(k, n)`` for k in 0..n-1, in parallel threads; return results
        (timed under the piece's name when profiling).

        Exceptions from any piece propagate to the caller.
        """
        n = self.threads if pieces is None else pieces
        profile = self.profile
        if profile is None:
            return self._map(piece, n)
        name = getattr(piece, "__qualname__", "run")
        return self._map(lambda k, count: profile.timed(name, k, piece, k, count), n)

    def _map(self, piece: Callable[[int, int], Any], n: int) -> list[Any]:
        """``piece(k, n)`` for k in 0..n-1 on the pool (inline for one piece)."""
        if n <= 1 or self._pool is None:
            return [piece(k, n) for k in range(n)]
        futures = [self._pool.submit(piece, k, n) for k in range(n)]
        return [f.result() for f in futures]

    def launch_pixels(self, kernel: wp.Kernel, height: int, width: int, inputs: Sequence[Any]) -> None:
        """Launch a per-pixel kernel in the shape this device wants, from one source.

        The kernel's last three inputs must be ``row0: int, row_step: int, cols: int``;
        its launch item ``(r, c)`` (``wp.tid()``) handles image row ``row0 + r * row_step``,
        columns ``c * cols`` up to ``min((c + 1) * cols, width)``.  On the CPU an item is a
        whole row (``cols = width``; the big struct arguments are copied once per row,
        not per pixel) and the rows are interleaved across the threads; on CUDA an
        item is one pixel (``cols = 1``), one thread each.
        """
        if height <= 0 or width <= 0:
            return
        self.ensure_loaded(kernel)
        if self.device.is_cuda:
            self._launch(kernel, 0, (height, width), [*inputs, 0, 1, 1])
            return
        n = min(self.threads, height)

        def piece(k: int, count: int) -> None:
            rows = (height - k + count - 1) // count
            self._launch(kernel, k, (rows, 1), [*inputs, k, count, width])

        self._map(piece, n)

    def launch_items(self, kernel: wp.Kernel, count: int, inputs: Sequence[Any]) -> None:
        """Launch a 1-D kernel over ``count`` items split across threads.

        The kernel's last two inputs must be ``start: int, step: int``; thread ``tid``
        handles item ``start + tid * step``.
        """
        if count <= 0:
            return
        self.ensure_loaded(kernel)
        n = min(self.threads, count)

        def piece(k: int, pieces: int) -> None:
            items = (count - k + pieces - 1) // pieces
            self._launch(kernel, k, items, [*inputs, k, pieces])

        self._map(piece, n)

    def _launch(self, kernel: wp.Kernel, piece: int, dim: Any, inputs: list[Any]) -> None:
        """One ``wp.launch`` (piece ``piece`` of a pass), timed by kernel when profiling."""
        profile = self.profile
        if profile is None:
            wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)
            return
        start, cpu = time.perf_counter(), time.thread_time()
        wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)
        if self.device.is_cuda:
            wp.synchronize_device(self.device)
        profile.record(kernel.key, piece, time.perf_counter() - start, time.thread_time() - cpu)
