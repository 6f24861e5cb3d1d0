"""The viewer's webcam calibration: 9 targets shown in turn on the page, then the fit.

The render thread feeds every frame's raw webcam sample (its eye feature) to
``CalibrationSession.collect`` with the wall clock; the session moves to the next of
the 9 targets (``gaze.webcam.synthetic.calibration_targets``: 10/50/90 % of the page)
every ``dwell_s`` and says so (the page draws it), and after the last one fits the
calibration with ``gaze.webcam.calibration.fit_calibration`` (frames in the first
``SETTLE_S`` after a target change ignored) on the same wall clock.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaze.source import GazeSample
from gaze.webcam.calibration import Calibration, TargetSchedule, fit_calibration
from gaze.webcam.synthetic import calibration_targets

#: Seconds each target is shown.
DWELL_S = 1.5


@dataclass(frozen=True)
class CalibrationStep:
    """What the page should show now: target ``index`` at normalised (x, y), or the end."""

    index: int
    x: float
    y: float


class CalibrationSession:
    """One run over the 9 targets, started at wall-clock ``start``."""

    def __init__(self, start: float, dwell_s: float = DWELL_S) -> None:
        targets = calibration_targets(dwell_s)
        self.schedule = TargetSchedule(start + targets[:, 0], targets[:, 1], targets[:, 2])
        self.end = start + len(targets) * dwell_s
        self._t: list[float] = []
        self._features: list[tuple[float, float]] = []
        self._last_sample_t: float | None = None
        self._shown = -1

    def collect(self, now: float, sample: GazeSample) -> CalibrationStep | None:
        """Keep ``sample``'s feature (once per webcam frame); returns the target to show
        when it changed since the last call."""
        if sample.t != self._last_sample_t:
            self._last_sample_t = sample.t
            self._t.append(now)
            self._features.append(sample.features if sample.features is not None else (np.nan, np.nan))
        index = int(self.schedule.index_at(np.array([now]))[0])
        if index == self._shown or index >= len(self.schedule.t) or now >= self.end:
            return None
        self._shown = index
        return CalibrationStep(index, float(self.schedule.x[index]), float(self.schedule.y[index]))

    def done(self, now: float) -> bool:
        """Every target has been shown for its time."""
        return now >= self.end

    def fit(self, where: str) -> Calibration:
        """The calibration from what was collected (``GazeError`` naming ``where`` when it cannot be fitted)."""
        features = np.array(self._features, dtype=float).reshape(-1, 2)
        valid = np.isfinite(features).all(axis=1)
        return fit_calibration(np.array(self._t), features, valid, self.schedule, where=where)

    def fit_and_save(self, path: Path) -> Calibration:
        """Fit and write the calibration file to ``path``."""
        calibration = self.fit(str(path))
        calibration.save(path)
        return calibration
