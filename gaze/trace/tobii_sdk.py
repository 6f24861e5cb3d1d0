"""Tobii Pro SDK gaze data written straight to a file (one row per ``gaze_data`` callback,
semicolon separated, as researchers' scripts dump it).

Columns used: ``system_time_stamp`` (microseconds), ``left/right_gaze_point_on_display_area``
(``(x, y)`` tuples in the display area, normalised, origin top-left) and
``left/right_gaze_point_validity`` (1 or True: valid).  The point is the mean of the valid
eyes (one eye when only one is valid); a sample with neither eye valid is invalid,
whatever point it carries.  A dump with only one eye's columns uses that eye.
"""

from __future__ import annotations

import numpy as np

from gaze.errors import GazeError
from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples, combine_eyes
from gaze.trace.table import Table
from gaze.trace.text import TraceText

FORMAT = "tobii_sdk"
TIME = "system_time_stamp"
POINT = "{}_gaze_point_on_display_area"
VALIDITY = "{}_gaze_point_validity"
EYES = ("left", "right")
NEITHER = "neither eye valid"


def _tuples(table: Table, index: int) -> tuple[np.ndarray, np.ndarray]:
    """A column of ``(x, y)`` cells as two float arrays (NaN where empty); a malformed cell is
    a ``GazeError`` naming the line."""
    xs = np.full(len(table.rows), np.nan)
    ys = np.full(len(table.rows), np.nan)
    for k, cell in enumerate(table.cells(index)):
        if not cell:
            continue
        parts = cell.strip("()[] ").split(",")
        try:
            xs[k], ys[k] = (float(p) for p in parts)
        except ValueError:
            raise GazeError(
                table.path,
                f"line {int(table.lines[k])}: column {table.header[index]!r} is not an (x, y) pair: {cell!r}",
            ) from None
    return xs, ys


def _eye(table: Table, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """One eye's ``(x, y, valid)``, or None when the dump has no columns for it."""
    point = table.find(POINT.format(side))
    if point is None:
        return None
    x, y = _tuples(table, point)
    validity = table.find(VALIDITY.format(side))
    valid = np.ones(x.shape, bool) if validity is None else table.bools(validity, empty=False)
    return x, y, valid


def sdk_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of an SDK dump (``screen_px`` is not needed: points are normalised)."""
    table = text.table
    t = table.times(table.require(TIME), "us")
    eyes = [eye for eye in (_eye(table, side) for side in EYES) if eye is not None]
    if len(eyes) == 1:
        eyes.append(eyes[0])
    x, y, valid = combine_eyes(eyes[0], eyes[1])
    return Samples(t, x, y, table.lines, flags={NEITHER: ~valid})


READER = TraceFormat(
    FORMAT,
    "Tobii Pro SDK gaze data dump",
    "system_time_stamp; left_/right_gaze_point_on_display_area (x, y); left_/right_gaze_point_validity",
    lambda text: TIME in text.names and any(POINT.format(side) in text.names for side in EYES),
    sdk_samples,
)
