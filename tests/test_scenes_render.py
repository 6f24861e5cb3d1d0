"""Every scene renders: the shipped ones in every mode (finite, non-negative radiance on
the numerical hard cases), and every shared real scene (skipped when absent)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_paths import shared_scenes_dir

from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.open import open_scene_source

ROOT = Path(__file__).resolve().parents[1]
HARD = ROOT / "scenes" / "hard_cases.usda"


@pytest.mark.parametrize("camera", ["/World/Cameras/Main", "/World/Cameras/Far", "/World/Cameras/Tiny"])
@pytest.mark.parametrize("mode", ["raster", "full"])
def test_hard_cases_render_finite_in_every_mode(device: str, camera: str, mode: str) -> None:
    scene = open_scene_source(HARD).scene_at(None)
    cam = next(c for c in scene.cameras if c.name == camera)
    with Renderer(scene, RenderSettings(width=80, height=60, device=device, mode=mode, exposure_ev=0.0)) as r:
        frame = r.render(cam)
    aovs = frame.aovs()
    assert np.isfinite(aovs["color"]).all() and (aovs["color"] >= 0).all()
    hit = np.isfinite(aovs["depth"])
    assert hit.mean() > 0.3  # the camera sees its subject, not only sky
    assert (aovs["depth"][hit] > 0).all()
    if mode == "full":
        vis = frame.visibility[hit]
        assert np.isfinite(vis).all() and (vis >= 0).all() and (vis <= 1).all()


def _shared_entries() -> list[dict]:
    manifest = shared_scenes_dir() / "manifest.json"
    return json.loads(manifest.read_text())["scenes"] if manifest.is_file() else []


@pytest.mark.parametrize("entry", _shared_entries(), ids=lambda e: e["name"])
def test_every_shared_scene_renders(shared_scenes: Path, device: str, entry: dict) -> None:
    scene = open_scene_source(shared_scenes / entry["file"]).scene_at(None)
    with Renderer(scene, RenderSettings(width=64, height=48, device=device, mode="hybrid", window_fraction=0.3)) as r:
        frame = r.render(scene.cameras[0])
    assert np.isfinite(frame.color).all()
    assert np.isfinite(frame.aovs()["depth"]).mean() > 0.5
    assert frame.image.std() > 2.0  # a picture, not a flat fill
    assert frame.stats["rays"]["traced_pixels"] > 0
