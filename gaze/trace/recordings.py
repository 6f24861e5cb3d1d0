"""A read trace file as its recordings: exports that join recordings carry a recording column
(Pupil Cloud ``recording id``, Tobii ``Recording name``/``RecordingName``); each recording is
validated and re-based on its own, and one must be chosen when there are several."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaze.errors import GazeError
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData, make_trace_data
from gaze.trace.samples import Samples

#: How to choose a recording, for messages.
CHOOSE = "choose one with --recording ID (trace: ?recording=ID)"


@dataclass(frozen=True)
class TraceFile:
    """Every sample row of one file, its format, and what the reader skipped."""

    path: str
    format: str
    samples: Samples
    min_confidence: float = DEFAULT_MIN_CONFIDENCE

    @property
    def recording_ids(self) -> list[str | None]:
        """The recording ids in order of first appearance (``[None]`` without a recording column)."""
        if self.samples.recording is None:
            return [None]
        return list(dict.fromkeys(self.samples.recording.tolist()))

    def recording_samples(self, recording: str | None) -> Samples:
        """The rows of one recording (all rows for ``None`` in a file without a recording column)."""
        if self.samples.recording is None:
            return self.samples
        return self.samples.subset(self.samples.recording == recording)

    def listing(self) -> str:
        """Each recording with its sample count and duration, for messages."""
        parts = []
        for rid in self.recording_ids:
            t = self.recording_samples(rid).t
            t = t[np.isfinite(t)]
            duration = float(t.max() - t.min()) if t.size else 0.0
            parts.append(f"{rid} ({t.size} samples, {duration:.3f} s)")
        return ", ".join(parts)

    def pick(self, recording: str | None) -> str | None:
        """The id of the recording to read: ``recording`` when the file holds it, the only one
        when ``recording`` is None; otherwise a ``GazeError`` listing the recordings."""
        ids = self.recording_ids
        if recording is None:
            if len(ids) > 1:
                raise GazeError(self.path, f"holds {len(ids)} recordings; {CHOOSE}: {self.listing()}")
            return ids[0]
        if ids == [None]:
            raise GazeError(self.path, f"recording {recording!r} asked for, but the file has no recording column")
        if recording not in ids:
            raise GazeError(self.path, f"no recording {recording!r}; the file holds {self.listing()}")
        return recording

    def trace(self, recording: str | None = None) -> TraceData:
        """One recording as a validated ``TraceData`` (see ``pick`` for the choice)."""
        rid = self.pick(recording)
        s = self.recording_samples(rid)
        confidence = np.ones(s.t.shape) if s.confidence is None else s.confidence
        return make_trace_data(
            self.path,
            self.format,
            s.t,
            s.x,
            s.y,
            confidence,
            np.ones(s.t.shape, bool),
            s.lines,
            self.min_confidence,
            flags=s.flags,
            skipped=s.skipped,
            recording=rid,
            notes=s.notes,
        )
