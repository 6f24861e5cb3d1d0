"""A per-launch profile of the launch layer (``Launcher.profile``): what each kernel and
each host thread spent, so every speed claim names the kernel it moved.

While a ``LaunchProfile`` is attached, every piece a ``Launcher`` runs (one launch of a
band of a pass on one host thread) is timed on its own thread,
summed by the thread (its *slot*) that ran it: wall time (``time.perf_counter``, after a
device sync on CUDA, so it covers the work; ``CLOCK_MONOTONIC`` on the native band
threads) and the thread's CPU time (``time.thread_time``, ``CLOCK_THREAD_CPUTIME_ID``
natively: a CPU launch runs on the calling thread, so this is the kernel's own work,
unaffected by other processes sharing the cores: the number to compare two versions by
on a busy machine).  Profiling adds two clock readings per piece and nothing else;
without a profile the launch layer reads no clock (except for what a pass's caller asks:
the coverage bands' costs, the tracer's deadline).
"""

from __future__ import annotations

import threading
from collections import defaultdict
from dataclasses import dataclass, field


@dataclass
class KernelTimes:
    """One kernel's launches and time, in total and per thread slot."""

    launches: int = 0
    ms: float = 0.0
    cpu_ms: float = 0.0
    piece_ms: dict[int, float] = field(default_factory=lambda: defaultdict(float))

    @property
    def balance(self) -> float:
        """Mean over the busiest thread's time (1: perfectly balanced threads)."""
        if not self.piece_ms:
            return 1.0
        busiest = max(self.piece_ms.values())
        return sum(self.piece_ms.values()) / (len(self.piece_ms) * busiest) if busiest > 0 else 1.0


class LaunchProfile:
    """Times per kernel name, summed over every launch while attached."""

    def __init__(self) -> None:
        """An empty profile."""
        self.kernels: dict[str, KernelTimes] = defaultdict(KernelTimes)
        self._lock = threading.Lock()

    def record(self, name: str, slot: int, seconds: float, cpu_seconds: float, first: bool | None = None) -> None:
        """Add one piece of a launch of ``name`` run on thread ``slot``: its wall and
        thread CPU seconds (thread-safe); ``first`` (default: slot 0) marks the launch's
        first piece, which counts the launch."""
        with self._lock:
            k = self.kernels[name]
            k.ms += seconds * 1000.0
            k.cpu_ms += cpu_seconds * 1000.0
            k.piece_ms[slot] += seconds * 1000.0
            if (slot == 0) if first is None else first:
                k.launches += 1

    def rows(self, frames: int = 1) -> list[dict[str, float | str]]:
        """Per kernel, slowest first: launches and ms per frame (the busiest thread's
        wall ms: the time it adds to the frame), the threads' CPU ms summed, and the
        thread balance (of the wall times)."""
        rows = []
        for name, k in self.kernels.items():
            busiest = max(k.piece_ms.values()) if k.piece_ms else 0.0
            rows.append(
                {
                    "kernel": name,
                    "launches": k.launches / frames,
                    "wall_ms": busiest / frames,
                    "cpu_ms": k.cpu_ms / frames,
                    "balance": k.balance,
                }
            )
        return sorted(rows, key=lambda r: -float(r["wall_ms"]))
