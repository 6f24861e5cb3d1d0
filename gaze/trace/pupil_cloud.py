"""Pupil Labs Neon / Invisible exports from Pupil Cloud (comma separated, times in UTC ns).

- Timeseries Data ``gaze.csv``: ``timestamp [ns]``, ``gaze x [px]``, ``gaze y [px]`` in the
  scene camera image (origin top-left; Neon 1600x1200, Invisible 1088x1080: the device
  is the one ``info.json`` beside the file names, or the caller gives the size),
  ``worn`` (0 = not worn: invalid), ``blink id`` (set during blinks: invalid).
- Marker Mapper ``gaze.csv``: ``gaze detected on surface`` (False: invalid) and
  ``gaze position on surface x/y [normalized]`` (origin top-left).
- Reference Image Mapper ``gaze.csv``: ``gaze detected in reference image`` (False:
  invalid) and ``gaze position in reference image x/y [px]``, pixels of a reference
  image whose size the file does not hold: the caller must give it.

Cloud exports join recordings: a ``recording id`` column says which row is whose.
Timestamps are parsed as int64 nanoseconds.
"""

from __future__ import annotations

import numpy as np

from gaze.trace.columns import time_unit
from gaze.trace.reader import TraceFormat
from gaze.trace.samples import Samples, pixel_note, pixel_size
from gaze.trace.sidecar import INFO_JSON, SCENE_CAMERAS, pupil_cloud_device
from gaze.trace.table import Table
from gaze.trace.text import TraceText

GAZE_FORMAT = "pupil_cloud"
MARKER_MAPPER_FORMAT = "marker_mapper"
REFERENCE_IMAGE_FORMAT = "reference_image_mapper"
TIME = "timestamp"
RECORDING = "recording id"
GAZE_COLUMNS = ("gaze x", "gaze y")
SURFACE_COLUMNS = ("gaze detected on surface", "gaze position on surface x", "gaze position on surface y")
REFERENCE_COLUMNS = (
    "gaze detected in reference image",
    "gaze position in reference image x",
    "gaze position in reference image y",
)
BLINK = "blink"
NOT_WORN = "not worn"
OFF_SURFACE = "off the surface"
OFF_REFERENCE = "not in the reference image"
SCENE = "the scene camera image"
REFERENCE = "the reference image"


def _common(table: Table) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray | None]:
    """Times (s), the blink flag where there is a ``blink id`` column, and the recording ids."""
    index = table.require(TIME)
    t = table.times(index, time_unit(table.path, table.header[index]))
    flags: dict[str, np.ndarray] = {}
    blink = table.find("blink id")
    if blink is not None:
        flags[BLINK] = np.array([bool(cell) for cell in table.cells(blink)], dtype=bool)
    rec = table.find(RECORDING)
    recording = None if rec is None else np.array(table.cells(rec), dtype=object)
    return t, flags, recording


def cloud_gaze_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a Timeseries Data ``gaze.csv``."""
    table = text.table
    t, flags, recording = _common(table)
    x, y = (table.floats(table.require(name)) for name in GAZE_COLUMNS)
    worn = table.find("worn")
    if worn is not None:
        flags = {NOT_WORN: ~table.bools(worn, empty=True), **flags}
    device = pupil_cloud_device(text.sibling_dir)
    sizes = " or ".join(f"--screen {w}x{h} ({name})" for name, (w, h) in SCENE_CAMERAS.items())
    size, source = pixel_size(
        table.path,
        screen_px,
        None if device is None else (SCENE_CAMERAS[device], f"{device}, from {INFO_JSON} beside the file"),
        SCENE,
        f"no {INFO_JSON} beside the file says which device recorded it: give {sizes}",
    )
    return Samples(
        t, x / size[0], y / size[1], table.lines, None, flags, {}, recording, pixel_note(size, source, SCENE)
    )


def marker_mapper_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a Marker Mapper enrichment ``gaze.csv`` (normalised: no pixel size needed)."""
    table = text.table
    t, flags, recording = _common(table)
    detected = table.bools(table.require(SURFACE_COLUMNS[0]), empty=False)
    x, y = (table.floats(table.require(name)) for name in SURFACE_COLUMNS[1:])
    return Samples(t, x, y, table.lines, None, {OFF_SURFACE: ~detected, **flags}, {}, recording)


def reference_image_samples(text: TraceText, screen_px: tuple[int, int] | None) -> Samples:
    """The samples of a Reference Image Mapper enrichment ``gaze.csv`` (the caller gives the image size)."""
    table = text.table
    t, flags, recording = _common(table)
    detected = table.bools(table.require(REFERENCE_COLUMNS[0]), empty=False)
    x, y = (table.floats(table.require(name)) for name in REFERENCE_COLUMNS[1:])
    size, source = pixel_size(
        table.path,
        screen_px,
        None,
        REFERENCE,
        "the file does not hold its size: give the reference image's --screen WxH (trace: ?screen=WxH)",
    )
    notes = pixel_note(size, source, REFERENCE)
    return Samples(
        t, x / size[0], y / size[1], table.lines, None, {OFF_REFERENCE: ~detected, **flags}, {}, recording, notes
    )


GAZE_READER = TraceFormat(
    GAZE_FORMAT,
    "Pupil Cloud (Neon / Invisible) gaze.csv",
    "timestamp [ns], gaze x [px], gaze y [px]",
    lambda text: {TIME, *GAZE_COLUMNS} <= text.names,
    cloud_gaze_samples,
)
MARKER_MAPPER_READER = TraceFormat(
    MARKER_MAPPER_FORMAT,
    "Pupil Cloud Marker Mapper gaze.csv",
    "timestamp [ns], gaze detected on surface, gaze position on surface x/y [normalized]",
    lambda text: {TIME, *SURFACE_COLUMNS} <= text.names,
    marker_mapper_samples,
)
REFERENCE_IMAGE_READER = TraceFormat(
    REFERENCE_IMAGE_FORMAT,
    "Pupil Cloud Reference Image Mapper gaze.csv",
    "timestamp [ns], gaze detected in reference image, gaze position in reference image x/y [px]",
    lambda text: {TIME, *REFERENCE_COLUMNS} <= text.names,
    reference_image_samples,
)
