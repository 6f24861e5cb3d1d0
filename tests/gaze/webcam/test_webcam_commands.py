"""``gaze calibrate`` and ``gaze record`` end to end on the synthetic videos."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from gaze.trace.simple_csv import read_simple
from gaze.webcam import synthetic
from gaze.webcam.calibration import load_calibration
from gaze.webcam.commands import run_calibrate, run_record

if TYPE_CHECKING:
    from conftest import Videos


def test_calibrate_then_record(videos: Videos, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    calib = tmp_path / "calib.json"
    args = argparse.Namespace(
        source=f"webcam:{videos.calibration.path}",
        targets=str(videos.targets_csv),
        out=str(calib),
        calibration=None,
        screen=None,
    )
    assert run_calibrate(args) == 0
    assert "from 9 of 9 targets, 81 settled frames of 135" in capsys.readouterr().out
    calibration = load_calibration(calib)
    assert calibration.reference is not None and calibration.targets == 9

    trace = tmp_path / "trace.csv"
    args = argparse.Namespace(
        source=videos.test.path, targets=None, out=str(trace), calibration=str(calib), screen=(1920, 1080)
    )
    assert run_record(args) == 0
    assert "180 samples (180 valid)" in capsys.readouterr().out
    lines = trace.read_text().splitlines()
    assert lines[0] == "t,x,y,confidence" and len(lines) == 181
    t = np.array([float(line.split(",")[0]) for line in lines[1:]])
    np.testing.assert_allclose(t, np.arange(180) / 30.0, atol=1e-6)  # frame times, not processing time
    data = read_simple(trace, screen_px=(1920, 1080))
    deg, _ = synthetic.gaze_errors(videos.test, data.x, data.y)
    assert np.median(deg) <= 1.5


def test_live_camera_without_targets_says_the_viewer_shows_them(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    args = argparse.Namespace(
        source="webcam:0", targets=None, out=str(tmp_path / "c.json"), calibration=None, screen=None
    )
    assert run_calibrate(args) != 0
    err = capsys.readouterr().err
    assert "webcam:0" in err and "viewer" in err and "--targets" in err
    assert not (tmp_path / "c.json").exists()
