"""A gaze source fed with pointer positions by a user interface."""

from __future__ import annotations

import math
import threading

from gaze.errors import GazeError
from gaze.source import GazeSample, GazeSource, centre_sample


class CursorSource(GazeSource):
    """Holds the latest pointer position; thread-safe; screen centre until the first one arrives."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._position: tuple[float, float] | None = None

    def set_position(self, x: float, y: float) -> None:
        """Record the pointer at normalised (x, y), clamped to [0, 1]^2 (any thread).

        A non-finite coordinate is a ``GazeError``; the previous position is kept.
        """
        x, y = float(x), float(y)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise GazeError("cursor", f"pointer position must be finite, got ({x}, {y})")
        point = (min(max(x, 0.0), 1.0), min(max(y, 0.0), 1.0))
        with self._lock:
            self._position = point

    def set_pixel(self, px: float, py: float, width: int, height: int) -> None:
        """Record the pointer at pixel (px, py) of a ``width`` x ``height`` view."""
        if width <= 0 or height <= 0:
            raise GazeError("cursor", f"view size must be positive, got {width}x{height}")
        self.set_position(px / width, py / height)

    def sample(self, t: float) -> GazeSample:
        """The latest position (valid), or the centre (invalid) before any arrived."""
        with self._lock:
            position = self._position
        if position is None:
            return centre_sample(t)
        return GazeSample(position[0], position[1], t)
