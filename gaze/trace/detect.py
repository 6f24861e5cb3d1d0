"""Trace format detection from the header, and one entry point that reads any format."""

from __future__ import annotations

import csv
from pathlib import Path

from gaze.errors import GazeError
from gaze.trace import pupil, simple_csv, tobii
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.table import open_text, parse_table

FORMATS = (simple_csv.FORMAT, pupil.GAZE_FORMAT, pupil.SURFACE_FORMAT, tobii.FORMAT)
#: Column delimiter of each format.
DELIMITERS = {simple_csv.FORMAT: ",", pupil.GAZE_FORMAT: ",", pupil.SURFACE_FORMAT: ",", tobii.FORMAT: "\t"}


def format_from_header(path: str | Path, first_line: str) -> str:
    """The format name (one of ``FORMATS``) that the header line ``first_line`` of ``path`` announces."""
    if "\t" in first_line:
        header = [cell.strip() for cell in first_line.split("\t")]
        if tobii.is_tobii_header(header):
            return tobii.FORMAT
    else:
        header = [cell.strip() for cell in next(csv.reader([first_line]))]
        names = set(header)
        if set(pupil.SURFACE_COLUMNS) <= names:
            return pupil.SURFACE_FORMAT
        if set(pupil.GAZE_COLUMNS) <= names:
            return pupil.GAZE_FORMAT
        if simple_csv.is_simple_header(header):
            return simple_csv.FORMAT
    raise GazeError(
        str(path),
        f"unknown columns {header}; expected a simple CSV (t,x,y[,confidence]), a Pupil Labs export "
        f"({','.join(pupil.GAZE_COLUMNS)} or {','.join(pupil.SURFACE_COLUMNS)}) "
        "or a Tobii Pro Lab TSV export (Recording timestamp [unit], Gaze point X, Gaze point Y)",
    )


def _first_line(text: str) -> str:
    return text.lstrip().splitlines()[0]


def detect_format(path: str | Path) -> str:
    """The format name of a trace file (one of ``FORMATS``), judged from its first line."""
    return format_from_header(path, _first_line(open_text(path)))


def check_format(fmt: str, where: str) -> str:
    """``fmt`` itself when it names a supported format, else a ``GazeError`` naming ``where``."""
    if fmt not in FORMATS:
        raise GazeError(where, f"unknown trace format {fmt!r}; choose one of {', '.join(FORMATS)}")
    return fmt


def read_trace(
    path: str | Path,
    fmt: str | None = None,
    screen_px: tuple[int, int] | None = None,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
) -> TraceData:
    """Read a trace in format ``fmt`` (detected from the header when None).

    ``screen_px`` is the pixel size for pixel coordinates (simple CSV in pixels, Tobii
    without resolution columns); ``min_confidence`` applies to formats with confidences.
    """
    if fmt is not None:
        check_format(fmt, str(path))
    if screen_px is not None and (screen_px[0] <= 0 or screen_px[1] <= 0):
        raise GazeError(str(path), f"screen size must be positive, got {screen_px[0]}x{screen_px[1]}")
    text = open_text(path)
    fmt = format_from_header(path, _first_line(text)) if fmt is None else fmt
    table = parse_table(path, text, DELIMITERS[fmt])
    if fmt == simple_csv.FORMAT:
        return simple_csv.simple_from_table(table, screen_px, min_confidence)
    if fmt == pupil.GAZE_FORMAT:
        return pupil.pupil_gaze_from_table(table, min_confidence)
    if fmt == pupil.SURFACE_FORMAT:
        return pupil.pupil_surface_from_table(table, min_confidence)
    return tobii.tobii_from_table(table, screen_px)
