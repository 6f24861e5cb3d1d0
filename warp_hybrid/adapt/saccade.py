"""Where a saccade in flight will land: the window's place while vision is suppressed.

During a saccade (the gaze source's I-VT label) the eye sees next to nothing (saccadic
suppression), so a window traced at the gaze is wasted; the frame that matters is the
one on screen when the eye lands.  ``SaccadePredictor`` takes the tracker's samples in
time order and, while a saccade is in flight, predicts its landing point:

- direction: the unit displacement from the saccade's onset (the last sample before
  the run of saccade samples) to the latest sample, on the screen;
- amplitude: from the peak angular speed so far by the main sequence, peak velocity
  ``V = v_max (1 - exp(-A / c))`` (the exponential form of Baloh et al. 1975, Neurology
  25:1065), inverted: ``A = -c ln(1 - V / v_max)``, with ``v_max = 600 deg/s`` and
  ``c = 6 deg``, the constants of Dai, Selesnick, Rizzo, Rucker and Hudson's parametric
  saccade model (IEEE SPMB 2016, doi:10.1109/SPMB.2016.7846860).  The speed saturates
  towards ``v_max`` for large saccades, where a small error in the speed is a large one
  in the amplitude: ``V / v_max`` is capped at ``max_share`` (0.95: at most 18 deg).
  Before the peak the speed so far is a lower bound of the peak, so the same inversion
  is a conservative (short) amplitude; the prediction is never behind the eye (at least
  the angle covered so far);
- the point that far from the onset along the direction (exact visual angle on the
  flat screen, ``offset_by_angle``), cut back along the line to the screen.

Pure numpy and deterministic: no clock, only the samples' own times.  Speeds from a
tracker's discrete samples underestimate the true peak (a chord over one interval),
the more the slower the tracker, so predictions from a 60 Hz tracker land short.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gaze.screen import ScreenGeometry
from gaze.source import SACCADE, GazeSample

from ..errors import RenderSettingsError


@dataclass(frozen=True)
class MainSequence:
    """Peak angular speed of a saccade against its amplitude: ``v_max (1 - exp(-A / c))``.

    ``v_max_deg_s``: the asymptotic peak speed (deg/s); ``c_deg``: the amplitude scale
    (deg); ``max_share``: the largest ``V / v_max`` the inversion trusts (module notes).
    """

    v_max_deg_s: float = 600.0
    c_deg: float = 6.0
    max_share: float = 0.95

    def __post_init__(self) -> None:
        if not (
            math.isfinite(self.v_max_deg_s) and self.v_max_deg_s > 0 and math.isfinite(self.c_deg) and self.c_deg > 0
        ):
            raise RenderSettingsError(f"main sequence v_max and c must be finite and positive, got {self}")
        if not 0.0 < self.max_share < 1.0:
            raise RenderSettingsError(f"main sequence max_share must be in (0, 1), got {self.max_share}")

    def peak_speed(self, amplitude_deg: float) -> float:
        """The peak angular speed (deg/s) of a saccade of ``amplitude_deg``."""
        return self.v_max_deg_s * (1.0 - math.exp(-amplitude_deg / self.c_deg))

    def amplitude(self, peak_speed_deg_s: float) -> float:
        """The amplitude (deg) whose peak speed is ``peak_speed_deg_s`` (the inverse,
        ``V / v_max`` capped at ``max_share``)."""
        share = min(max(peak_speed_deg_s / self.v_max_deg_s, 0.0), self.max_share)
        return -self.c_deg * math.log1p(-share)


@dataclass(frozen=True)
class Landing:
    """A predicted landing point: ``x, y`` normalised (origin top-left, on the screen),
    ``amplitude_deg`` the predicted angle from the onset, ``peak_passed`` whether the
    speed has fallen from its peak (else the amplitude is a lower bound)."""

    x: float
    y: float
    amplitude_deg: float
    peak_passed: bool

    @property
    def point(self) -> tuple[float, float]:
        """``(x, y)``."""
        return (self.x, self.y)


def offset_by_angle(
    screen: ScreenGeometry, start: tuple[float, float], direction: tuple[float, float], angle_deg: float
) -> tuple[float, float]:
    """The screen point ``angle_deg`` of visual angle from ``start`` along the on-screen
    ``direction`` (normalised units; both top-left), cut back along that line to the
    screen [0, 1]^2.

    The eye sees ``start`` along ``v0`` (screen centre on its axis, ``distance_cm`` away);
    the points of the line through ``start`` along ``direction`` are seen in the plane of
    ``v0`` and that direction, so the ray turned by ``angle_deg`` in that plane, met with
    the screen plane, is the point (``ScreenGeometry.angle_deg`` of the two is the angle).
    """
    ax, ay = (float(v) for v in screen.to_cm(start[0], start[1]))
    ux, uy = direction[0] * screen.width_cm, direction[1] * screen.height_cm
    norm = math.hypot(ux, uy)
    if norm == 0.0 or angle_deg <= 0.0:
        return _on_screen(start, start)
    v0 = np.array([ax, ay, screen.distance_cm])
    v0 /= np.linalg.norm(v0)
    u = np.array([ux / norm, uy / norm, 0.0])
    w = u - float(u @ v0) * v0
    w /= np.linalg.norm(w)
    theta = math.radians(angle_deg)
    ray = math.cos(theta) * v0 + math.sin(theta) * w
    if ray[2] <= 1e-9:  # at or past the screen plane's horizon: as far along the line as the screen goes
        far = (start[0] + direction[0] / norm * 1e6, start[1] + direction[1] / norm * 1e6)
        return _on_screen(start, far)
    hit = ray * (screen.distance_cm / ray[2])
    return _on_screen(start, (hit[0] / screen.width_cm + 0.5, hit[1] / screen.height_cm + 0.5))


def _on_screen(start: tuple[float, float], end: tuple[float, float]) -> tuple[float, float]:
    """``end``, or where the segment from ``start`` (on the screen) to it leaves [0, 1]^2."""
    s = 1.0
    for a, b in zip(start, end):
        if b > 1.0:
            s = min(s, (1.0 - a) / (b - a))
        elif b < 0.0:
            s = min(s, a / (a - b))
    s = max(s, 0.0)
    x, y = (a + s * (b - a) for a, b in zip(start, end))
    return (min(max(x, 0.0), 1.0), min(max(y, 0.0), 1.0))


class SaccadePredictor:
    """Predicts the landing point of the saccade in flight from the tracker's samples
    (module notes).

    ``add`` the samples in time order (a sample not later than the last is ignored, an
    invalid one forgets the saccade); ``landing`` answers while the latest sample is
    labelled a saccade and it has moved from the onset, else None.  ``screen`` is the
    geometry of the angles (the one the source's I-VT labels used).
    """

    def __init__(self, screen: ScreenGeometry | None = None, main_sequence: MainSequence | None = None) -> None:
        self.screen = screen or ScreenGeometry()
        self.main_sequence = main_sequence or MainSequence()
        self._last: GazeSample | None = None
        self._run: list[GazeSample] = []  # the onset sample, then the saccade samples since

    def reset(self) -> None:
        """Forget every sample."""
        self._last = None
        self._run = []

    def add(self, sample: GazeSample) -> None:
        """One tracker sample, later than the last one added."""
        if self._last is not None and sample.t <= self._last.t:
            return
        if not sample.valid:
            self.reset()
            return
        if sample.label == SACCADE:
            if not self._run and self._last is not None:
                self._run = [self._last]  # the onset; without one, the first saccade sample is it
            self._run.append(sample)
        else:
            self._run = []
        self._last = sample

    def landing(self) -> Landing | None:
        """Where the saccade in flight lands, or None (none in flight, or no movement yet)."""
        if len(self._run) < 2:
            return None
        t = np.array([s.t for s in self._run])
        x = np.array([s.x for s in self._run])
        y = np.array([s.y for s in self._run])
        onset, latest = (x[0], y[0]), (x[-1], y[-1])
        direction = (latest[0] - onset[0], latest[1] - onset[1])
        if direction == (0.0, 0.0):
            return None
        speeds = self.screen.angle_deg(x[:-1], y[:-1], x[1:], y[1:]) / np.diff(t)
        peak = float(speeds.max())
        peak_passed = bool(speeds.size >= 2 and speeds[-1] < peak)
        covered = float(self.screen.angle_deg(onset[0], onset[1], latest[0], latest[1]))
        amplitude = max(covered, self.main_sequence.amplitude(peak))
        lx, ly = offset_by_angle(self.screen, onset, direction, amplitude)
        return Landing(lx, ly, amplitude, peak_passed)
