"""WebcamSource: a worker thread that keeps only the newest sample and stops cleanly."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from gaze.errors import GazeError
from gaze.webcam.calibration import Calibration
from gaze.webcam.capture import Frame, FrameSource
from gaze.webcam.source import WebcamSource

if TYPE_CHECKING:
    from conftest import Videos

WAIT_S = 10.0


def wait_for(condition, what: str) -> None:
    """Poll ``condition`` until it holds; fail (not hang) after ``WAIT_S``."""
    deadline = time.monotonic() + WAIT_S
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.002)


class FakeCamera(FrameSource):
    """Blank 64x48 frames at t = index / 10, delivered as fast as asked; ``limit`` frames, or endless."""

    live = True
    name = "fake"

    def __init__(self, limit: int | None = None) -> None:
        self.limit = limit
        self.index = 0
        self.closed = False
        self.closed_by = ""

    def read(self) -> Frame | None:
        if self.limit is not None and self.index >= self.limit:
            return None
        time.sleep(0.001)
        frame = Frame(self.index, self.index / 10.0, np.full((48, 64, 3), 100, np.uint8))
        self.index += 1
        return frame

    def close(self) -> None:
        self.closed = True
        self.closed_by = threading.current_thread().name


def test_worker_keeps_only_the_newest_sample() -> None:
    frames = FakeCamera(limit=25)
    source = WebcamSource("fake", frames=lambda device: frames, realtime=False)
    first = source.sample(0.0)
    assert (first.x, first.y, first.valid) == (0.5, 0.5, False)  # the centre before any frame
    with source:
        wait_for(lambda: not source.running, "the 25 frames")
        newest = source.sample(9.0)
        # Nobody read the 24 older samples: a queue would hand out frame 0 now.
        assert source.frames_processed == 25 and newest.t == pytest.approx(2.4)
        assert source.sample(10.0) is newest
        assert not newest.valid and newest.confidence == 0.0  # a blank frame shows no face
    assert frames.closed and frames.closed_by == "gaze fake"


def test_worker_stops_cleanly_while_frames_keep_coming() -> None:
    frames = FakeCamera()
    source = WebcamSource("fake", frames=lambda device: frames, realtime=False)
    source.start()
    source.start()  # no second worker
    wait_for(lambda: source.frames_processed >= 3, "a few frames")
    source.stop()
    assert not source.running and frames.closed
    count = frames.index
    time.sleep(0.05)
    assert frames.index == count  # nothing reads any more
    source.stop()  # twice is fine


def test_video_file_source_with_calibration(videos: Videos, calibration: Calibration, tmp_path: Path) -> None:
    path = tmp_path / "calib.json"
    calibration.save(path)
    with WebcamSource(f"webcam:{videos.test.path}", str(path), realtime=False) as source:
        wait_for(lambda: not source.running, "the end of the video")
        last = source.sample(100.0)
    assert source.frames_processed == len(videos.test.t)
    assert last.t == pytest.approx(videos.test.t[-1]) and last.valid
    assert abs(last.x - videos.test.x[-1]) < 0.05 and abs(last.y - videos.test.y[-1]) < 0.05


def test_missing_camera_and_worker_failure_are_gaze_errors() -> None:
    with pytest.raises(GazeError, match="webcam:99"):
        WebcamSource(99).start()

    class Broken(FakeCamera):
        def read(self) -> Frame | None:
            return Frame(0, 0.0, np.zeros((4, 4, 7), np.uint8))  # not an image OpenCV converts

    source = WebcamSource("broken", frames=lambda device: Broken(), realtime=False)
    with source:
        wait_for(lambda: not source.running, "the worker to fail")
        with pytest.raises(GazeError, match="broken: the webcam estimator failed"):
            source.sample(0.0)


def test_bad_calibration_file_fails_at_construction(tmp_path: Path) -> None:
    path = tmp_path / "calib.json"
    path.write_text("[]")
    with pytest.raises(GazeError, match="calib.json: a calibration file holds one JSON object"):
        WebcamSource(0, str(path))
