"""Cursor and fixed sources, and the spec-string factory."""

from __future__ import annotations

import sys
import threading
import types
from pathlib import Path

import pytest

from gaze.cursor import CursorSource
from gaze.errors import GazeError
from gaze.factory import open_source
from gaze.fixed import FixedSource
from gaze.source import GazeSample, GazeSource
from gaze.trace.playback import TraceSource


def test_cursor_starts_at_centre_then_follows() -> None:
    with CursorSource() as cursor:
        s = cursor.sample(1.5)
        assert (s.x, s.y, s.t, s.valid, s.confidence) == (0.5, 0.5, 1.5, False, 0.0)
        cursor.set_position(0.25, 0.75)
        s = cursor.sample(2.0)
        assert (s.x, s.y, s.valid, s.confidence) == (0.25, 0.75, True, 1.0)
        cursor.set_pixel(480, 270, 1920, 1080)
        assert (cursor.sample(2.1).x, cursor.sample(2.1).y) == (0.25, 0.25)
        cursor.set_position(-0.5, 3.0)  # outside the view: clamped to its edge
        assert (cursor.sample(3.0).x, cursor.sample(3.0).y) == (0.0, 1.0)
        with pytest.raises(GazeError, match="cursor: pointer position must be finite"):
            cursor.set_position(float("nan"), 0.5)
        assert (cursor.sample(3.0).x, cursor.sample(3.0).y) == (0.0, 1.0)


def test_cursor_thread_safe() -> None:
    cursor = CursorSource()
    steps = 2000
    torn: list[tuple[float, float]] = []
    done = threading.Event()

    def writer(offset: int) -> None:
        for k in range(steps):
            v = ((k * 4 + offset) % 1000) / 1000.0
            cursor.set_position(v, 1.0 - v)

    def reader() -> None:
        while not done.is_set():
            s = cursor.sample(0.0)
            if s.valid and abs(s.x + s.y - 1.0) > 1e-12:
                torn.append((s.x, s.y))

    threads = [threading.Thread(target=writer, args=(i,)) for i in range(4)]
    watcher = threading.Thread(target=reader)
    watcher.start()
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    done.set()
    watcher.join()
    assert torn == []  # every sample is one writer's (x, y) pair, never a mix
    last = cursor.sample(0.0)
    finals = {((steps - 1) * 4 + i) % 1000 / 1000.0 for i in range(4)}
    assert last.x in finals and last.y == pytest.approx(1.0 - last.x)


def test_fixed_source() -> None:
    with FixedSource(0.2, 0.9) as fixed:
        for t in (0.0, 7.5):
            s = fixed.sample(t)
            assert (s.x, s.y, s.t, s.valid, s.confidence) == (0.2, 0.9, t, True, 1.0)
    with pytest.raises(GazeError, match=r"\[0,1\]\^2"):
        FixedSource(1.2, 0.5)


def test_factory_cursor_fixed_trace(tmp_path: Path) -> None:
    assert isinstance(open_source("cursor"), CursorSource)
    with open_source(" fixed:0.25,0.75 ") as source:
        assert (source.sample(3.0).x, source.sample(3.0).y) == (0.25, 0.75)
    path = tmp_path / "g.csv"
    path.write_text("t,x,y\n100,0.1,0.2\n101,0.3,0.6\n", encoding="utf-8")
    with open_source(f"trace:{path}") as source:
        assert isinstance(source, TraceSource)
        s = source.sample(0.5)
        assert (s.x, s.y) == pytest.approx((0.2, 0.4))
    pixels = tmp_path / "p.csv"
    pixels.write_text("t,x,y\n0,192,108\n1,960,540\n", encoding="utf-8")
    with open_source(f"trace:{pixels}?format=simple&screen=1920x1080") as source:
        assert (source.sample(0.0).x, source.sample(0.0).y) == pytest.approx((0.1, 0.1))
        assert source.screen.width_px == 1920 and source.screen.height_px == 1080
    low = tmp_path / "low.csv"
    low.write_text("t,x,y,confidence\n0,0.1,0.1,0.3\n1,0.9,0.9,0.3\n", encoding="utf-8")
    with pytest.raises(GazeError, match="no valid samples"):
        open_source(f"trace:{low}")
    assert open_source(f"trace:{low}?min_confidence=0.2").sample(0.5).valid


@pytest.mark.parametrize(
    ("spec", "problem"),
    [
        ("", "unknown kind ''"),
        ("eyes", "unknown kind 'eyes'"),
        ("cursor:1", "cursor takes no argument"),
        ("fixed", "fixed needs an argument"),
        ("fixed:", "fixed needs an argument"),
        ("fixed:0.5", "fixed needs X,Y"),
        ("fixed:1,2,3", "fixed needs X,Y"),
        ("fixed:a,b", "fixed needs X,Y"),
        ("fixed:1.5,0.2", r"must lie in \[0,1\]\^2"),
        ("fixed:nan,0.2", r"must lie in \[0,1\]\^2"),
        ("trace:", "trace needs an argument"),
        ("trace:g.csv?format=xml", "unknown trace format 'xml'"),
        ("trace:g.csv?screen=big", "screen size must look like 1920x1080"),
        ("trace:g.csv?screen=0x10", "screen size must be positive"),
        ("trace:g.csv?colour=red", "unknown option 'colour' for trace"),
        ("trace:g.csv?format", "malformed option 'format'"),
        ("trace:g.csv?format=simple&format=tobii", "given twice"),
        ("trace:g.csv?min_confidence=high", "min_confidence must be a number"),
        ("trace:g.csv?min_confidence=2", r"min_confidence must lie in \[0, 1\]"),
        ("webcam:", "webcam needs an argument"),
        ("webcam:0?fps=30", "unknown option 'fps' for webcam"),
    ],
)
def test_factory_malformed_specs_name_the_spec(spec: str, problem: str) -> None:
    with pytest.raises(GazeError, match=problem) as info:
        open_source(spec)
    assert info.value.where == f"gaze source {spec!r}"


def test_factory_trace_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(GazeError, match=r"missing\.csv: trace file not found") as info:
        open_source(f"trace:{tmp_path / 'missing.csv'}")
    assert info.value.where == str(tmp_path / "missing.csv")


class FakeWebcam(GazeSource):
    """Stands in for gaze.webcam.source.WebcamSource: records its arguments."""

    def __init__(self, device: int | str, calibration: str | None = None) -> None:
        self.device = device
        self.calibration = calibration

    def sample(self, t: float) -> GazeSample:
        """Unused by the factory test."""
        raise AssertionError("not sampled")


def test_factory_webcam_specs(monkeypatch: pytest.MonkeyPatch) -> None:
    module = types.ModuleType("gaze.webcam.source")
    module.WebcamSource = FakeWebcam  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "gaze.webcam.source", module)
    camera = open_source("webcam:2?calibration=calib.json")
    assert isinstance(camera, FakeWebcam) and (camera.device, camera.calibration) == (2, "calib.json")
    video = open_source("webcam:clips/session 1.mp4")
    assert (video.device, video.calibration) == ("clips/session 1.mp4", None)


def test_factory_webcam_unavailable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gaze.webcam.source", None)
    with pytest.raises(GazeError, match="webcam estimator is not available") as info:
        open_source("webcam:0")
    assert info.value.where == "gaze source 'webcam:0'"
