"""Replaying a recorded trace as a gaze source: interpolation, blink hold and I-VT labels."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from gaze.errors import GazeError
from gaze.screen import ScreenGeometry
from gaze.source import FIXATION, UNKNOWN, GazeSample, GazeSource
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.detect import read_trace
from gaze.trace.ivt import DEFAULT_THRESHOLD_DEG_S, label_ivt


def hold_positions(data: TraceData, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each sample, the point to hold when the signal is lost there.

    That is the last valid fixation sample at or before it; failing that the last
    valid sample; before the first valid sample, the first valid sample.
    """
    n = len(data)
    idx = np.arange(n)
    fix = data.valid & (labels == FIXATION)
    last_fix = np.maximum.accumulate(np.where(fix, idx, -1))
    last_valid = np.maximum.accumulate(np.where(data.valid, idx, -1))
    first_valid = int(np.argmax(data.valid))
    source = np.where(last_fix >= 0, last_fix, np.where(last_valid >= 0, last_valid, first_valid))
    return data.x[source], data.y[source]


class TraceSource(GazeSource):
    """A recorded trace played back on its own clock (``t`` = seconds from the first sample).

    Between two valid samples the point is interpolated linearly; where either is
    invalid (blink, track loss, low confidence) the last valid fixation is held and
    the sample is marked invalid.  Before the start and after the end the first/last
    sample is held.  Points are clamped to [0, 1]^2; labels come from I-VT.
    """

    def __init__(
        self,
        data: TraceData,
        screen: ScreenGeometry | None = None,
        threshold_deg_s: float = DEFAULT_THRESHOLD_DEG_S,
    ) -> None:
        self.data = data
        self.screen = screen or ScreenGeometry()
        self.labels = label_ivt(data.t, data.x, data.y, data.valid, self.screen, threshold_deg_s)
        self.hold_x, self.hold_y = hold_positions(data, self.labels)

    @classmethod
    def from_file(
        cls,
        path: str | Path,
        fmt: str | None = None,
        screen: ScreenGeometry | None = None,
        screen_px: tuple[int, int] | None = None,
        min_confidence: float = DEFAULT_MIN_CONFIDENCE,
        threshold_deg_s: float = DEFAULT_THRESHOLD_DEG_S,
        recording: str | None = None,
    ) -> TraceSource:
        """Read a trace file (any supported format) and wrap it.

        ``screen_px`` gives the pixel size of pixel coordinates in the file; ``screen``
        (default: the standard monitor at ``screen_px``) is the geometry for I-VT;
        ``recording`` picks one recording of a file that joins several.
        """
        data = read_trace(path, fmt, screen_px, min_confidence, recording)
        if screen is None and screen_px is not None:
            screen = ScreenGeometry().with_pixels(*screen_px)
        return cls(data, screen, threshold_deg_s)

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample."""
        return self.data.duration

    def _at_index(self, i: int, t: float) -> GazeSample:
        d = self.data
        if d.valid[i]:
            return _clamped(d.x[i], d.y[i], t, d.confidence[i], True, self.labels[i])
        return _clamped(self.hold_x[i], self.hold_y[i], t, 0.0, False, UNKNOWN)

    def sample(self, t: float) -> GazeSample:
        """The gaze at ``t`` seconds from the first sample (a non-finite ``t`` is a ``GazeError``)."""
        d = self.data
        if not math.isfinite(t):
            raise GazeError(d.path, f"sample time must be finite, got {t!r}")
        if t <= d.t[0]:
            return self._at_index(0, t)
        if t >= d.t[-1]:
            return self._at_index(len(d) - 1, t)
        i = int(np.searchsorted(d.t, t, side="right")) - 1
        f = (t - d.t[i]) / (d.t[i + 1] - d.t[i])
        if f == 0.0:
            return self._at_index(i, t)
        if not (d.valid[i] and d.valid[i + 1]):
            return _clamped(self.hold_x[i], self.hold_y[i], t, 0.0, False, UNKNOWN)
        x = d.x[i] + f * (d.x[i + 1] - d.x[i])
        y = d.y[i] + f * (d.y[i + 1] - d.y[i])
        confidence = d.confidence[i] + f * (d.confidence[i + 1] - d.confidence[i])
        label = self.labels[i] if f < 0.5 else self.labels[i + 1]
        return _clamped(x, y, t, confidence, True, label)


def _clamped(x: float, y: float, t: float, confidence: float, valid: bool, label: str) -> GazeSample:
    """A sample with its point clamped to [0, 1]^2."""
    return GazeSample(
        float(min(max(x, 0.0), 1.0)), float(min(max(y, 0.0), 1.0)), float(t), float(confidence), bool(valid), str(label)
    )
