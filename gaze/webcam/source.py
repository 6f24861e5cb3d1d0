"""``WebcamSource``: the webcam estimator as a ``GazeSource``, running in a worker thread."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from gaze.errors import GazeError
from gaze.source import GazeSample, GazeSource, centre_sample
from gaze.webcam.calibration import Calibration, load_calibration
from gaze.webcam.capture import FrameSource, device_name, open_frames
from gaze.webcam.estimator import GazeEstimator

#: How long ``stop`` waits for the worker (a blocked camera read returns within a frame or two).
JOIN_TIMEOUT_S = 5.0


class WebcamSource(GazeSource):
    """Gaze from a camera index or a video file played as a camera, with an optional calibration file.

    ``start`` opens the frames (a ``GazeError`` naming the device when that fails) and
    starts a worker thread that reads frames, runs the ``GazeEstimator`` and keeps only
    the newest sample; ``sample(t)`` returns that sample (its ``t`` is the frame's time
    on the source's clock) or the screen centre, invalid, before the first frame.  A
    video file is paced to the wall clock like a camera unless ``realtime=False``; at its
    end the last sample stays.  Without a calibration the samples are the screen centre,
    invalid, with the raw feature in ``features``.  ``open_frames`` is injectable.
    """

    def __init__(
        self,
        device: int | str,
        calibration: str | None = None,
        *,
        frames: Callable[[int | str], FrameSource] = open_frames,
        realtime: bool | None = None,
    ) -> None:
        self.device = device
        self.name = device_name(device)
        self.calibration: Calibration | None = load_calibration(calibration) if calibration else None
        self._open = frames
        self._realtime = realtime
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._latest: GazeSample | None = None
        self._error: BaseException | None = None
        self._processed = 0

    @property
    def frames_processed(self) -> int:
        """How many frames the worker has turned into samples so far."""
        with self._lock:
            return self._processed

    @property
    def running(self) -> bool:
        """True while the worker thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> None:
        """Open the device or file and start the worker (no-op while running)."""
        if self.running:
            return
        frames = self._open(self.device)
        realtime = (not frames.live) if self._realtime is None else self._realtime
        self._stop.clear()
        self._error = None
        self._thread = threading.Thread(
            target=self._work, args=(frames, realtime), name=f"gaze {self.name}", daemon=True
        )
        self._thread.start()

    def _work(self, frames: FrameSource, realtime: bool) -> None:
        """Worker: read, estimate, publish the newest sample; pace video files when ``realtime``."""
        estimator = GazeEstimator(self.calibration)
        start = time.monotonic()
        try:
            while not self._stop.is_set():
                frame = frames.read()
                if frame is None:
                    break
                if realtime and self._stop.wait(max(0.0, start + frame.t - time.monotonic())):
                    break
                sample = estimator.process(frame.image, frame.t)
                with self._lock:
                    self._latest = sample
                    self._processed += 1
        except Exception as exc:  # surfaced to the caller by sample()
            self._error = exc
        finally:
            frames.close()

    def stop(self) -> None:
        """Stop the worker and release the device; safe to call twice."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(JOIN_TIMEOUT_S)
            self._thread = None

    def sample(self, t: float) -> GazeSample:
        """The newest sample (or the centre, invalid, before the first); raises the worker's failure."""
        if self._error is not None:
            raise GazeError(self.name, f"the webcam estimator failed: {self._error}") from self._error
        with self._lock:
            latest = self._latest
        return latest if latest is not None else centre_sample(t)
