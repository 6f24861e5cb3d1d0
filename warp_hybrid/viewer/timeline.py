"""Scene time for a live viewer: plays in real time, loops over the stage's range, pauses, seeks."""

from __future__ import annotations

from ..scene.usd.stage import StageInfo


def stage_duration(info: StageInfo) -> float:
    """Seconds the stage's time range spans (0 for a still scene)."""
    if info.time_range is None:
        return 0.0
    start, end = info.time_range
    return max(0.0, (end - start) / info.time_codes_per_second)


class Timeline:
    """Seconds from the start of the stage's time range, driven by a wall clock."""

    def __init__(self, duration: float, now: float, playing: bool = True) -> None:
        """A timeline of ``duration`` seconds at 0, playing (if it has any length) from ``now``."""
        self.duration = max(0.0, float(duration))
        self.playing = playing and self.duration > 0.0
        self._t = 0.0
        self._wall = now

    @property
    def animated(self) -> bool:
        """The scene changes over time."""
        return self.duration > 0.0

    def time(self, now: float) -> float:
        """The scene time at wall-clock ``now`` (looping over the range while playing)."""
        if self.playing:
            self._t = (self._t + max(0.0, now - self._wall)) % self.duration
        self._wall = now
        return self._t

    def play(self, playing: bool, now: float) -> None:
        """Play or pause from ``now`` (a still scene never plays)."""
        self.time(now)
        self.playing = playing and self.animated

    def seek(self, t: float, now: float) -> None:
        """Show time ``t`` (clamped to the range) from ``now``."""
        self.time(now)
        self._t = min(max(float(t), 0.0), self.duration)
