"""Per-stage timing with an injectable clock.

Every stage of a frame is timed through a ``StageTimer``; the clock is a plain
callable returning seconds so tests (and the future window controller) can inject a
fake one.  With a real clock, a Warp device is synchronised before each reading so the
time covers the launched work, not only its enqueueing.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

Clock = Callable[[], float]


def perf_clock() -> float:
    """The default clock: ``time.perf_counter`` in seconds."""
    return time.perf_counter()


@dataclass
class StageTimer:
    """Accumulates milliseconds per named stage for one frame.

    ``sync`` is called before each clock reading (pass ``wp.synchronize_device`` for
    a GPU device; on the CPU, launches are synchronous and it may be ``None``).
    """

    clock: Clock = perf_clock
    sync: Callable[[], None] | None = None
    stages_ms: dict[str, float] = field(default_factory=dict)

    def now(self) -> float:
        """The clock's reading in seconds, after the device finished its queued work."""
        if self.sync is not None:
            self.sync()
        return self.clock()

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the enclosed block and add it to ``stages_ms[name]``."""
        start = self.now()
        try:
            yield
        finally:
            elapsed = (self.now() - start) * 1000.0
            self.stages_ms[name] = self.stages_ms.get(name, 0.0) + elapsed

    def add(self, name: str, ms: float) -> None:
        """Add ``ms`` to ``stages_ms[name]`` (a stage measured by its caller)."""
        self.stages_ms[name] = self.stages_ms.get(name, 0.0) + ms

    @property
    def total_ms(self) -> float:
        """Sum over all stages."""
        return float(sum(self.stages_ms.values()))
