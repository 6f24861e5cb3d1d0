"""The replay's video: H.264 in MP4 (yuv420p), encoded on a background thread through PyAV.

The file plays in browsers and ordinary players: libx264 (PyAV's bundled FFmpeg),
High profile, pixel format yuv420p, the BT.709 matrix in limited ("TV") range, tagged
BT.709 primaries with the sRGB transfer curve (the frames are sRGB-encoded), and the
index (``moov``) moved to the front on close (``movflags=+faststart``) so playback
starts before the whole file has arrived.  Encoder options, chosen for speed at a
quality where a rendered frame shows no visible loss: ``preset=veryfast``, ``crf=20``
(x264's defaults are ``medium`` and 23).

``VideoWriter.write`` copies the frame and puts it on a bounded queue (``queue_size``
frames; a full queue blocks the caller, so memory stays flat however long the replay);
one encoder thread converts, encodes and muxes.  yuv420p needs even sizes: an odd
width or height is padded by repeating the last column or row, so the video is
``encoded_width x encoded_height`` (the next even numbers).

The file is written under a temporary name beside the target and renamed into place by
``close`` (``partial.PartialFile``), which also drains the queue and flushes the
encoder, so ``close`` in a ``finally:`` after a ``KeyboardInterrupt`` (or an exception
raised by a SIGTERM handler) leaves a playable video of every frame written so far.
An exception in the encoder thread is raised as ``WarpHybridError`` by the next
``write`` or by ``close``, and the temporary file is then removed.  A process killed
outright (no ``close``) leaves the target untouched and an unplayable ``.partial.mp4``.
"""

from __future__ import annotations

import math
import os
import queue
import threading
import time
from contextlib import AbstractContextManager
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
from av.error import FFmpegError
from av.video.reformatter import ColorRange, Colorspace

from ..errors import WarpHybridError
from .partial import PartialFile

#: libx264 options (see the module docstring).
X264_OPTIONS = {"preset": "veryfast", "crf": "20"}
#: The colour description written into the stream (as encoder options, which every PyAV
#: version passes to FFmpeg): BT.709 matrix and primaries, limited range, sRGB transfer.
COLOUR_TAGS = {"colorspace": "bt709", "color_primaries": "bt709", "color_range": "tv", "color_trc": "iec61966-2-1"}

# Marks the end of the frames on the queue.
_END = object()


