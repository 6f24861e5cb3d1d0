"""Replaying a gaze trace over an animated scene: video, stats CSV, animation,
interruption and a gaze source that fails mid-replay."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from gaze.fixed import FixedSource
from gaze.source import GazeSample
from warp_hybrid.renderer import RenderSettings
from warp_hybrid.replay.loop import FRAME_STAGES, AdaptiveLoop, LoopSettings
from warp_hybrid.replay.run import ReplayInterrupted, ReplayOutputs, SteadyGaze, _Interrupts, replay
from warp_hybrid.replay.stats_csv import FIXED_COLUMNS, read_stats, stats_columns
from warp_hybrid.scene.open import open_scene_source

ROOT = Path(__file__).resolve().parents[2]
ANIMATED = ROOT / "scenes" / "textured_animated.usda"
W, H = 64, 48


def _settings(device: str, mode: str = "hybrid") -> RenderSettings:
    return RenderSettings(width=W, height=H, device=device, mode=mode, threads=1)


def _video_frames(path: Path) -> tuple[int, int, int]:
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = [f for f in container.decode(stream)]
        assert stream.codec_context.name == "h264" and frames[0].format.name == "yuv420p"
        return len(frames), frames[0].width, frames[0].height


def test_a_short_replay_writes_a_video_and_one_row_per_frame(device: str, tmp_path: Path) -> None:
    outputs = ReplayOutputs(video=tmp_path / "r.mp4", stats=tmp_path / "r.csv", summary_json=tmp_path / "s.json")
    source = open_scene_source(ANIMATED)
    with AdaptiveLoop(source, _settings(device), LoopSettings(fps=12.0)) as loop:
        result = replay(loop, FixedSource(0.3, 0.6), 5, outputs, warm_up=1, progress=False)
    assert result.frames == 5 and not result.interrupted
    assert _video_frames(outputs.video) == (5, W, H)
    capture = cv2.VideoCapture(str(outputs.video))
    count = 0
    while True:
        ok, image = capture.read()
        if not ok:
            break
        assert image.shape == (H, W, 3)
        count += 1
    capture.release()
    assert count == 5
    rows = read_stats(outputs.stats)
    assert [r["frame"] for r in rows] == list(range(5))
    assert list(rows[0]) == list(stats_columns(FRAME_STAGES))
    assert list(rows[0])[: len(FIXED_COLUMNS)] == list(FIXED_COLUMNS)
    np.testing.assert_allclose([r["t"] for r in rows], np.arange(5) / 12.0, atol=1e-6)
    for r in rows:
        assert (
            r["gaze_x"] == pytest.approx(0.3)
            and r["gaze_valid"]
            and r["budget_ms"] == pytest.approx(1000 / 12, abs=1e-3)
        )
        assert r["frame_ms"] >= r["scene_update_ms"] + r["refit_ms"] + r["raster_ms"]
        # whole pixels: the traced share may pass the planned area by half a percent at 64x48
        assert 0.0 < r["traced_fraction"] <= r["window_fraction"] + 0.006 and r["window_fraction"] <= 1.0
    assert (tmp_path / "s.json").is_file()
    assert {p.name for p in tmp_path.iterdir()} == {"r.mp4", "r.csv", "s.json"}  # no partial files left


def test_an_animated_object_moves_between_frames(device: str) -> None:
    source = open_scene_source(ANIMATED)
    with AdaptiveLoop(source, _settings(device, "raster"), LoopSettings(fps=24.0, adaptive=False)) as loop:
        gaze = GazeSample(0.5, 0.5, 0.0)
        first = loop.step(0.0, gaze).frame.aovs()["depth"].copy()
        second = loop.step(0.25, gaze).frame.aovs()["depth"]  # the cube turned 45 degrees
        again = loop.step(0.0, gaze).frame.aovs()["depth"]
    changed = ~np.isclose(first, second, equal_nan=True)
    assert changed.sum() > 20  # the animated mesh moved (and with it its depth)
    np.testing.assert_array_equal(again, first)  # back at t = 0: the same frame


def test_a_gaze_trace_shorter_than_the_replay_holds_its_last_point(tmp_path: Path) -> None:
    trace = tmp_path / "short.csv"
    trace.write_text("t,x,y,confidence\n0.0,0.2,0.3,1\n0.1,0.4,0.5,1\n")
    from gaze.factory import open_source

    with open_source(f"trace:{trace}") as source:
        steady = SteadyGaze(source)
        inside = steady.sample(0.1)
        after = steady.sample(0.5)
    assert inside.valid and (inside.x, inside.y) == pytest.approx((0.4, 0.5))
    assert not after.valid and (after.x, after.y) == pytest.approx((0.4, 0.5)) and after.t == 0.5


def test_a_failing_gaze_source_holds_the_last_valid_point() -> None:
    class Unplugged(FixedSource):
        calls = 0

        def sample(self, t: float) -> GazeSample:
            self.calls += 1
            if self.calls > 2:
                raise OSError("camera unplugged")
            return super().sample(t)

    steady = SteadyGaze(Unplugged(0.7, 0.2))
    samples = [steady.sample(k / 10) for k in range(5)]
    assert [s.valid for s in samples] == [True, True, False, False, False]
    assert all((s.x, s.y) == pytest.approx((0.7, 0.2)) for s in samples)
    assert steady.failure == "camera unplugged"


def _signal_self(sig: int) -> None:
    """Send ``sig`` to this process and give its handler the bytecodes to run in."""
    os.kill(os.getpid(), sig)
    for _ in range(100):
        time.sleep(0.001)


@pytest.mark.parametrize(("sig", "raised"), [(signal.SIGTERM, ReplayInterrupted), (signal.SIGINT, KeyboardInterrupt)])
def test_an_interruption_while_a_frame_is_written_waits_for_its_last_output(sig: int, raised: type) -> None:
    """A signal between a frame's video frame and its CSV row (the replay's race) is held
    until both are written; outside the writes it interrupts at once."""
    interrupts = _Interrupts()
    written = []
    before = signal.getsignal(sig)
    with interrupts.installed():
        with pytest.raises(raised):
            with interrupts.writing():
                written.append("video frame")
                _signal_self(sig)
                written.append("csv row")
        assert written == ["video frame", "csv row"]
        with pytest.raises(raised):
            _signal_self(sig)
            written.append("never")
    assert written == ["video frame", "csv row"]
    assert signal.getsignal(sig) == before  # the replay's handlers are gone after it


def test_sigterm_mid_replay_leaves_a_playable_video_and_whole_rows(tmp_path: Path) -> None:
    video, stats = tmp_path / "cut.mp4", tmp_path / "cut.csv"
    command = [
        sys.executable, "-m", "warp_hybrid", "replay", str(ANIMATED), "--gaze", "fixed:0.5,0.5", "--fps", "24",
        "--frames", "100000", "--size", f"{W}x{H}", "--out", str(video), "--stats", str(stats), "--warm-up", "0",
        "--threads", "1",
    ]  # fmt: skip
    proc = subprocess.Popen(command, cwd=ROOT, env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 240.0
        partial = None
        while time.monotonic() < deadline and proc.poll() is None:
            partial = next(tmp_path.glob("*cut*.partial.csv"), None)
            if partial is not None and partial.read_text().count("\n") >= 4:
                break
            time.sleep(0.2)
        assert partial is not None and proc.poll() is None, proc.stderr.read().decode() if proc.poll() else "no rows"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err.decode()
    rows = read_stats(stats)
    assert len(rows) >= 3 and [r["frame"] for r in rows] == list(range(len(rows)))
    frames, width, height = _video_frames(video)
    assert (width, height) == (W, H) and frames == len(rows)
    assert not list(tmp_path.glob("*.partial.*"))
