"""Recorded gaze traces: readers per format, detection, playback and I-VT labelling."""

from gaze.trace.data import DEFAULT_MIN_CONFIDENCE, TraceData
from gaze.trace.detect import FORMATS, READERS, detect_format, read_recordings, read_trace
from gaze.trace.ivt import DEFAULT_THRESHOLD_DEG_S, angular_speed, label_ivt
from gaze.trace.playback import TraceSource
from gaze.trace.recordings import TraceFile
from gaze.trace.simple_csv import format_simple, write_simple, write_trace

__all__ = [
    "DEFAULT_MIN_CONFIDENCE",
    "DEFAULT_THRESHOLD_DEG_S",
    "FORMATS",
    "READERS",
    "TraceData",
    "TraceFile",
    "TraceSource",
    "angular_speed",
    "detect_format",
    "format_simple",
    "label_ivt",
    "read_recordings",
    "read_trace",
    "write_simple",
    "write_trace",
]
