"""What ``gaze info`` reports about a trace file: its format, recordings, duration, sample
rate, share of valid samples, and what was skipped or made invalid, and why."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from gaze.errors import GazeError
from gaze.trace.data import TraceData
from gaze.trace.detect import format_title
from gaze.trace.recordings import TraceFile


def sample_rate(data: TraceData) -> float | None:
    """Samples per second from the median interval (None with fewer than two samples)."""
    if len(data) < 2:
        return None
    return float(1.0 / np.median(np.diff(data.t)))


def recording_summary(data: TraceData) -> dict[str, Any]:
    """One recording's numbers (``id`` None in a file without a recording column)."""
    rate = sample_rate(data)
    valid = int(data.valid.sum())
    return {
        "id": data.recording,
        "samples": len(data),
        "valid": valid,
        "valid_share": valid / len(data),
        "duration_s": data.duration,
        "rate_hz": rate,
        "invalid": dict(data.invalid),
    }


def file_summary(trace_file: TraceFile, recording: str | None = None) -> dict[str, Any]:
    """The report on ``trace_file``: every recording, or only ``recording`` when given.

    A recording that cannot be read (no valid sample, unsorted times) is reported with
    its ``error`` instead of numbers, so the others are still described.
    """
    ids = trace_file.recording_ids if recording is None else [trace_file.pick(recording)]
    recordings = []
    for rid in ids:
        try:
            recordings.append(recording_summary(trace_file.trace(rid)))
        except GazeError as exc:
            recordings.append({"id": rid, "samples": len(trace_file.recording_samples(rid)), "error": exc.problem})
    return {
        "path": trace_file.path,
        "format": trace_file.format,
        "title": format_title(trace_file.format),
        "recordings_in_file": len(trace_file.recording_ids),
        "notes": dict(trace_file.samples.notes),
        "skipped": dict(trace_file.samples.skipped),
        "recordings": recordings,
    }


def count_phrase(counts: Mapping[str, int]) -> str:
    """``{'a': 2, 'b': 1}`` -> ``'2 a, 1 b'`` (``'none'`` when empty)."""
    return ", ".join(f"{n} {reason}" for reason, n in counts.items()) or "none"


def format_summary(summary: dict[str, Any]) -> str:
    """The report as lines of text."""
    lines = [
        f"{summary['path']}: {summary['title']} (format {summary['format']})",
        f"  recordings: {summary['recordings_in_file']}",
    ]
    lines += [f"  {key}: {value}" for key, value in summary["notes"].items()]
    lines.append(f"  skipped rows: {count_phrase(summary['skipped'])}")
    for rec in summary["recordings"]:
        name = "recording" if rec["id"] is None else f"recording {rec['id']}"
        if "error" in rec:
            lines.append(f"  {name}: {rec['samples']} rows, unreadable: {rec['error']}")
            continue
        rate = "n/a" if rec["rate_hz"] is None else f"{rec['rate_hz']:.1f} Hz"
        lines.append(
            f"  {name}: {rec['samples']} samples over {rec['duration_s']:.3f} s at {rate}, "
            f"{100 * rec['valid_share']:.1f}% valid; invalid: {count_phrase(rec['invalid'])}"
        )
    return "\n".join(lines)
