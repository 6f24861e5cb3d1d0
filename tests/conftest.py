"""Shared fixtures: the Warp device (one fixture picks the backend, Mitsuba-style),
the kernel cache inside the build tree, and the shared scenes folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("WARP_HYBRID_KERNEL_CACHE", str(ROOT / "build" / "warp-cache"))

from scene_paths import shared_scenes_dir  # noqa: E402

from warp_hybrid.runtime import init_warp  # noqa: E402

init_warp()


def _test_devices() -> list[str]:
    """Devices to run device tests on: ``WARP_HYBRID_TEST_DEVICES`` (comma separated),
    default ``cpu``; CUDA runs later by setting it to ``cpu,cuda:0``."""
    return [d.strip() for d in os.environ.get("WARP_HYBRID_TEST_DEVICES", "cpu").split(",") if d.strip()]


@pytest.fixture(params=_test_devices(), scope="session")
def device(request: pytest.FixtureRequest) -> str:
    """The Warp device a test runs on."""
    return request.param


@pytest.fixture(scope="session")
def shared_scenes() -> Path:
    """The shared scenes folder; skips the test cleanly where it is absent."""
    path = shared_scenes_dir()
    if not (path / "manifest.json").is_file():
        pytest.skip(f"shared scenes not found at {path}")
    return path
