"""The reader interface every trace format implements, and reading a file with one reader
(the registry of readers and the detection rule live in ``detect``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from gaze.errors import GazeError
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE
from gaze.trace.recordings import TraceFile
from gaze.trace.samples import Samples
from gaze.trace.table import open_text
from gaze.trace.text import TraceText


@dataclass(frozen=True)
class TraceFormat:
    """One supported trace format.

    ``matches`` judges a file by its first line (``TraceText.first_line`` / ``names``);
    ``read`` turns the file into ``Samples``, given the caller's pixel size (or None).
    ``title`` names the format for people, ``expects`` says what its header holds.
    """

    name: str
    title: str
    expects: str
    matches: Callable[[TraceText], bool]
    read: Callable[[TraceText, tuple[int, int] | None], Samples]


def read_with(
    reader: TraceFormat,
    path: str | Path,
    screen_px: tuple[int, int] | None = None,
    min_confidence: float = DEFAULT_MIN_CONFIDENCE,
    text: TraceText | None = None,
) -> TraceFile:
    """Read the file at ``path`` (or its already decoded ``text``) with ``reader``.

    The rows the table parser dropped join the reader's own skipped rows.
    """
    if screen_px is not None and (screen_px[0] <= 0 or screen_px[1] <= 0):
        raise GazeError(str(path), f"screen size must be positive, got {screen_px[0]}x{screen_px[1]}")
    text = text if text is not None else TraceText(str(path), open_text(path))
    samples = reader.read(text, screen_px)
    skipped = {**text.table_skipped(), **samples.skipped}
    return TraceFile(text.path, reader.name, replace(samples, skipped=skipped), min_confidence)
