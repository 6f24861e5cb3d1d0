"""The simple CSV trace format: ``t,x,y[,confidence]``, one sample per row.

``t`` is in seconds (or in the unit its header names: ``t [ms]``); ``x, y`` are
normalised with the origin at the top-left, or pixels of a screen whose size the caller
gives (whenever the caller gives one, and required when the header says ``x [px]``).
Empty ``x``/``y`` cells mark invalid samples (blinks, track loss); an empty or missing
``confidence`` is 1, and, as for every format, a sample whose confidence is not a number
in [0, 1] (``nan``, ``inf``, ``7``) or is below the reader's minimum (default 0.6) is
invalid, counted by its reason.  The writer always
emits the header ``t,x,y,confidence`` and writes invalid rows as ``t,,,0``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaze.atomic import write_atomic
from gaze.errors import GazeError
from gaze.trace.columns import split_unit, time_unit
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.reader import TraceFormat, read_with
from gaze.trace.samples import Samples, pixel_note, pixel_size
from gaze.trace.text import TraceText

FORMAT = "simple"
HEADER = ["t", "x", "y"]
#: Normalised values beyond this magnitude are taken as pixels given by mistake.
PIXEL_SUSPICION = 2.0


def is_simple_header(header: list[str]) -> bool:
    """True for ``t,x,y`` or ``t,x,y,confidence`` (case-insensitive, each with an optional unit suffix)."""
    names = [split_unit(h)[0] for h in header]
    return names in (HEADER, HEADER + ["confidence"])


def read_simple(
    path: str | Path,
    screen_px: tuple[int, int] | None = None,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
) -> TraceData:
    """Read a simple CSV trace; with ``screen_px=(W, H)`` the x, y columns are pixels."""
    return read_with(READER, path, screen_px, min_confidence).trace()


def simple_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a simple CSV.  ``t`` may carry a time unit (``t [ms]``, default seconds);
    ``x``/``y`` are pixels when their header says ``[px]`` or the caller gives a screen size."""
    table = text.table
    if not is_simple_header(table.header):
        raise GazeError(table.path, f"unknown columns {table.header}; the simple format is t,x,y[,confidence]")
    width = len(table.header)
    for row, line in zip(table.rows, table.lines):
        if any(cell.strip() for cell in row[width:]):
            raise GazeError(table.path, f"line {int(line)}: {len(row)} cells but the header names {width} columns")
    t = table.times(0, time_unit(table.path, table.header[0], default="s"))
    x, y = table.floats(1), table.floats(2)
    confidence = np.ones_like(t)
    if width == 4:  # an empty cell means full confidence; a written NaN is a bad value
        given = np.array([bool(cell) for cell in table.cells(3)], dtype=bool)
        confidence = np.where(given, table.floats(3), 1.0)
    notes: dict[str, str] = {}
    if screen_px is not None or any((split_unit(h)[1] or "").lower() == "px" for h in table.header[1:3]):
        size, source = pixel_size(table.path, screen_px, None, "the screen")
        x, y = x / size[0], y / size[1]
        notes = pixel_note(size, source, "the screen")
    else:
        biggest = float(np.nanmax(np.abs(np.concatenate([x, y])), initial=0.0))
        if biggest > PIXEL_SUSPICION:
            raise GazeError(
                table.path,
                f"coordinates up to {biggest:g} look like pixels; give the screen size (screen=WxH / --screen WxH)",
            )
    return Samples(t, x, y, table.lines, confidence, notes=notes)


READER = TraceFormat(
    FORMAT,
    "simple CSV",
    "t,x,y[,confidence]",
    lambda text: is_simple_header(text.labels),
    simple_samples,
)


def _check_samples(
    where: str, t: np.ndarray, x: np.ndarray, y: np.ndarray, confidence: np.ndarray, valid: np.ndarray
) -> None:
    """Refuse samples that the reader could not read back."""
    if not (t.shape == x.shape == y.shape == confidence.shape == valid.shape) or t.ndim != 1:
        raise GazeError(where, "t, x, y, confidence and valid must be 1-D arrays of one length")
    if not np.isfinite(t).all():
        raise GazeError(where, "timestamps must be finite")
    if (np.diff(np.round(t, 6)) <= 0).any():
        raise GazeError(where, "timestamps must be strictly increasing, at least 1 us apart")
    measured = np.isfinite(x) & np.isfinite(y) & np.isfinite(confidence)
    if (valid & ~measured).any():
        raise GazeError(where, f"valid sample {int(np.argmax(valid & ~measured))} has a non-finite x, y or confidence")


def format_simple(
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    confidence: np.ndarray,
    valid: np.ndarray,
    screen_px: tuple[int, int] | None = None,
    where: str = "simple CSV",
) -> str:
    """The simple CSV text: header ``t,x,y,confidence``, one row per sample.

    ``t`` is written as given (seconds; readers re-base it to the first sample);
    invalid rows are ``t,,,0``.  With ``screen_px`` the coordinates are written in
    pixels, otherwise normalised (origin top-left).  Times are written to 1 us,
    normalised coordinates to 1e-6, pixels to 0.01 px, confidences to 1e-4.
    Samples the reader could not read back (unsorted or non-finite times, a valid
    sample without a point) are a ``GazeError`` naming ``where``.
    """
    t, x, y, confidence = (np.asarray(a, dtype=float) for a in (t, x, y, confidence))
    valid = np.asarray(valid, dtype=bool)
    _check_samples(where, t, x, y, confidence, valid)
    lines = ["t,x,y,confidence"]
    for ti, xi, yi, ci, vi in zip(t, x, y, confidence, valid):
        if not vi:
            lines.append(f"{ti:.6f},,,0")
        elif screen_px is not None:
            lines.append(f"{ti:.6f},{xi * screen_px[0]:.2f},{yi * screen_px[1]:.2f},{ci:.4f}")
        else:
            lines.append(f"{ti:.6f},{xi:.6f},{yi:.6f},{ci:.4f}")
    return "\n".join(lines) + "\n"


def write_simple(
    path: str | Path,
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    confidence: np.ndarray,
    valid: np.ndarray,
    screen_px: tuple[int, int] | None = None,
) -> None:
    """Write a simple CSV trace atomically (see ``format_simple``)."""
    write_atomic(path, format_simple(t, x, y, confidence, valid, screen_px, where=str(path)))


def write_trace(path: str | Path, data: TraceData, screen_px: tuple[int, int] | None = None) -> None:
    """Write a trace read from any format as a simple CSV (times from its first sample)."""
    write_simple(path, data.t, data.x, data.y, data.confidence, data.valid, screen_px)
