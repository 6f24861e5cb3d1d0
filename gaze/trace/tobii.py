"""Tobii Pro Lab data exports (tab separated).

Columns used: ``Recording timestamp [unit]`` (unit from the header: us/µs/μs, ms or s),
``Gaze point X`` and ``Gaze point Y`` (pixels of the recording, origin top-left, an
optional ``[...]`` unit suffix), ``Sensor`` (only ``Eye Tracker`` rows are kept when the
column exists) and, for the screen size, ``Recording resolution width/height`` unless
the caller gives one.  Empty gaze cells are invalid samples; decimal commas are accepted.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from gaze.errors import GazeError
from gaze.trace.data import TraceData, make_trace_data
from gaze.trace.table import Table, read_table

FORMAT = "tobii"
EYE_TRACKER = "eye tracker"
TIME_UNITS = {"us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ms": 1e-3, "s": 1.0}
_UNIT = re.compile(r"^(?P<name>[^\[]*?)\s*(\[(?P<unit>[^\]]*)\])?$")


def split_unit(label: str) -> tuple[str, str | None]:
    """``'Recording timestamp [ms]'`` -> ``('recording timestamp', 'ms')``."""
    match = _UNIT.match(label.strip())
    if match is None:
        return label.strip().lower(), None
    return match.group("name").strip().lower(), match.group("unit")


def is_tobii_header(header: list[str]) -> bool:
    """True when the header holds a ``Recording timestamp`` column."""
    return any(split_unit(label)[0] == "recording timestamp" for label in header)


def read_tobii(path: str | Path, screen_px: tuple[int, int] | None = None) -> TraceData:
    """Read a Tobii Pro Lab TSV export; ``screen_px`` overrides the recording resolution."""
    return tobii_from_table(read_table(path, "\t"), screen_px)


def _find_optional(table: Table, name: str) -> tuple[int, str | None] | None:
    """The index and unit of the column whose name (without its unit) is ``name``, or None."""
    for i, label in enumerate(table.header):
        base, unit = split_unit(label)
        if base == name:
            return i, unit
    return None


def _find(table: Table, name: str) -> tuple[int, str | None]:
    """Like ``_find_optional``, but a missing column is a ``GazeError``."""
    found = _find_optional(table, name)
    if found is None:
        raise GazeError(table.path, f"missing column {name!r}; columns are {table.header}")
    return found


def _screen_from_columns(table: Table, keep: np.ndarray) -> tuple[int, int]:
    """The recording's pixel size from its ``Recording resolution`` columns."""
    found = [_find_optional(table, f"recording resolution {side}") for side in ("width", "height")]
    if found[0] is None or found[1] is None:
        raise GazeError(table.path, "gaze points are pixels but there is no screen size; give screen=WxH / --screen")
    size = []
    for (index, _), side in zip(found, ("width", "height")):
        values = table.floats(index, decimal_comma=True)[keep]
        values = values[np.isfinite(values)]
        if values.size == 0 or values[0] <= 0:
            raise GazeError(table.path, f"no usable 'Recording resolution {side}' value")
        size.append(int(values[0]))
    return size[0], size[1]


def tobii_from_table(table: Table, screen_px: tuple[int, int] | None = None) -> TraceData:
    """Build the trace from a parsed Tobii table (see the module notes)."""
    t_index, unit = _find(table, "recording timestamp")
    if unit is None:
        raise GazeError(table.path, "'Recording timestamp' has no unit in its header (e.g. [ms] or [us])")
    unit = unit.strip().lower()
    if unit not in TIME_UNITS:
        raise GazeError(table.path, f"unknown timestamp unit [{unit}]; expected one of {sorted(TIME_UNITS)}")
    x_index, _ = _find(table, "gaze point x")
    y_index, _ = _find(table, "gaze point y")
    keep = np.ones(len(table.rows), bool)
    sensor = _find_optional(table, "sensor")
    if sensor is not None:
        keep = np.array([cell.lower() == EYE_TRACKER for cell in table.cells(sensor[0])], dtype=bool)
        if not keep.any():
            raise GazeError(table.path, "no rows with Sensor = 'Eye Tracker'")
    width, height = screen_px if screen_px is not None else _screen_from_columns(table, keep)
    t = table.floats(t_index, decimal_comma=True)[keep] * TIME_UNITS[unit]
    x = table.floats(x_index, decimal_comma=True)[keep] / width
    y = table.floats(y_index, decimal_comma=True)[keep] / height
    ones = np.ones(t.shape)
    return make_trace_data(table.path, FORMAT, t, x, y, ones, ones.astype(bool), table.lines[keep], 0.0)
