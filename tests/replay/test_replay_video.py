"""The replay video: H.264 / yuv420p MP4 that PyAV and OpenCV read back, written atomically."""

from __future__ import annotations

import os
import time
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from warp_hybrid.errors import WarpHybridError
from warp_hybrid.replay.video import VideoWriter

# H.264 at crf 20 is lossy: a flat patch comes back within this many 8-bit steps.
TOLERANCE = 6
LEFT, RIGHT = (200, 40, 90), (20, 220, 128)


def two_colour_frame(width: int, height: int) -> np.ndarray:
    """A frame whose left half is LEFT and right half RIGHT (flat patches survive H.264)."""
    image = np.empty((height, width, 3), np.uint8)
    image[:, : width // 2] = LEFT
    image[:, width // 2 :] = RIGHT
    return image


def write_frames(path: Path, width: int, height: int, count: int) -> VideoWriter:
    with VideoWriter(path, width, height, 30) as writer:
        for _ in range(count):
            writer.write(two_colour_frame(width, height))
    return writer


def read_pyav(path: Path) -> tuple[av.VideoStream, list[np.ndarray]]:
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = [frame.to_ndarray(format="rgb24") for frame in container.decode(stream)]
    return stream, frames


def read_opencv(path: Path) -> list[np.ndarray]:
    capture = cv2.VideoCapture(str(path))
    assert capture.isOpened()
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    return frames


def test_video_reads_back_in_pyav_and_opencv(tmp_path: Path) -> None:
    path = tmp_path / "replay.mp4"
    writer = write_frames(path, 64, 48, 5)
    assert writer.frames == 5
    assert writer.encode_ms > 0.0
    stream, frames = read_pyav(path)
    assert stream.codec_context.name == "h264"
    assert stream.codec_context.pix_fmt == "yuv420p"
    assert (stream.width, stream.height) == (64, 48)
    assert len(frames) == 5
    data = path.read_bytes()
    assert data.find(b"moov") < data.find(b"mdat")  # faststart: the index comes first
    first = frames[0].astype(int)
    assert np.abs(first[8:40, 4:28] - LEFT).max() <= TOLERANCE
    assert np.abs(first[8:40, 36:60] - RIGHT).max() <= TOLERANCE
    bgr = read_opencv(path)
    assert len(bgr) == 5
    assert bgr[0].shape == (48, 64, 3)
    assert np.abs(bgr[0][8:40, 4:28, ::-1].astype(int) - LEFT).max() <= TOLERANCE


def test_odd_size_is_padded_to_even_by_repeating_the_edge(tmp_path: Path) -> None:
    path = tmp_path / "odd.mp4"
    writer = write_frames(path, 63, 47, 3)
    assert (writer.encoded_width, writer.encoded_height) == (64, 48)
    stream, frames = read_pyav(path)
    assert (stream.width, stream.height) == (64, 48)
    assert len(frames) == 3
    # The added column and row repeat the last ones (RIGHT), not black.
    assert np.abs(frames[0][:, 63].astype(int) - RIGHT).max() <= TOLERANCE
    assert np.abs(frames[0][47, 36:].astype(int) - RIGHT).max() <= TOLERANCE
    assert len(read_opencv(path)) == 3


def test_file_mode_and_no_temporary_left(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        path = tmp_path / "new" / "folder" / "replay.mp4"
        with VideoWriter(path, 32, 32, 24) as writer:
            writer.write(two_colour_frame(32, 32))
            assert not path.exists()
            assert [p.name.endswith(".partial.mp4") for p in path.parent.iterdir()] == [True]
    finally:
        os.umask(old)
    assert os.stat(path).st_mode & 0o777 == 0o644
    assert [p.name for p in path.parent.iterdir()] == ["replay.mp4"]


def test_interrupted_replay_leaves_a_playable_video(tmp_path: Path) -> None:
    path = tmp_path / "interrupted.mp4"
    writer = VideoWriter(path, 48, 32, 60)
    with pytest.raises(KeyboardInterrupt):
        try:
            for index in range(10):
                if index == 4:
                    raise KeyboardInterrupt
                writer.write(two_colour_frame(48, 32))
        finally:
            writer.close()
    assert writer.frames == 4
    stream, frames = read_pyav(path)
    assert len(frames) == 4
    assert len(read_opencv(path)) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["interrupted.mp4"]
    writer.close()  # a second close is a no-op


def failing_encoder(image: np.ndarray | None) -> None:
    raise RuntimeError("encoder exploded")


def test_encoder_error_surfaces_on_close(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "broken.mp4"
    writer = VideoWriter(path, 32, 32, 30)
    monkeypatch.setattr(writer, "_encode", failing_encoder)
    writer.write(two_colour_frame(32, 32))
    with pytest.raises(WarpHybridError, match="broken.mp4: video encoding failed: encoder exploded"):
        writer.close()
    assert list(tmp_path.iterdir()) == []


def test_encoder_error_surfaces_on_the_next_write(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "broken.mp4"
    writer = VideoWriter(path, 32, 32, 30, queue_size=2)
    monkeypatch.setattr(writer, "_encode", failing_encoder)
    deadline = time.monotonic() + 30.0
    with pytest.raises(WarpHybridError, match="encoder exploded"):
        while time.monotonic() < deadline:  # the encoder thread fails on the first frame
            writer.write(two_colour_frame(32, 32))
            time.sleep(0.01)
    writer.close()  # already reported: close cleans up without raising again
    assert list(tmp_path.iterdir()) == []


def test_bad_paths_and_frames(tmp_path: Path) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(WarpHybridError, match="a_file/replay.mp4"):
        VideoWriter(blocker / "replay.mp4", 32, 32, 30)
    with pytest.raises(WarpHybridError, match="is a folder"):
        VideoWriter(tmp_path, 32, 32, 30)
    with VideoWriter(tmp_path / "ok.mp4", 32, 32, 30) as writer:
        with pytest.raises(ValueError, match=r"\(32, 32, 3\) uint8"):
            writer.write(np.zeros((32, 31, 3), np.uint8))
    with pytest.raises(WarpHybridError, match="write after close"):
        writer.write(two_colour_frame(32, 32))
