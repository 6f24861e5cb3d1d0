"""Tobii Studio data exports (tab separated).

Columns used: ``RecordingTimestamp`` (ms), ``GazePointX (ADCSpx)`` / ``GazePointY (ADCSpx)``
(pixels of the screen, origin top-left), ``ValidityLeft`` / ``ValidityRight`` (Tobii's
codes: 0 certain, 1 probable, 2 uncertain, 3 probably not, 4 eye not found; a sample is
valid when either eye's code is at most 1, otherwise invalid whatever point it carries),
``RecordingName`` (several recordings in one export) and ``RecordingResolution``
(``1920 x 1080``) for the screen size unless the caller gives one.  Rows without
validity codes are mouse or Studio event rows: skipped and counted.
"""

from __future__ import annotations

import numpy as np

from gaze.trace.columns import time_unit
from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples, pixel_note, pixel_size
from gaze.trace.sidecar import parse_size
from gaze.trace.text import TraceText

FORMAT = "tobii_studio"
EVENT_ROWS = "event rows (no validity codes: mouse and Studio events)"
UNCERTAIN = "validity code 2-4 on both eyes"
#: The highest validity code of an eye whose gaze is used.
MAX_VALID_CODE = 1
WHAT = "the recording's screen"


def studio_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a Tobii Studio export (see the module notes)."""
    table = text.table
    t_index = table.require("recordingtimestamp")
    t = table.times(t_index, time_unit(table.path, table.header[t_index], default="ms"))
    x = table.floats(table.require("gazepointx", "ADCSpx"))
    y = table.floats(table.require("gazepointy", "ADCSpx"))
    left, right = (table.floats(table.require(f"validity{side}")) for side in ("left", "right"))
    keep = np.isfinite(left) | np.isfinite(right)
    skipped = {} if keep.all() else {EVENT_ROWS: int((~keep).sum())}
    certain = (np.nan_to_num(left, nan=np.inf) <= MAX_VALID_CODE) | (np.nan_to_num(right, nan=np.inf) <= MAX_VALID_CODE)
    found = None
    res = table.find("recordingresolution")
    if res is not None:
        sizes = [parse_size(cell) for cell in table.cells(res)]
        found = next(((size, "RecordingResolution column") for size in sizes if size is not None), None)
    size, source = pixel_size(table.path, screen_px, found, WHAT)
    name = table.find("recordingname")
    recording = None if name is None else np.array(table.cells(name), dtype=object)[keep]
    return Samples(
        t[keep],
        x[keep] / size[0],
        y[keep] / size[1],
        table.lines[keep],
        None,
        {UNCERTAIN: ~certain[keep]},
        skipped,
        recording,
        pixel_note(size, source, WHAT),
    )


READER = TraceFormat(
    FORMAT,
    "Tobii Studio TSV export",
    "RecordingTimestamp, GazePointX (ADCSpx), GazePointY (ADCSpx), ValidityLeft, ValidityRight",
    lambda text: "recordingtimestamp" in text.names,
    studio_samples,
)
