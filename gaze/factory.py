"""Gaze sources from spec strings (command line ``--gaze``/``--source`` values).

Grammar (a kind, then ``:`` and its argument, then optional ``?key=value&key=value``)::

    cursor
    fixed:X,Y                         normalised, origin top-left, each in [0, 1]
    trace:PATH[?format=F][&screen=WxH][&min_confidence=C][&recording=ID]
                                      F one of ``gaze.trace.FORMATS`` (default:
                                      detected from the header); WxH the pixel size
                                      of pixel-unit files; ID one recording of a file
                                      that joins several
    webcam:INDEX[?calibration=FILE]   a camera index (digits)
    webcam:VIDEO[?calibration=FILE]   a video file played as the camera

The query starts at the last ``?``, so a path may not contain ``?``.
"""

from __future__ import annotations

from gaze.cursor import CursorSource
from gaze.errors import GazeError
from gaze.fixed import FixedSource, point_problem
from gaze.screen import ScreenGeometry, parse_screen_size
from gaze.source import GazeSource
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE
from gaze.trace.detect import check_format
from gaze.trace.playback import TraceSource

KINDS = ("cursor", "fixed", "trace", "webcam")
#: Query keys each kind accepts.
QUERY_KEYS = {
    "cursor": (),
    "fixed": (),
    "trace": ("format", "screen", "min_confidence", "recording"),
    "webcam": ("calibration",),
}
SPEC_HELP = "cursor, fixed:X,Y, trace:PATH[?format=F&screen=WxH&recording=ID] or webcam:INDEX|VIDEO[?calibration=FILE]"


def _spec_error(spec: str, problem: str) -> GazeError:
    """A ``GazeError`` that names the spec."""
    return GazeError(f"gaze source {spec!r}", problem)


def split_spec(spec: str) -> tuple[str, str, dict[str, str]]:
    """Split a spec into (kind, argument, query); ``GazeError`` naming the spec when malformed."""
    text = spec.strip()
    kind, colon, rest = text.partition(":")
    kind = kind.strip().lower()
    if kind not in KINDS:
        raise _spec_error(spec, f"unknown kind {kind!r}; expected {SPEC_HELP}")
    argument, question, query_text = rest.rpartition("?") if "?" in rest else (rest, "", "")
    query: dict[str, str] = {}
    if question:
        for item in query_text.split("&"):
            key, equals, value = item.partition("=")
            key = key.strip().lower()
            if not equals or not key or not value.strip():
                raise _spec_error(spec, f"malformed option {item!r}; options look like ?key=value&key=value")
            if key not in QUERY_KEYS[kind]:
                allowed = ", ".join(QUERY_KEYS[kind]) or "none"
                raise _spec_error(spec, f"unknown option {key!r} for {kind} (allowed: {allowed})")
            if key in query:
                raise _spec_error(spec, f"option {key!r} given twice")
            query[key] = value.strip()
    if kind == "cursor":
        if colon or question:
            raise _spec_error(spec, "cursor takes no argument")
    elif not argument.strip():
        raise _spec_error(spec, f"{kind} needs an argument after ':'; expected {SPEC_HELP}")
    return kind, argument.strip(), query


def _fixed(spec: str, argument: str) -> FixedSource:
    """``fixed:X,Y``."""
    parts = argument.split(",")
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        raise _spec_error(spec, f"fixed needs X,Y (two numbers), got {argument!r}") from None
    problem = point_problem(x, y)
    if problem is not None:
        raise _spec_error(spec, f"fixed {problem}")
    return FixedSource(x, y)


def _trace(spec: str, path: str, query: dict[str, str]) -> TraceSource:
    """``trace:PATH[?format=F&screen=WxH&min_confidence=C&recording=ID]``."""
    fmt = check_format(query["format"], f"gaze source {spec!r}") if "format" in query else None
    screen_px = parse_screen_size(query["screen"], f"gaze source {spec!r}") if "screen" in query else None
    min_confidence = DEFAULT_MIN_CONFIDENCE
    if "min_confidence" in query:
        try:
            min_confidence = float(query["min_confidence"])
        except ValueError:
            raise _spec_error(spec, f"min_confidence must be a number, got {query['min_confidence']!r}") from None
        if not 0.0 <= min_confidence <= 1.0:
            raise _spec_error(spec, f"min_confidence must lie in [0, 1], got {min_confidence:g}")
    screen = ScreenGeometry().with_pixels(*screen_px) if screen_px is not None else None
    return TraceSource.from_file(path, fmt, screen, screen_px, min_confidence, recording=query.get("recording"))


def _webcam(spec: str, argument: str, query: dict[str, str]) -> GazeSource:
    """``webcam:INDEX|VIDEO[?calibration=FILE]`` (the estimator is imported only here)."""
    try:
        from gaze.webcam.source import WebcamSource
    except ModuleNotFoundError as exc:
        if exc.name is None or not (exc.name.startswith("gaze.webcam") or exc.name == "cv2"):
            raise
        raise _spec_error(spec, f"the webcam estimator is not available ({exc})") from None
    device: int | str = int(argument) if argument.isdigit() else argument
    return WebcamSource(device, query.get("calibration"))


def open_source(spec: str) -> GazeSource:
    """The gaze source that ``spec`` describes (see the module notes); use it as a context manager.

    A malformed or unknown spec is a ``GazeError`` naming the spec; a bad trace file
    is a ``GazeError`` naming the file.
    """
    kind, argument, query = split_spec(spec)
    if kind == "cursor":
        return CursorSource()
    if kind == "fixed":
        return _fixed(spec, argument)
    if kind == "trace":
        return _trace(spec, argument, query)
    return _webcam(spec, argument, query)
