"""Where the viewer looks, per frame: the pages' pointer (``gaze.cursor``) or another gaze source.

``PointerGaze`` keeps, with the cursor position, which pointer message set it (the
page, its sequence number, the page's send time and the server's receipt time), so
each frame can say which pointer move it shows and the page can measure the latency
from the move to the frame on its own clock.  ``SourceGaze`` samples any other
source (``webcam:``, ``trace:``) through replay's ``SteadyGaze``, which holds the
last valid point when the source fails.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

from gaze.cursor import CursorSource
from gaze.factory import open_source, split_spec
from gaze.source import GazeSample, GazeSource

from ..replay.run import SteadyGaze


@dataclass(frozen=True)
class PointerTag:
    """The pointer message behind a gaze point."""

    client: int
    seq: int
    sent_ms: float
    received: float

    def header(self, published: float) -> dict[str, float | int]:
        """The frame header's ``pointer`` entry; ``server_ms``: receipt to publication."""
        return {
            "client": self.client,
            "seq": self.seq,
            "sent_ms": self.sent_ms,
            "server_ms": 1000.0 * (published - self.received),
        }


class GazeFeed:
    """A gaze point per frame, with the pointer message behind it when there is one."""

    kind = "source"
    takes_pointer = False

    def sample(self, t: float) -> tuple[GazeSample, PointerTag | None]:
        """The gaze at wall-clock seconds ``t`` since the viewer started."""
        raise NotImplementedError

    def raw(self, t: float) -> GazeSample:
        """The source's own sample at ``t`` (with the webcam's eye feature), for calibration."""
        return self.sample(t)[0]

    def close(self) -> None:
        """Release the source."""


class PointerGaze(GazeFeed):
    """The newest pointer position of any page is the gaze (thread-safe)."""

    kind = "cursor"
    takes_pointer = True

    def __init__(self) -> None:
        self.cursor = CursorSource()
        self._lock = threading.Lock()
        self._tag: PointerTag | None = None

    def pointer(self, client: int, x: float, y: float, seq: int, sent_ms: float) -> None:
        """A page's pointer moved to normalised (x, y) (server thread)."""
        with self._lock:
            self.cursor.set_position(x, y)
            self._tag = PointerTag(client, seq, sent_ms, time.monotonic())

    def sample(self, t: float) -> tuple[GazeSample, PointerTag | None]:
        """The newest pointer (the centre, invalid, before the first)."""
        with self._lock:
            return self.cursor.sample(t), self._tag


class SourceGaze(GazeFeed):
    """Any ``GazeSource`` (started here, stopped by ``close``)."""

    def __init__(self, source: GazeSource, kind: str) -> None:
        self.source = source
        self.kind = kind
        source.start()
        self._steady = SteadyGaze(source)

    def sample(self, t: float) -> tuple[GazeSample, PointerTag | None]:
        """The source's gaze at ``t`` (its last valid point when it fails)."""
        return self._steady.sample(t), None

    def raw(self, t: float) -> GazeSample:
        """The source's own sample (not held), with its eye feature."""
        return self.source.sample(t)

    def close(self) -> None:
        """Stop the source."""
        self.source.stop()


def webcam_spec(spec: str) -> str | None:
    """``webcam:DEVICE`` without its options when ``spec`` is a webcam spec, else None."""
    kind, argument, _ = split_spec(spec)
    return f"webcam:{argument}" if kind == "webcam" else None


def open_feed(spec: str) -> GazeFeed:
    """The feed for a ``--gaze`` spec: the pages' pointer for ``cursor``, else the source
    it names, started (``GazeError`` naming the spec or the device when it fails)."""
    kind = split_spec(spec)[0]
    if kind == "cursor":
        return PointerGaze()
    return SourceGaze(open_source(spec), kind)
