"""How an image is seen: the screen it fills, the viewing distance, and visual angles.

The defaults are the gaze package's screen (``gaze.screen.ScreenGeometry``: a 1920 px
wide, 53 cm wide monitor seen from 60 cm), so the metrics and the gaze trackers assume
one viewer.  An image of any size is shown scaled across the full screen width with
square pixels, so its physical height is ``screen_width_m * H / W``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gaze.screen import ScreenGeometry

_GAZE_SCREEN = ScreenGeometry()
_CM_PER_M = 100.0


@dataclass(frozen=True)
class ViewingSetup:
    """A flat screen ``screen_width_m`` wide with ``screen_width_px`` pixels across,
    seen from ``distance_m`` by an eye on the axis through the screen centre."""

    screen_width_px: int = _GAZE_SCREEN.width_px
    screen_width_m: float = _GAZE_SCREEN.width_cm / _CM_PER_M
    distance_m: float = _GAZE_SCREEN.distance_cm / _CM_PER_M

    def __post_init__(self) -> None:
        """Refuse sizes and distances that are not finite and positive."""
        values = (self.screen_width_px, self.screen_width_m, self.distance_m)
        if not all(math.isfinite(v) and v > 0 for v in values):
            raise ValueError(f"viewing set-up sizes and distance must be finite and positive, got {self}")

    def pixels_per_degree(self, image_width_px: int) -> float:
        """Pixels of an ``image_width_px`` wide image per degree of visual angle.

        FLIP's own definition (its ``vc`` viewing conditions, Andersson et al. 2020):
        ``ppd = distance_m * (image_width_px / screen_width_m) * pi / 180``, i.e. pixels
        per metre on the screen times the metres one degree spans at the distance.  It is
        the exact density at the screen centre (the small-angle limit); towards the
        edges a degree spans more pixels.  ``screen_width_px`` cancels, because the
        image is scaled to the screen width: this is ``image_width_px /
        screen_width_px`` times the screen's own pixels per degree.
        """
        if image_width_px <= 0:
            raise ValueError(f"image width must be positive, got {image_width_px}")
        return self.distance_m * (image_width_px / self.screen_width_m) * math.pi / 180.0

    def eccentricity_deg(self, shape: tuple[int, ...], gaze: tuple[float, float]) -> np.ndarray:
        """(H, W) float64: the visual angle in degrees between the line of sight to the
        gaze point and the line of sight to each pixel centre of an ``(H, W, ...)`` image.

        Pixel (i, j) (column, row; row 0 at the top) is at ``((i + 0.5) / W, (j + 0.5) /
        H)`` on the screen and ``gaze`` is normalised to [0, 1]^2, origin top-left (not
        clamped).  The angle is exact for the flat screen (``ScreenGeometry.angle_deg``:
        the angle between the two rays from the eye); when the gaze is at the screen
        centre it equals ``atan(r / distance_m)`` of the on-screen distance ``r``.
        """
        height, width = int(shape[0]), int(shape[1])
        if height <= 0 or width <= 0:
            raise ValueError(f"image shape must be positive, got {tuple(shape)}")
        gx, gy = (float(v) for v in gaze)
        if not (math.isfinite(gx) and math.isfinite(gy)):
            raise ValueError(f"gaze must be finite, got {gaze!r}")
        screen = ScreenGeometry(width, height, self.screen_width_m * _CM_PER_M, self.distance_m * _CM_PER_M)
        x = (np.arange(width, dtype=np.float64) + 0.5) / width
        y = (np.arange(height, dtype=np.float64) + 0.5) / height
        return screen.angle_deg(gx, gy, x[None, :], y[:, None])
