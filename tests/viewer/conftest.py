"""Viewer fixtures: a small live viewer (64x48, one thread) whose render loop runs for the module."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from warp_hybrid.renderer import RenderSettings
from warp_hybrid.replay.loop import LoopSettings
from warp_hybrid.scene.open import open_scene_source
from warp_hybrid.viewer.render_thread import ViewSettings
from warp_hybrid.viewer.serve import build_viewer
from warp_hybrid.viewer.session import Viewer

ROOT = Path(__file__).resolve().parents[2]
STILL = ROOT / "scenes" / "cornell_glass.usda"
ANIMATED = ROOT / "scenes" / "textured_animated.usda"
W, H = 64, 48
FPS = 15.0
#: A window small enough to move around the small frame.
MAX_WINDOW = 0.15
#: How long a test waits for the warm-up (kernels compile on the first run).
WARM_UP_TIMEOUT_S = 600.0


@dataclass
class LiveViewer:
    """A started viewer and where its recordings go."""

    viewer: Viewer
    record_dir: Path


def view_settings(tmp: Path, gaze: str = "cursor", fps: float = FPS) -> ViewSettings:
    """Small, single-threaded viewer settings writing under ``tmp``."""
    return ViewSettings(
        render=RenderSettings(width=W, height=H, device="cpu", threads=1),
        loop=LoopSettings(fps=fps, max_window=MAX_WINDOW),
        gaze=gaze,
        record_dir=tmp / "recordings",
        calibration_file=tmp / "calibration.json",
    )


def started(scene: Path, settings: ViewSettings) -> Viewer:
    """A viewer on ``scene`` with its render loop running and warm."""
    viewer = build_viewer(open_scene_source(scene), settings)
    viewer.thread.start()
    assert viewer.thread.warm.wait(WARM_UP_TIMEOUT_S), "the viewer's warm-up did not finish"
    return viewer


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveViewer]:
    """The animated scene in a running viewer (cursor gaze), shared by a module's tests."""
    tmp = tmp_path_factory.mktemp("viewer")
    viewer = started(ANIMATED, view_settings(tmp))
    yield LiveViewer(viewer, tmp / "recordings")
    viewer.thread.stop()
