"""Frame sources: timestamps from the video, clear errors for videos and cameras that do not open."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from gaze.errors import GazeError
from gaze.webcam.capture import device_name, open_frames, parse_device


def test_parse_device() -> None:
    assert parse_device("webcam:0") == 0
    assert parse_device("webcam:12") == 12
    assert parse_device("3") == 3
    assert parse_device(2) == 2
    assert parse_device("webcam:clips/a.avi") == "clips/a.avi"
    assert parse_device("clips/a.avi") == "clips/a.avi"
    assert device_name(5) == "webcam:5" and device_name("webcam:x.mp4") == "x.mp4"
    with pytest.raises(GazeError, match="expected webcam:INDEX"):
        parse_device("webcam:")


def test_video_frames_are_timestamped_index_over_fps(tmp_path: Path) -> None:
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (64, 48))
    for k in range(7):
        writer.write(np.full((48, 64, 3), 30 * k, np.uint8))
    writer.release()
    with open_frames(f"webcam:{path}") as frames:
        assert not frames.live
        read = []
        while (frame := frames.read()) is not None:
            read.append(frame)
    assert [f.index for f in read] == list(range(7))
    assert [f.t for f in read] == [k / 25.0 for k in range(7)]
    assert read[3].image.shape == (48, 64, 3)
    assert abs(float(read[3].image.mean()) - 90.0) < 3.0


def test_video_that_does_not_open_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.avi"
    path.write_text("this is not a video\n")
    with pytest.raises(GazeError, match="broken.avi: the video does not open"):
        open_frames(str(path))
    with pytest.raises(GazeError, match="missing.mp4: video file not found"):
        open_frames(str(tmp_path / "missing.mp4"))


def test_missing_camera_names_the_device() -> None:
    with pytest.raises(GazeError, match="webcam:99: no camera at index 99"):
        open_frames("webcam:99")
