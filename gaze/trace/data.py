"""Raw trace samples as read from a file, validated and re-based to the first sample."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaze.errors import GazeError

#: Samples whose confidence is below this are treated as invalid (Pupil Labs' advice).
DEFAULT_MIN_CONFIDENCE = 0.6
#: Points further than this (a share of the screen) beyond an edge are outliers: invalid.
OUTSIDE_MARGIN = 0.25
#: Invalid-sample reasons that every format shares (format flags come first).
NO_POINT = "no gaze point"
BAD_CONFIDENCE = "confidence not a number in [0, 1]"
OUTSIDE = "outside the screen"
FLAGGED = "flagged invalid"


@dataclass(frozen=True)
class TraceData:
    """Gaze samples of one recording.

    ``t`` is in seconds from the first sample (strictly increasing); ``x, y`` are
    normalised top-left; ``valid`` already excludes empty cells, off-surface rows and
    samples below the minimum confidence and points far outside the screen.  Invalid
    samples carry no measurement: their ``x, y`` are NaN and their ``confidence`` is 0.
    ``recording`` is the recording id (None for a file without a recording column);
    ``skipped`` counts the file's rows that are not samples, ``invalid`` the invalid
    samples, each by reason; ``notes`` say what the reader took from elsewhere.
    """

    path: str
    format: str
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    confidence: np.ndarray
    valid: np.ndarray
    recording: str | None = None
    skipped: Mapping[str, int] = field(default_factory=dict)
    invalid: Mapping[str, int] = field(default_factory=dict)
    notes: Mapping[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last sample."""
        return float(self.t[-1] - self.t[0]) if len(self) else 0.0


def invalid_reasons(
    flags: Mapping[str, np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    confidence: np.ndarray,
    min_confidence: float,
) -> tuple[np.ndarray, dict[str, int]]:
    """Which samples are valid, and the invalid ones counted by their first reason.

    In order: the file's own ``flags`` (reason -> mask), no point (empty cells), a
    confidence that is not a number in [0, 1] (NaN, infinite, negative or above 1: a
    broken export, never trusted), a confidence below ``min_confidence``, a point more
    than ``OUTSIDE_MARGIN`` of the screen beyond an edge.
    """
    with np.errstate(invalid="ignore"):
        outside = (np.abs(x - 0.5) > 0.5 + OUTSIDE_MARGIN) | (np.abs(y - 0.5) > 0.5 + OUTSIDE_MARGIN)
        bad = ~((confidence >= 0.0) & (confidence <= 1.0))
        low = ~(confidence >= min_confidence)
    checks = [
        *flags.items(),
        (NO_POINT, ~(np.isfinite(x) & np.isfinite(y))),
        (BAD_CONFIDENCE, bad),
        (f"below confidence {min_confidence:g}", low),
        (OUTSIDE, outside),
    ]
    invalid = np.zeros(x.shape, bool)
    counts: dict[str, int] = {}
    for reason, mask in checks:
        new = np.asarray(mask, bool) & ~invalid
        if new.any():
            counts[reason] = counts.get(reason, 0) + int(new.sum())
        invalid |= new
    return ~invalid, counts


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
    *,
    flags: Mapping[str, np.ndarray] | None = None,
    skipped: Mapping[str, int] | None = None,
    recording: str | None = None,
    notes: Mapping[str, str] | None = None,
) -> TraceData:
    """Validate raw columns (times in seconds) and build a ``TraceData``.

    ``usable`` marks rows the format itself considers measured, ``flags`` (reason ->
    mask) the rows it marks as not measured and why (a row that either marks is
    invalid; the named reason is the one counted); ``lines`` holds each row's line
    number in the file, for error messages.  Raises ``GazeError`` for an empty trace,
    missing/unsorted/duplicate timestamps, or no valid sample at all.
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
    valid, invalid = invalid_reasons(
        {**(flags or {}), FLAGGED: ~np.asarray(usable, bool)}, x, y, confidence, min_confidence
    )
    if not valid.any():
        raise GazeError(
            where,
            f"no valid samples (all empty, flagged invalid, below confidence {min_confidence} or outside the screen)",
        )
    x = np.where(valid, x, np.nan)
    y = np.where(valid, y, np.nan)
    confidence = np.where(valid, confidence, 0.0)
    return TraceData(
        where, fmt, t - t[0], x, y, confidence, valid, recording, dict(skipped or {}), invalid, dict(notes or {})
    )
