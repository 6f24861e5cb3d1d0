"""Synthetic webcam videos (rendered once per session): a 9-point calibration and a 12-target test."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from gaze.webcam import synthetic
from gaze.webcam.calibration import Calibration, TargetSchedule
from gaze.webcam.capture import open_frames
from gaze.webcam.commands import calibrate_stream

CALIBRATION_S = 4.5
TEST_S = 6.0


@dataclass(frozen=True)
class Videos:
    """The rendered calibration and test videos, the calibration targets and their CSV."""

    calibration: synthetic.SyntheticVideo
    test: synthetic.SyntheticVideo
    targets: np.ndarray
    targets_csv: Path


@pytest.fixture(scope="session")
def videos(tmp_path_factory: pytest.TempPathFactory) -> Videos:
    """MJPG .avi calibration video and mp4v .mp4 test video of the astronaut with drawn eyes."""
    folder = tmp_path_factory.mktemp("webcam")
    targets = synthetic.calibration_targets()
    csv = folder / "targets.csv"
    synthetic.write_targets_csv(csv, targets)
    calibration = synthetic.render_video(folder / "calibration.avi", targets, CALIBRATION_S, seed=0)
    test = synthetic.render_video(folder / "test.mp4", synthetic.evaluation_targets(), TEST_S, seed=1)
    return Videos(calibration, test, targets, csv)


@pytest.fixture(scope="session")
def calibration(videos: Videos) -> Calibration:
    """The calibration fitted on the calibration video (through the capture layer)."""
    with open_frames(videos.calibration.path) as frames:
        fitted, count = calibrate_stream(frames, TargetSchedule(*videos.targets.T), videos.calibration.path)
    assert count == len(videos.calibration.t)
    return fitted
