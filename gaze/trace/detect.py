"""The registry of trace readers, the one detection rule, and the entry points that read any format.

Detection judges a file by its first non-blank line alone: exactly one reader's
``matches`` must accept it (each format has a column, or a line form, no other has).
"""

from __future__ import annotations

from pathlib import Path

from gaze.errors import GazeError
from gaze.trace import (
    eyelink,
    gazepoint,
    pupil,
    pupil_cloud,
    pupil_imotions,
    simple_csv,
    tobii,
    tobii_sdk,
    tobii_studio,
)
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.reader import TraceFormat, read_with
from gaze.trace.recordings import TraceFile
from gaze.trace.table import open_text
from gaze.trace.text import TraceText

#: Every reader, in the order formats are listed to people.
READERS: tuple[TraceFormat, ...] = (
    simple_csv.READER,
    pupil.GAZE_READER,
    pupil.SURFACE_READER,
    tobii.READER,
    pupil_imotions.READER,
    pupil_cloud.GAZE_READER,
    pupil_cloud.MARKER_MAPPER_READER,
    pupil_cloud.REFERENCE_IMAGE_READER,
    gazepoint.READER,
    eyelink.READER,
    tobii_studio.READER,
    tobii_sdk.READER,
)
FORMATS = tuple(reader.name for reader in READERS)
_BY_NAME = {reader.name: reader for reader in READERS}


def matching_readers(text: TraceText) -> list[TraceFormat]:
    """Every reader that accepts the file's first line (detection wants exactly one)."""
    return [reader for reader in READERS if reader.matches(text)]


def detect_reader(text: TraceText) -> TraceFormat:
    """The one reader that accepts the file; ``GazeError`` naming the file when none or several do."""
    found = matching_readers(text)
    if len(found) == 1:
        return found[0]
    if found:
        names = ", ".join(reader.name for reader in found)
        raise GazeError(text.path, f"the header fits several formats ({names}); choose one with --format / ?format=")
    expected = "; ".join(f"{reader.title} ({reader.expects})" for reader in READERS)
    raise GazeError(text.path, f"unknown columns {text.labels}; expected one of: {expected}")


def detect_format(path: str | Path) -> str:
    """The format name of a trace file (one of ``FORMATS``), judged from its first line."""
    return detect_reader(TraceText(str(path), open_text(path))).name


def check_format(fmt: str, where: str) -> str:
    """``fmt`` itself when it names a supported format, else a ``GazeError`` naming ``where``."""
    if fmt not in _BY_NAME:
        raise GazeError(where, f"unknown trace format {fmt!r}; choose one of {', '.join(FORMATS)}")
    return fmt


def format_title(fmt: str) -> str:
    """The people's name of a format (``'Tobii Pro Lab TSV export'`` for ``'tobii'``)."""
    return _BY_NAME[check_format(fmt, "format")].title


def read_recordings(
    path: str | Path,
    fmt: str | None = None,
    screen_px: tuple[int, int] | None = None,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
) -> TraceFile:
    """Read every recording of a trace file in format ``fmt`` (detected when None)."""
    if fmt is not None:
        check_format(fmt, str(path))
    text = TraceText(str(path), open_text(path))
    reader = detect_reader(text) if fmt is None else _BY_NAME[fmt]
    return read_with(reader, path, screen_px, min_confidence, text)


def read_trace(
    path: str | Path,
    fmt: str | None = None,
    screen_px: tuple[int, int] | None = None,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
    recording: str | None = None,
) -> TraceData:
    """Read one recording of a trace in format ``fmt`` (detected from the header when None).

    ``screen_px`` is the pixel size for pixel coordinates (it overrides a size the file
    holds); ``min_confidence`` applies to formats with confidences; ``recording`` picks
    one recording of a file that joins several (required then; see ``TraceFile.pick``).
    """
    return read_recordings(path, fmt, screen_px, min_confidence).trace(recording)
