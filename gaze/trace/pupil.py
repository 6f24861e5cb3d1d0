"""Pupil Labs Core exports (Pupil Player raw data exporter).

``gaze_positions.csv`` (gaze_timestamp, confidence, norm_pos_x, norm_pos_y; older Pupil
Player versions wrote ``timestamp`` instead of ``gaze_timestamp``) and
``gaze_positions_on_surface_<name>.csv`` (gaze_timestamp, x_norm, y_norm, on_surf
[, confidence]).  Both are normalised with the origin at the bottom-left, so y flips;
timestamps are in seconds (Pupil time, re-based to the first sample).

Binocular gaze (``base_data`` naming two pupil data, ``... -0 ... -1``) and monocular gaze
(one) are interleaved at different rates in ``gaze_positions.csv``; where a file holds
both, only the binocular rows are read and the monocular ones are skipped (counted).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.reader import TraceFormat, read_with
from gaze.trace.samples import Samples
from gaze.trace.table import Table
from gaze.trace.text import TraceText

GAZE_FORMAT = "pupil"
SURFACE_FORMAT = "pupil_surface"
GAZE_COLUMNS = ("gaze_timestamp", "confidence", "norm_pos_x", "norm_pos_y")
SURFACE_COLUMNS = ("gaze_timestamp", "x_norm", "y_norm", "on_surf")
#: Time column names of ``gaze_positions.csv``: current Pupil Player, then the old one.
TIME_COLUMNS = ("gaze_timestamp", "timestamp")
MONOCULAR = "monocular rows among binocular ones"
OFF_SURFACE = "off the surface (on_surf False)"


def read_pupil_gaze(path: str | Path, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Read ``gaze_positions.csv``."""
    return read_with(GAZE_READER, path, None, min_confidence).trace()


def read_pupil_surface(path: str | Path, min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> TraceData:
    """Read ``gaze_positions_on_surface_<name>.csv``."""
    return read_with(SURFACE_READER, path, None, min_confidence).trace()


def _time_column(table: Table) -> int:
    """The index of ``gaze_timestamp`` (or the old ``timestamp``)."""
    for name in TIME_COLUMNS:
        if name in table.header:
            return table.column(name)
    return table.column(TIME_COLUMNS[0])


def is_pupil_gaze_header(names: frozenset[str]) -> bool:
    """True for a ``gaze_positions.csv`` header, current or old."""
    return set(GAZE_COLUMNS[1:]) <= names and any(name in names for name in TIME_COLUMNS)


def binocular_rows(table: Table) -> np.ndarray | None:
    """Where the file mixes binocular and monocular rows (``base_data`` with two entries or one),
    the mask of the binocular rows; None when there is no ``base_data`` column or no mix."""
    if "base_data" not in table.header:
        return None
    binocular = np.array([len(cell.split()) >= 2 for cell in table.cells(table.column("base_data"))], dtype=bool)
    return binocular if binocular.any() and not binocular.all() else None


def pupil_gaze_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of ``gaze_positions.csv`` (``screen_px`` is not needed: positions are normalised)."""
    table = text.table
    t = table.floats(_time_column(table))
    conf, x, y_up = (table.floats(table.column(name)) for name in GAZE_COLUMNS[1:])
    samples = Samples(t, x, 1.0 - y_up, table.lines, conf)
    keep = binocular_rows(table)
    if keep is None:
        return samples
    return replace(samples.subset(keep), skipped={MONOCULAR: int((~keep).sum())})


def pupil_surface_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a surface export; rows with ``on_surf`` False are invalid, whatever their point."""
    table = text.table
    t, x, y_up = (table.floats(table.column(name)) for name in SURFACE_COLUMNS[:3])
    on_surf = table.bools(table.column("on_surf"), empty=False)
    conf = table.floats(table.column("confidence")) if "confidence" in table.header else np.ones_like(t)
    return Samples(t, x, 1.0 - y_up, table.lines, conf, flags={OFF_SURFACE: ~on_surf})


GAZE_READER = TraceFormat(
    GAZE_FORMAT,
    "Pupil Core gaze_positions.csv",
    ",".join(GAZE_COLUMNS) + " (or timestamp,...)",
    lambda text: is_pupil_gaze_header(text.names),
    pupil_gaze_samples,
)
SURFACE_READER = TraceFormat(
    SURFACE_FORMAT,
    "Pupil Core gaze_positions_on_surface_<name>.csv",
    ",".join(SURFACE_COLUMNS),
    lambda text: set(SURFACE_COLUMNS) <= text.names,
    pupil_surface_samples,
)
