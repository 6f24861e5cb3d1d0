"""Pupil Labs Core exports (Pupil Player raw data exporter).

``gaze_positions.csv`` (gaze_timestamp, confidence, norm_pos_x, norm_pos_y) and
``gaze_positions_on_surface_<name>.csv`` (gaze_timestamp, x_norm, y_norm, on_surf
[, confidence]).  Both are normalised with the origin at the bottom-left, so y flips;
timestamps are in seconds (Pupil time, re-based to the first sample).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaze.errors import GazeError
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData, make_trace_data
from gaze.trace.table import Table, read_table

GAZE_FORMAT = "pupil"
SURFACE_FORMAT = "pupil_surface"
GAZE_COLUMNS = ("gaze_timestamp", "confidence", "norm_pos_x", "norm_pos_y")
SURFACE_COLUMNS = ("gaze_timestamp", "x_norm", "y_norm", "on_surf")
_TRUE = {"true", "1", "yes"}
_FALSE = {"false", "0", "no", ""}


def read_pupil_gaze(path: str | Path, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Read ``gaze_positions.csv``."""
    return pupil_gaze_from_table(read_table(path, ","), min_confidence)


def read_pupil_surface(path: str | Path, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Read ``gaze_positions_on_surface_<name>.csv``."""
    return pupil_surface_from_table(read_table(path, ","), min_confidence)


def pupil_gaze_from_table(table: Table, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Build the trace from a parsed ``gaze_positions.csv`` table."""
    t, conf, x, y_up = (table.floats(table.column(name)) for name in GAZE_COLUMNS)
    usable = np.ones(t.shape, bool)
    return make_trace_data(table.path, GAZE_FORMAT, t, x, 1.0 - y_up, conf, usable, table.lines, min_confidence)


def pupil_surface_from_table(table: Table, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Build the trace from a parsed surface export; rows with ``on_surf`` False are invalid."""
    t, x, y_up = (table.floats(table.column(name)) for name in SURFACE_COLUMNS[:3])
    on_surf = np.zeros(t.shape, bool)
    for k, cell in enumerate(table.cells(table.column("on_surf"))):
        word = cell.lower()
        if word not in _TRUE | _FALSE:
            raise GazeError(table.path, f"line {int(table.lines[k])}: on_surf must be True or False, got {cell!r}")
        on_surf[k] = word in _TRUE
    conf = table.floats(table.column("confidence")) if "confidence" in table.header else np.ones_like(t)
    return make_trace_data(table.path, SURFACE_FORMAT, t, x, 1.0 - y_up, conf, on_surf, table.lines, min_confidence)
