"""Gazepoint Analysis exports: ``<user>_all_gaze.csv`` (comma separated, a trailing comma on
every line).

Columns used: ``TIME`` (seconds from the start; the header carries the start date in
parentheses, ``TIME(2021/06/21 14:26:13.616)``), ``FPOGX`` / ``FPOGY`` (the fixation
point of gaze as fractions of the screen, origin top-left) and ``FPOGV`` (1 valid, 0
invalid: such rows still carry the last point, which is ignored).
"""

from __future__ import annotations

from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples
from gaze.trace.text import TraceText

FORMAT = "gazepoint"
COLUMNS = ("time", "fpogx", "fpogy", "fpogv")
FLAGGED = "flagged invalid (FPOGV 0)"


def gazepoint_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of an ``all_gaze`` CSV (``screen_px`` is not needed: points are fractions)."""
    table = text.table
    t, x, y = (table.floats(table.require(name)) for name in COLUMNS[:3])
    valid = table.bools(table.require("fpogv"), empty=False)
    return Samples(t, x, y, table.lines, flags={FLAGGED: ~valid})


READER = TraceFormat(
    FORMAT,
    "Gazepoint Analysis all_gaze CSV",
    "TIME, FPOGX, FPOGY, FPOGV",
    lambda text: set(COLUMNS) <= text.names,
    gazepoint_samples,
)
