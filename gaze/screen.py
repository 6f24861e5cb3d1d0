"""Screen geometry: pixel size, physical width and viewing distance, and visual angles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaze.errors import GazeError


@dataclass(frozen=True)
class ScreenGeometry:
    """A flat screen seen by an eye on the axis through its centre.

    Pixels are square, so the physical height is ``width_cm * height_px / width_px``.
    The defaults are a 24" 16:9 monitor (1920x1080, 53 cm wide) seen from 60 cm.
    """

    width_px: int = 1920
    height_px: int = 1080
    width_cm: float = 53.0
    distance_cm: float = 60.0

    def __post_init__(self) -> None:
        if self.width_px <= 0 or self.height_px <= 0 or self.width_cm <= 0 or self.distance_cm <= 0:
            raise GazeError("screen", f"sizes and distance must be positive, got {self}")

    @property
    def height_cm(self) -> float:
        """Physical height from the width and the pixel aspect."""
        return self.width_cm * self.height_px / self.width_px

    def to_cm(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised top-left points to centimetres from the screen centre (x right, y down)."""
        return (np.asarray(x, float) - 0.5) * self.width_cm, (np.asarray(y, float) - 0.5) * self.height_cm

    def angle_deg(self, x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> np.ndarray:
        """Visual angle in degrees between normalised screen points (x0, y0) and (x1, y1)."""
        ax, ay = self.to_cm(x0, y0)
        bx, by = self.to_cm(x1, y1)
        d = self.distance_cm
        cross = np.sqrt((ay * d - d * by) ** 2 + (d * bx - ax * d) ** 2 + (ax * by - ay * bx) ** 2)
        dot = ax * bx + ay * by + d * d
        return np.degrees(np.arctan2(cross, dot))

    def with_pixels(self, width_px: int, height_px: int) -> ScreenGeometry:
        """The same monitor width and distance at another pixel size."""
        return ScreenGeometry(width_px, height_px, self.width_cm, self.distance_cm)


def parse_screen_size(text: str, where: str = "screen") -> tuple[int, int]:
    """Parse ``WxH`` (e.g. ``1920x1080``) into positive integer pixels."""
    parts = text.lower().split("x")
    try:
        w, h = (int(p) for p in parts)
    except ValueError:
        raise GazeError(where, f"screen size must look like 1920x1080, got {text!r}") from None
    if w <= 0 or h <= 0:
        raise GazeError(where, f"screen size must be positive, got {text!r}")
    return w, h
