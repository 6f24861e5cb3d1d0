"""Raw trace samples as read from a file, validated and re-based to the first sample."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaze.errors import GazeError

#: Samples whose confidence is below this are treated as invalid (Pupil Labs' advice).
DEFAULT_MIN_CONFIDENCE = 0.6


@dataclass(frozen=True)
class TraceData:
    """Gaze samples of one recording.

    ``t`` is in seconds from the first sample (strictly increasing); ``x, y`` are
    normalised top-left; ``valid`` already excludes empty cells, off-surface rows and
    samples below the minimum confidence.  Invalid samples carry no measurement: their
    ``x, y`` are NaN and their ``confidence`` is 0.
    """

    path: str
    format: str
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    confidence: np.ndarray
    valid: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample."""
        return float(self.t[-1] - self.t[0]) if len(self) else 0.0


def make_trace_data(
    path: str | Path,
    fmt: str,
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    confidence: np.ndarray,
    usable: np.ndarray,
    lines: np.ndarray,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
) -> TraceData:
    """Validate raw columns (times in seconds) and build a ``TraceData``.

    ``usable`` marks rows the format itself considers measured; ``lines`` holds each
    row's line number in the file, for error messages.  Raises ``GazeError`` for an
    empty trace, missing/unsorted/duplicate timestamps, or no valid sample at all.
    """
    where = str(path)
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        raise GazeError(where, "the trace holds no samples")
    bad_t = ~np.isfinite(t)
    if bad_t.any():
        raise GazeError(where, f"line {int(lines[np.argmax(bad_t)])}: missing or non-numeric timestamp")
    steps = np.diff(t)
    bad_steps = np.flatnonzero(steps <= 0)
    if bad_steps.size:
        k = int(bad_steps[0]) + 1
        now, before = float(t[k]), float(t[k - 1])
        if now == before:
            raise GazeError(where, f"line {int(lines[k])}: duplicate timestamp ({now!r} s)")
        raise GazeError(
            where, f"line {int(lines[k])}: timestamp {now!r} s is before the previous one, {before!r} s (unsorted)"
        )
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    confidence = np.asarray(confidence, dtype=float)
    valid = (
        np.asarray(usable, bool)
        & np.isfinite(x)
        & np.isfinite(y)
        & np.isfinite(confidence)
        & (np.nan_to_num(confidence) >= min_confidence)
    )
    if not valid.any():
        raise GazeError(where, f"no valid samples (all empty, off-surface or below confidence {min_confidence})")
    x = np.where(valid, x, np.nan)
    y = np.where(valid, y, np.nan)
    confidence = np.where(valid, confidence, 0.0)
    return TraceData(where, fmt, t - t[0], x, y, confidence, valid)
