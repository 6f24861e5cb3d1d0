"""``warp-hybrid gaze calibrate`` and ``gaze record``: the webcam estimator on the command line.

Both read frames by their own timestamps (``index / fps`` for a video file, the capture
clock for a camera), never by the time processing takes.  ``args`` carries ``source``
(``webcam:0``, ``webcam:PATH``, a bare index or a bare path), ``targets``, ``out``,
``calibration`` and ``screen`` (``(w, h)`` pixels or None).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

import numpy as np

from gaze.trace.simple_csv import write_simple
from gaze.webcam.calibration import (
    SETTLE_S,
    Calibration,
    TargetSchedule,
    fit_calibration,
    load_calibration,
    read_targets,
)
from gaze.webcam.capture import FrameSource, open_frames, parse_device
from gaze.webcam.estimator import GazeEstimator

NO_TARGETS = (
    "{source}: calibrating a live camera needs the 9-target display, which comes with the viewer "
    "(a later issue); for now record a calibration video while looking at targets and give "
    "--source VIDEO --targets targets.csv (rows t,x,y, normalised, origin top-left)"
)


@dataclass(frozen=True)
class Recording:
    """Per-frame estimator output: times (s), normalised points, confidences, validity, and
    the estimator's processing time per frame (ms, decoding excluded)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    confidence: np.ndarray
    valid: np.ndarray
    ms: np.ndarray


def calibrate_stream(
    frames: FrameSource, schedule: TargetSchedule, where: str, estimator: GazeEstimator | None = None
) -> tuple[Calibration, int]:
    """Measure every frame of ``frames`` (a live camera until the last target has been shown
    for the median target duration) and fit a calibration; returns it and the frame count."""
    dwell = float(np.median(np.diff(schedule.t))) if len(schedule.t) > 1 else 1.0
    end = schedule.t[-1] + dwell
    estimator = estimator or GazeEstimator()
    t, features, references = [], [], []
    while (frame := frames.read()) is not None and not (frames.live and frame.t > end):
        m = estimator.measure(frame.image, frame.t)
        t.append(frame.t)
        features.append(m.features if m.features is not None else (np.nan, np.nan))
        references.append(m.reference)
    reference = estimator.tracker.reference
    # Frames measured against a face reference that was later replaced do not share its anchor.
    valid = np.array([r is reference for r in references]) & np.isfinite(np.array(features)).all(axis=1)
    calibration = fit_calibration(np.array(t), np.array(features), valid, schedule, SETTLE_S, reference, where)
    return calibration, len(t)


def record_stream(frames: FrameSource, estimator: GazeEstimator) -> Recording:
    """Run the estimator over every frame (a live camera until Ctrl-C)."""
    rows: list[tuple[float, float, float, float, bool, float]] = []
    try:
        while (frame := frames.read()) is not None:
            start = time.perf_counter()
            s = estimator.process(frame.image, frame.t)
            rows.append((s.t, s.x, s.y, s.confidence, s.valid, 1000.0 * (time.perf_counter() - start)))
    except KeyboardInterrupt:
        if not frames.live or not rows:
            raise
    t, x, y, confidence, valid, ms = (np.array(column) for column in zip(*rows, strict=True))
    return Recording(t, x, y, confidence, valid.astype(bool), ms)


def run_calibrate(args: argparse.Namespace) -> int:
    """``gaze calibrate``: fit a calibration from a source and a targets file, save it as JSON;
    returns the exit status (2 with a message when there is no targets file)."""
    device = parse_device(args.source)
    if args.targets is None:
        if isinstance(device, int):
            print(NO_TARGETS.format(source=args.source), file=sys.stderr)
        else:
            print(
                f"{args.source}: a calibration video needs --targets targets.csv (rows t,x,y: the target "
                "shown from t until the next row's t)",
                file=sys.stderr,
            )
        return 2
    schedule = read_targets(args.targets)
    with open_frames(device) as frames:
        calibration, count = calibrate_stream(frames, schedule, f"{args.source} with targets {args.targets}")
    calibration.save(args.out)
    print(
        f"{args.out}: quadratic calibration from {calibration.targets} of {len(schedule.t)} targets, "
        f"{calibration.samples} settled frames of {count}; residual {calibration.residual_rms:.4f} rms "
        "(normalised screen units)"
    )
    return 0


def run_record(args: argparse.Namespace) -> int:
    """``gaze record``: run the calibrated estimator over a source (a video to its end, a live
    camera until Ctrl-C) and write a simple CSV trace; returns the exit status."""
    estimator = GazeEstimator(load_calibration(args.calibration))
    with open_frames(args.source) as frames:
        rec = record_stream(frames, estimator)
    write_simple(args.out, rec.t, rec.x, rec.y, rec.confidence, rec.valid, args.screen)
    print(
        f"{args.out}: {len(rec.t)} samples ({int(rec.valid.sum())} valid) over {rec.t[-1] - rec.t[0]:.3f} s "
        f"from {frames.name}"
    )
    return 0
