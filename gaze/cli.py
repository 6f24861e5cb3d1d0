"""The ``gaze`` command line: ``calibrate``, ``record``, ``convert`` and ``info``.

``add_gaze_parser`` hangs the ``gaze`` sub-command under a parent program
(``warp-hybrid gaze ...``); ``build_parser`` makes the stand-alone ``python -m gaze``
program with the same sub-commands; ``run_gaze`` runs a parsed command.  The webcam
commands live in ``gaze.webcam.commands`` and are imported only when used.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from collections.abc import Callable, Sequence

from gaze.atomic import check_output
from gaze.errors import GazeError
from gaze.screen import parse_screen_size
from gaze.trace.data import DEFAULT_MIN_CONFIDENCE
from gaze.trace.detect import FORMATS, read_recordings
from gaze.trace.simple_csv import write_trace
from gaze.trace.summary import count_phrase, file_summary, format_summary


def screen_size_arg(text: str) -> tuple[int, int]:
    """argparse type for ``--screen WxH``: a (width, height) tuple of positive pixels."""
    try:
        return parse_screen_size(text, "--screen")
    except GazeError as exc:
        raise argparse.ArgumentTypeError(exc.problem) from None


def confidence_arg(text: str) -> float:
    """argparse type for ``--min-confidence``: a number in [0, 1]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number in [0, 1], got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a number in [0, 1], got {text!r}")
    return value


def add_gaze_commands(parser: argparse.ArgumentParser) -> None:
    """Add the ``calibrate``, ``record``, ``convert`` and ``info`` sub-commands to ``parser``
    (their name lands in ``args.gaze_command``)."""
    sub = parser.add_subparsers(dest="gaze_command", required=True, metavar="{calibrate,record,convert,info}")

    p = sub.add_parser("calibrate", help="9-point webcam calibration: fit features -> screen, save JSON")
    p.add_argument("--source", required=True, help="webcam:INDEX or webcam:VIDEO (a video file)")
    p.add_argument(
        "--targets",
        default=None,
        help="CSV with rows t,x,y (normalised, origin top-left): the target shown from t until the next row's t",
    )
    p.add_argument("--out", required=True, help="calibration JSON to write")

    p = sub.add_parser("record", help="run the webcam estimator and write a simple CSV gaze trace")
    p.add_argument("--source", required=True, help="webcam:INDEX or webcam:VIDEO (a video file)")
    p.add_argument("--calibration", required=True, help="calibration JSON from 'gaze calibrate'")
    p.add_argument("--out", required=True, help="trace CSV to write (t,x,y,confidence)")
    p.add_argument(
        "--screen", type=screen_size_arg, default=None, metavar="WxH", help="screen size in pixels, e.g. 1920x1080"
    )

    p = sub.add_parser("convert", help="convert a recorded gaze trace (any supported export) to the simple CSV")
    p.add_argument("input", help="trace file; its format is detected from the header unless --format is given")
    p.add_argument(
        "output",
        help="simple CSV to write: t,x,y,confidence, t from the first sample, x,y normalised with the origin top-left",
    )
    _add_reading_options(p)

    p = sub.add_parser("info", help="what a trace file holds: format, recordings, rate, valid share, skipped rows")
    p.add_argument("input", help="trace file; its format is detected from the header unless --format is given")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    _add_reading_options(p)


def _add_reading_options(p: argparse.ArgumentParser) -> None:
    """The options of every command that reads a trace file: format, screen, confidence, recording."""
    p.add_argument("--format", choices=FORMATS, default=None, help="input format (default: detect)")
    p.add_argument(
        "--screen",
        type=screen_size_arg,
        default=None,
        metavar="WxH",
        help="pixel size of pixel coordinates in the input (it overrides a size the file holds; needed where "
        "the file holds none)",
    )
    p.add_argument(
        "--min-confidence",
        type=confidence_arg,
        default=DEFAULT_MIN_CONFIDENCE,
        help=f"samples below this confidence are invalid (default {DEFAULT_MIN_CONFIDENCE})",
    )
    p.add_argument(
        "--recording",
        default=None,
        metavar="ID",
        help="one recording of a file that joins several (a 'recording id' / 'Recording name' column)",
    )


def add_gaze_parser(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``gaze`` sub-command (with calibrate/record/convert/info) to a parent program's sub-parsers."""
    parser = subparsers.add_parser(
        "gaze",
        help="gaze sources: webcam calibrate/record, trace convert/info",
        description="Gaze sources: webcam calibration and recording, trace conversion and inspection.",
    )
    add_gaze_commands(parser)


def build_parser() -> argparse.ArgumentParser:
    """The stand-alone ``gaze`` program (``python -m gaze``)."""
    parser = argparse.ArgumentParser(
        prog="gaze", description="Gaze sources: webcam calibration and recording, trace conversion and inspection."
    )
    add_gaze_commands(parser)
    return parser


def _cmd_convert(args: argparse.Namespace) -> int:
    """``gaze convert IN OUT``: read one recording of any supported trace, write the simple CSV atomically."""
    trace_file = read_recordings(args.input, args.format, args.screen, args.min_confidence)
    data = trace_file.trace(args.recording)
    write_trace(args.output, data)
    recording = "" if data.recording is None else f" recording {data.recording}"
    skipped = f"; skipped rows: {count_phrase(data.skipped)}" if data.skipped else ""
    invalid = f"; invalid: {count_phrase(data.invalid)}" if data.invalid else ""
    print(
        f"{args.output}: {len(data)} samples ({int(data.valid.sum())} valid) over {data.duration:.3f} s "
        f"from {data.format}{recording} {args.input}{skipped}{invalid}"
    )
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    """``gaze info TRACE``: print what the file holds (text, or JSON with ``--json``)."""
    trace_file = read_recordings(args.input, args.format, args.screen, args.min_confidence)
    summary = file_summary(trace_file, args.recording)
    print(json.dumps(summary, indent=2) if args.json else format_summary(summary))
    return 0


def _webcam_command(name: str) -> Callable[[argparse.Namespace], int]:
    """``run_<name>`` from ``gaze.webcam.commands``, imported only now."""
    try:
        commands = importlib.import_module("gaze.webcam.commands")
    except ModuleNotFoundError as exc:
        if exc.name is None or not (exc.name.startswith("gaze.webcam") or exc.name == "cv2"):
            raise
        raise GazeError(f"gaze {name}", f"the webcam estimator is not available ({exc})") from None
    return getattr(commands, f"run_{name}")


def _cmd_calibrate(args: argparse.Namespace) -> int:
    """``gaze calibrate`` (the webcam estimator's command)."""
    return _webcam_command("calibrate")(args)


def _cmd_record(args: argparse.Namespace) -> int:
    """``gaze record`` (the webcam estimator's command)."""
    return _webcam_command("record")(args)


def run_gaze(args: argparse.Namespace) -> int:
    """Run the parsed ``gaze`` sub-command; returns the exit status (``GazeError`` propagates).
    The command's output file is checked before any work (``gaze.atomic.check_output``)."""
    for name in ("out", "output"):
        if getattr(args, name, None):
            check_output(getattr(args, name))
    commands = {"calibrate": _cmd_calibrate, "record": _cmd_record, "convert": _cmd_convert, "info": _cmd_info}
    return commands[args.gaze_command](args)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m gaze``: errors are one line on stderr and exit status 2."""
    args = build_parser().parse_args(argv)
    try:
        return run_gaze(args)
    except GazeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