class VideoWriter(AbstractContextManager["VideoWriter"]):
    """Writes (H, W, 3) uint8 RGB frames to an H.264 MP4 at ``fps`` frames per second.

    A context manager (``__exit__`` calls ``close``).  ``path``'s missing folders are
    created; a path that cannot be written, or an encoder that cannot be opened, raises
    ``WarpHybridError`` naming the file.  One thread writes.  ``fps`` may be a float or
    a ``Fraction``; it is stored as the nearest fraction with a denominator up to 1001
    (``30000 / 1001`` stays NTSC's 29.97 exactly).
    """

    def __init__(
        self, path: str | os.PathLike[str], width: int, height: int, fps: float, *, queue_size: int = 8
    ) -> None:
        if int(width) < 1 or int(height) < 1:
            raise ValueError(f"video size must be positive, got {width}x{height}")
        if not (math.isfinite(float(fps)) and float(fps) > 0.0):
            raise ValueError(f"video frame rate must be a positive number, got {fps}")
        if queue_size < 1:
            raise ValueError(f"queue_size must be at least 1, got {queue_size}")
        self.path = Path(path)
        self.width, self.height = int(width), int(height)
        self.encoded_width = self.width + self.width % 2
        self.encoded_height = self.height + self.height % 2
        self.fps = Fraction(fps).limit_denominator(1001)
        self._file = PartialFile(self.path, ".partial.mp4")
        try:
            self._container, self._stream = self._open()
        except BaseException:
            self._file.discard()
            raise
        self._queue: queue.Queue[object] = queue.Queue(maxsize=queue_size)
        self._frames = 0
        self._encode_s = 0.0
        self._error: BaseException | None = None
        self._error_reported = False
        self._end_queued = False
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=f"video-encoder {self.path.name}", daemon=True)
        self._thread.start()

    @property
    def frames(self) -> int:
        """Frames encoded so far: every frame written, once ``close`` has returned."""
        return self._frames

    @property
    def encode_ms(self) -> float:
        """Total time the encoder thread spent converting, encoding and muxing (ms),
        measured in that thread (the final flush included once ``close`` returned)."""
        return self._encode_s * 1e3

    def write(self, image: np.ndarray) -> None:
        """Queue one (height, width, 3) uint8 RGB frame (row 0 at the top) for encoding.

        The frame is copied (padded to the even size), so the caller may reuse its
        buffer at once; blocks while the queue is full.  Raises ``WarpHybridError`` if
        the encoder thread has failed, ``ValueError`` for a frame of the wrong shape.
        """
        self._raise_encoder_error()
        if self._end_queued:
            raise WarpHybridError(f"{self.path}: write after close")
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.shape != (self.height, self.width, 3):
            raise ValueError(
                f"{self.path}: expected a ({self.height}, {self.width}, 3) uint8 frame, got {image.shape} {image.dtype}"
            )
        pad_rows, pad_cols = self.encoded_height - self.height, self.encoded_width - self.width
        if pad_rows or pad_cols:
            frame = np.pad(image, ((0, pad_rows), (0, pad_cols), (0, 0)), mode="edge")
        else:
            frame = np.array(image, order="C", copy=True)
        self._queue.put(frame)

    def close(self) -> None:
        """Drain the queue, flush the encoder, close the container and rename the file
        into place.  Safe to call again (a no-op once done), and to call again after an
        interruption of ``close`` itself.  Raises ``WarpHybridError`` for an encoder
        error not raised by ``write`` yet (the temporary file is removed then)."""
        if self._closed:
            return
        if not self._end_queued:
            self._queue.put(_END)
            self._end_queued = True
        self._thread.join()
        self._closed = True
        if self._error is not None:
            self._file.discard()
            self._raise_encoder_error()
            return
        self._file.commit()

    def __exit__(self, *exc: object) -> None:
        """Close the writer (also after an exception: the frames written are kept)."""
        self.close()

    def _open(self) -> tuple[av.container.OutputContainer, av.VideoStream]:
        """The MP4 container on the temporary file and its configured H.264 stream."""
        try:
            container = av.open(str(self._file.temp), "w", format="mp4", options={"movflags": "+faststart"})
        except (FFmpegError, OSError) as exc:
            raise WarpHybridError(f"{self.path}: cannot open the video for writing: {exc}") from None
        try:
            stream = container.add_stream("libx264", rate=self.fps, options={**X264_OPTIONS, **COLOUR_TAGS})
            stream.width, stream.height = self.encoded_width, self.encoded_height
            stream.pix_fmt = "yuv420p"
        except (FFmpegError, OSError, ValueError) as exc:
            container.close()
            raise WarpHybridError(f"{self.path}: cannot set up the H.264 encoder (libx264): {exc}") from None
        return container, stream

    def _run(self) -> None:
        """The encoder thread: encode queued frames until the end mark, then flush and
        close the container.  After a failure it keeps draining the queue (so ``write``
        never blocks on it) and keeps the exception for ``write`` / ``close``."""
        while True:
            item = self._queue.get()
            if item is _END:
                break
            if self._error is None:
                self._encode_timed(item)
        if self._error is None:
            self._encode_timed(None)
        try:
            self._container.close()
        except BaseException as exc:  # kept for the writing thread
            if self._error is None:
                self._error = exc

    def _encode_timed(self, image: np.ndarray | None) -> None:
        """``_encode(image)``, its time added to ``encode_ms``, any exception kept for
        the writing thread (``write`` / ``close`` raise it)."""
        start = time.perf_counter()
        try:
            self._encode(image)
        except BaseException as exc:  # kept for the writing thread
            self._error = exc
        finally:
            self._encode_s += time.perf_counter() - start

    def _encode(self, image: np.ndarray | None) -> None:
        """Convert one RGB frame to yuv420p (BT.709, limited range) and encode and mux
        it; ``None`` flushes the encoder."""
        frame = None
        if image is not None:
            frame = av.VideoFrame.from_ndarray(image, format="rgb24").reformat(
                format="yuv420p", dst_colorspace=Colorspace.ITU709, dst_color_range=ColorRange.MPEG
            )
            frame.pts = self._frames
        for packet in self._stream.encode(frame):
            self._container.mux(packet)
        if image is not None:
            self._frames += 1

    def _raise_encoder_error(self) -> None:
        """Raise the encoder thread's exception as ``WarpHybridError``, once."""
        if self._error is not None and not self._error_reported:
            self._error_reported = True
            raise WarpHybridError(f"{self.path}: video encoding failed: {self._error}") from self._error
