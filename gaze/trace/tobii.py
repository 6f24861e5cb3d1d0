"""Tobii Pro Lab data exports (tab separated).

Columns used: ``Recording timestamp [unit]`` (unit from the header: us/µs/μs, ms, s or
ns), ``Gaze point X`` and ``Gaze point Y`` (pixels of the recording, origin top-left, an
optional ``[...]`` unit suffix), ``Sensor`` (only ``Eye Tracker`` rows are kept when the
column exists: mouse, gyroscope and event rows are skipped and counted), ``Validity
left/right`` (both ``Invalid``: the sample is invalid, whatever point it carries),
``Recording name`` (several recordings in one export) and, for the screen size,
``Recording resolution width/height`` unless the caller gives one.  Empty gaze cells
are invalid samples; decimal commas are accepted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gaze.errors import GazeError
from gaze.trace.columns import TIME_UNITS, split_unit, time_unit
from gaze.trace.data import TraceData
from gaze.trace.reader import TraceFormat, read_with
from gaze.trace.samples import Samples, pixel_note, pixel_size
from gaze.trace.table import Table
from gaze.trace.text import TraceText

__all__ = ["FORMAT", "READER", "TIME_UNITS", "read_tobii", "split_unit", "tobii_samples"]

FORMAT = "tobii"
EYE_TRACKER = "eye tracker"
NOT_EYE_TRACKER = "Sensor is not 'Eye Tracker' (mouse, gyroscope, event rows)"
BOTH_INVALID = "both eyes Invalid"
WHAT = "the recording's screen"


def read_tobii(path: str | Path, screen_px: tuple[int, int] | None = None) -> TraceData:
    """Read a Tobii Pro Lab TSV export; ``screen_px`` overrides the recording resolution."""
    return read_with(READER, path, screen_px, 0.0).trace()


def recording_resolution(table: Table, keep: np.ndarray, names: tuple[str, str]) -> tuple[int, int] | None:
    """The first usable (width, height) of the kept rows in the two columns ``names``; None
    when the columns are absent; a ``GazeError`` when they hold no usable value."""
    found = [table.find(name) for name in names]
    if found[0] is None or found[1] is None:
        return None
    size = []
    for index, name in zip(found, names):
        values = table.floats(index)[keep]
        values = values[np.isfinite(values)]
        if values.size == 0 or values[0] <= 0:
            raise GazeError(table.path, f"no usable {table.header[index]!r} value")
        size.append(int(values[0]))
    return size[0], size[1]


def tobii_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a Pro Lab export (see the module notes)."""
    table = text.table
    t_index = table.require("recording timestamp")
    unit = time_unit(table.path, table.header[t_index])
    x_index = table.require("gaze point x")
    y_index = table.require("gaze point y")
    keep = np.ones(len(table.rows), bool)
    sensor = table.find("sensor")
    skipped: dict[str, int] = {}
    if sensor is not None:
        keep = np.array([cell.lower() == EYE_TRACKER for cell in table.cells(sensor)], dtype=bool)
        if not keep.any():
            raise GazeError(table.path, "no rows with Sensor = 'Eye Tracker'")
        if not keep.all():
            skipped[NOT_EYE_TRACKER] = int((~keep).sum())
    found = recording_resolution(table, keep, ("recording resolution width", "recording resolution height"))
    size, source = pixel_size(
        table.path, screen_px, None if found is None else (found, "Recording resolution columns"), WHAT
    )
    flags: dict[str, np.ndarray] = {}
    validity = [table.find(f"validity {side}") for side in ("left", "right")]
    if validity[0] is not None and validity[1] is not None:
        invalid = [np.array([c.lower() == "invalid" for c in table.cells(i)], dtype=bool) for i in validity]
        flags[BOTH_INVALID] = (invalid[0] & invalid[1])[keep]
    name = table.find("recording name")
    recording = None if name is None else np.array(table.cells(name), dtype=object)[keep]
    return Samples(
        table.times(t_index, unit)[keep],
        table.floats(x_index)[keep] / size[0],
        table.floats(y_index)[keep] / size[1],
        table.lines[keep],
        None,
        flags,
        skipped,
        recording,
        pixel_note(size, source, WHAT),
    )


READER = TraceFormat(
    FORMAT,
    "Tobii Pro Lab TSV export",
    "Recording timestamp [unit], Gaze point X, Gaze point Y",
    lambda text: "recording timestamp" in text.names,
    tobii_samples,
)
