"""Frame sources for the webcam estimator: a live camera or a video file played as one.

Both yield ``Frame``s with a timestamp in seconds from the start of the source: for a
video file ``index / fps`` (the frames' own times, not the time processing takes); for
a live camera the capture clock (``time.monotonic`` at each grab, from the first grab).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaze.errors import GazeError

WEBCAM_PREFIX = "webcam:"


@dataclass(frozen=True)
class Frame:
    """One captured image (BGR uint8, rows top to bottom) and its time in seconds."""

    index: int
    t: float
    image: np.ndarray


class FrameSource(ABC):
    """An open stream of frames; ``read`` returns None at the end; close it when done."""

    name: str
    live: bool

    @abstractmethod
    def read(self) -> Frame | None:
        """The next frame, or None when the stream has ended."""

    @abstractmethod
    def close(self) -> None:
        """Release the device or file; safe to call twice."""

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class VideoFileFrames(FrameSource):
    """A video file played as a camera; frame ``k`` has ``t = k / fps``."""

    live = False

    def __init__(self, path: str | Path) -> None:
        self.name = str(path)
        if not Path(path).is_file():
            raise GazeError(self.name, "video file not found")
        self._capture = cv2.VideoCapture(self.name)
        if not self._capture.isOpened():
            raise GazeError(self.name, "the video does not open (not a format this OpenCV build decodes)")
        self.fps = float(self._capture.get(cv2.CAP_PROP_FPS))
        if not math.isfinite(self.fps) or self.fps <= 0.0:
            self.close()
            raise GazeError(self.name, "the video has no frame rate, so its frames have no timestamps")
        self._index = 0
        self._first = self._grab()
        if self._first is None:
            self.close()
            raise GazeError(self.name, "the video yields no frames")

    def _grab(self) -> np.ndarray | None:
        ok, image = self._capture.read()
        return image if ok and image is not None else None

    def read(self) -> Frame | None:
        """The next frame at ``t = index / fps``, or None after the last one."""
        if self._first is not None:
            image, self._first = self._first, None
        else:
            image = self._grab()
        if image is None:
            return None
        frame = Frame(self._index, self._index / self.fps, image)
        self._index += 1
        return frame

    def close(self) -> None:
        """Release the file."""
        self._capture.release()


class CameraFrames(FrameSource):
    """A live camera by index; ``t`` is the capture clock from the first grab."""

    live = True

    def __init__(self, index: int) -> None:
        self.name = f"{WEBCAM_PREFIX}{index}"
        self._capture = cv2.VideoCapture(index)
        if not self._capture.isOpened():
            raise GazeError(self.name, f"no camera at index {index} (it does not open)")
        self._index = 0
        self._t0: float | None = None
        first = self._grab()
        if first is None:
            self.close()
            raise GazeError(self.name, "the camera opened but delivers no frames")
        self._first: Frame | None = first

    def _grab(self) -> Frame | None:
        if not self._capture.grab():
            return None
        stamp = time.monotonic()
        ok, image = self._capture.retrieve()
        if not ok or image is None:
            return None
        if self._t0 is None:
            self._t0 = stamp
        frame = Frame(self._index, stamp - self._t0, image)
        self._index += 1
        return frame

    def read(self) -> Frame | None:
        """The next frame, or None when the camera stops delivering."""
        if self._first is not None:
            frame, self._first = self._first, None
            return frame
        return self._grab()

    def close(self) -> None:
        """Release the camera."""
        self._capture.release()


def parse_device(spec: int | str) -> int | str:
    """``webcam:0`` / ``0`` / ``0`` (int) -> camera index 0; ``webcam:PATH`` / ``PATH`` -> the path."""
    if isinstance(spec, int):
        return spec
    text = spec.strip()
    if text.lower().startswith(WEBCAM_PREFIX):
        text = text[len(WEBCAM_PREFIX) :].strip()
    if not text:
        raise GazeError(str(spec), "expected webcam:INDEX or webcam:VIDEO_PATH")
    return int(text) if text.isdigit() else text


def device_name(device: int | str) -> str:
    """How messages name a device: ``webcam:INDEX`` for cameras, the path for videos."""
    device = parse_device(device)
    return f"{WEBCAM_PREFIX}{device}" if isinstance(device, int) else device


def open_frames(device: int | str) -> FrameSource:
    """Open a camera (an index) or a video file (a path); ``GazeError`` naming it if it fails."""
    device = parse_device(device)
    if isinstance(device, int):
        return CameraFrames(device)
    return VideoFileFrames(device)
