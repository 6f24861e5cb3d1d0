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
    #: The open stages, innermost last: each one's name and the milliseconds charged to
    #: other stages while it was open (``charge``).
    _open: list[list] = field(default_factory=list, repr=False)

    def now(self) -> float:
        """The clock's reading in seconds, after the device finished its queued work."""
        if self.sync is not None:
            self.sync()
        return self.clock()

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the enclosed block and add it to ``stages_ms[name]`` (less what was charged
        to other stages meanwhile, ``charge``)."""
        start = self.now()
        entry = [name, 0.0]
        self._open.append(entry)
        try:
            yield
        finally:
            self._open.pop()
            elapsed = (self.now() - start) * 1000.0 - entry[1]
            self.stages_ms[name] = self.stages_ms.get(name, 0.0) + elapsed
            if self._open:  # (an enclosing stage's time holds the charged time too)
                self._open[-1][1] += entry[1]

    @property
    def current(self) -> str | None:
        """The innermost open stage's name (None outside every stage)."""
        return self._open[-1][0] if self._open else None

    def charge(self, name: str, seconds: float) -> None:
        """Move ``seconds`` of the open stages' time to stage ``name``: work that stage
        started, which the innermost open stage waited for (a pass that ran on while the
        next stage's Python prepared the next, ``Launcher.overlapping``).  Outside every
        stage the time is only added to ``name``."""
        ms = seconds * 1000.0
        self.stages_ms[name] = self.stages_ms.get(name, 0.0) + ms
        if self._open:
            self._open[-1][1] += ms

    def add(self, name: str, ms: float) -> None:
        """Add ``ms`` to ``stages_ms[name]`` (a stage measured by its caller)."""
        self.stages_ms[name] = self.stages_ms.get(name, 0.0) + ms

    @property
    def total_ms(self) -> float:
        """Sum over all stages."""
        return float(sum(self.stages_ms.values()))
