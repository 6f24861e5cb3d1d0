"""Pupil Player's iMotions exporter: ``gaze.tlv`` (tab separated).

Columns used: ``GazeTimeStamp`` (seconds, Pupil time), ``Gaze2dX`` / ``Gaze2dY`` (pixels
of the undistorted world camera image, origin top-left) and ``Confidence``.  The pixel
size is the caller's, else the ``World Camera Resolution`` of ``iMotions_info.csv``
beside the file (the exporter copies the recording's ``info.csv`` there).
"""

from __future__ import annotations

from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples, pixel_note, pixel_size
from gaze.trace.sidecar import IMOTIONS_INFO, imotions_world_size
from gaze.trace.text import TraceText

FORMAT = "pupil_imotions"
COLUMNS = ("gazetimestamp", "gaze2dx", "gaze2dy", "confidence")
WHAT = "the undistorted world camera image"


def imotions_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of ``gaze.tlv``."""
    table = text.table
    t, x, y, conf = (table.floats(table.require(name)) for name in COLUMNS)
    found = imotions_world_size(text.sibling_dir)
    size, source = pixel_size(
        table.path,
        screen_px,
        None if found is None else (found, f"{IMOTIONS_INFO} beside the file"),
        WHAT,
        f"give --screen WxH (trace: ?screen=WxH), or keep {IMOTIONS_INFO} beside the file",
    )
    return Samples(t, x / size[0], y / size[1], table.lines, conf, notes=pixel_note(size, source, WHAT))


READER = TraceFormat(
    FORMAT,
    "Pupil Player iMotions export gaze.tlv",
    "GazeTimeStamp, Gaze2dX, Gaze2dY, Confidence",
    lambda text: set(COLUMNS) <= text.names,
    imotions_samples,
)
