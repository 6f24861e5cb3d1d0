"""A gaze source that always looks at one point."""

from __future__ import annotations

import math

from gaze.errors import GazeError
from gaze.source import GazeSample, GazeSource


def point_problem(x: float, y: float) -> str | None:
    """The one rule for a gaze point someone gives (``--gaze X,Y``, ``fixed:X,Y``): both
    finite and in [0, 1] (normalised, origin top-left); what is wrong, or None.  A point
    outside is refused, never clamped (pixels given by mistake would look like a corner)."""
    if math.isfinite(x) and math.isfinite(y) and 0.0 <= x <= 1.0 and 0.0 <= y <= 1.0:
        return None
    return f"point must lie in [0,1]^2 (normalised, origin top-left), got ({x:g}, {y:g})"


class FixedSource(GazeSource):
    """Always returns the normalised point (x, y)."""

    def __init__(self, x: float, y: float) -> None:
        problem = point_problem(x, y)
        if problem is not None:
            raise GazeError("fixed", problem)
        self.x = float(x)
        self.y = float(y)

    def sample(self, t: float) -> GazeSample:
        """The fixed point, valid with full confidence."""
        return GazeSample(self.x, self.y, t)
