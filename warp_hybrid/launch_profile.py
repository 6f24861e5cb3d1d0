"""A per-launch profile of the launch layer (``Launcher.profile``): what each kernel and
each host thread spent, so every speed claim names the kernel it moved.

While a ``LaunchProfile`` is attached, every piece a ``Launcher`` runs (one ``wp.launch``
of a kernel on one host thread, or one ``run`` piece) is timed on its own thread with
``time.perf_counter`` (after a device sync on CUDA, so the time covers the work).
Profiling adds a clock reading per piece and nothing else; without a profile the
launch layer reads no clock.
"""

from __future__ import annotations

import threading
import time
from collections import defaultdict
from dataclasses import dataclass, field


@dataclass
class KernelTimes:
    """One kernel's (or run piece's) launches and time, in total and per piece index."""

    launches: int = 0
    ms: float = 0.0
    piece_ms: dict[int, float] = field(default_factory=lambda: defaultdict(float))

    @property
    def balance(self) -> float:
        """Mean over the busiest piece's time (1: perfectly balanced threads)."""
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

    def record(self, name: str, piece: int, seconds: float) -> None:
        """Add one piece of one launch of ``name`` (thread-safe)."""
        with self._lock:
            k = self.kernels[name]
            k.ms += seconds * 1000.0
            k.piece_ms[piece] += seconds * 1000.0
            if piece == 0:
                k.launches += 1

    def timed(self, name: str, piece: int, fn, *args) -> object:
        """Call ``fn(*args)`` and record its time as ``name``'s piece ``piece``."""
        start = time.perf_counter()
        result = fn(*args)
        self.record(name, piece, time.perf_counter() - start)
        return result

    def rows(self, frames: int = 1) -> list[dict[str, float | str]]:
        """Per kernel, slowest first: launches and ms per frame (the busiest thread's
        ms: the wall time it adds), CPU ms over all threads, thread balance."""
        rows = []
        for name, k in self.kernels.items():
            busiest = max(k.piece_ms.values()) if k.piece_ms else 0.0
            rows.append(
                {
                    "kernel": name,
                    "launches": k.launches / frames,
                    "wall_ms": busiest / frames,
                    "cpu_ms": k.ms / frames,
                    "balance": k.balance,
                }
            )
        return sorted(rows, key=lambda r: -float(r["wall_ms"]))
