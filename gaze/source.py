"""The gaze interface: one sample per question, sources as context managers."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from types import TracebackType

FIXATION = "fixation"
SACCADE = "saccade"
UNKNOWN = "unknown"


@dataclass(frozen=True)
class GazeSample:
    """Where the viewer looks at time ``t`` (seconds).

    ``x, y`` are normalised to [0, 1]^2 with the origin at the top-left (x right, y down)
    and are always a usable point: when ``valid`` is False they hold the last good
    fixation (or the screen centre) and ``confidence`` is 0.  ``label`` is the I-VT eye
    movement class where a source knows it; ``features`` carries the raw webcam
    feature (pupil offset from the face anchor) for calibration.
    """

    x: float
    y: float
    t: float
    confidence: float = 1.0
    valid: bool = True
    label: str = UNKNOWN
    features: tuple[float, float] | None = None


def centre_sample(t: float) -> GazeSample:
    """The fallback sample before a source has measured anything: screen centre, invalid."""
    return GazeSample(0.5, 0.5, t, confidence=0.0, valid=False)


class GazeSource(ABC):
    """Answers "where is the viewer looking at time t?"; use as a context manager.

    ``start``/``stop`` acquire and release whatever the source holds (a camera, a
    worker thread); sources without resources keep the default no-ops.
    """

    def start(self) -> None:
        """Acquire resources; called by ``__enter__``."""

    def stop(self) -> None:
        """Release resources; called by ``__exit__``; safe to call twice."""

    @abstractmethod
    def sample(self, t: float) -> GazeSample:
        """The gaze at time ``t`` in seconds (the source's own clock for live sources)."""

    def __enter__(self) -> GazeSource:
        self.start()
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
