"""A gaze source that always looks at one point."""

from __future__ import annotations

from gaze.errors import GazeError
from gaze.source import GazeSample, GazeSource


class FixedSource(GazeSource):
    """Always returns the normalised point (x, y)."""

    def __init__(self, x: float, y: float) -> None:
        if not (0.0 <= x <= 1.0 and 0.0 <= y <= 1.0):
            raise GazeError("fixed", f"point must lie in [0,1]^2, got ({x}, {y})")
        self.x = float(x)
        self.y = float(y)

    def sample(self, t: float) -> GazeSample:
        """The fixed point, valid with full confidence."""
        return GazeSample(self.x, self.y, t)
