"""The One Euro filter (Casiez, Roussel and Vogel, CHI 2012) for noisy gaze points."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gaze.errors import GazeError


def smoothing_factor(cutoff_hz: float, dt: float) -> float:
    """Exponential smoothing factor of a first-order low-pass at ``cutoff_hz`` for step ``dt``."""
    tau = 1.0 / (2.0 * math.pi * cutoff_hz)
    return 1.0 / (1.0 + tau / dt)


@dataclass
class OneEuroFilter:
    """Speed-adaptive low-pass filter on a vector signal.

    The cutoff is ``min_cutoff + beta * |dx/dt|`` (Hz), where the speed is itself
    low-passed at ``d_cutoff``: slow movements (fixation noise) are smoothed hard,
    fast ones (saccades) pass with little lag.  Units of ``beta`` are 1/(signal unit);
    the defaults suit normalised screen coordinates at 15-120 Hz.
    """

    min_cutoff: float = 1.0
    beta: float = 1.0
    d_cutoff: float = 1.0

    def __post_init__(self) -> None:
        if self.min_cutoff <= 0 or self.d_cutoff <= 0 or self.beta < 0:
            raise GazeError("one euro filter", f"need min_cutoff > 0, d_cutoff > 0, beta >= 0, got {self}")
        self.reset()

    def reset(self) -> None:
        """Forget the history; the next value passes unfiltered."""
        self._t: float | None = None
        self._x: np.ndarray | None = None
        self._dx: np.ndarray | None = None

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        """Filter value ``x`` observed at time ``t`` (seconds); returns the smoothed value.

        A time that does not advance returns the previous output unchanged.
        """
        x = np.asarray(x, dtype=float)
        if self._t is None or self._x is None or self._dx is None:
            self._t, self._x, self._dx = t, x.copy(), np.zeros_like(x)
            return x.copy()
        dt = t - self._t
        if dt <= 0.0:
            return self._x.copy()
        a_d = smoothing_factor(self.d_cutoff, dt)
        self._dx = self._dx + a_d * ((x - self._x) / dt - self._dx)
        cutoff = self.min_cutoff + self.beta * float(np.linalg.norm(self._dx))
        a = smoothing_factor(cutoff, dt)
        self._x = self._x + a * (x - self._x)
        self._t = t
        return self._x.copy()
