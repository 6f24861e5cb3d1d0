"""Helpers for the hard-case tests: render a scene (or a USD file) and keep what the
invariance rule compares, and the G-buffer channels the tests look at."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from warp_hybrid import open_scene_source
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.invariance import RenderView, mesh_index
from warp_hybrid.scene.model import Camera, Scene

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"


@dataclass
class Rendered:
    """One frame on the host: the invariance view plus colour, triangle ids, positions."""

    view: RenderView
    color: np.ndarray
    triangle_id: np.ndarray
    position: np.ndarray
    scene: Scene


def render(
    scene: Scene, device: str, width: int = 64, height: int = 48, camera: Camera | None = None, **settings: object
) -> Rendered:
    """Render ``scene`` (full mode, no anti-aliasing unless ``settings`` say otherwise)
    through ``camera`` (default its first)."""
    opts = dict(width=width, height=height, device=device, mode="full", antialias=False)
    opts.update(settings)
    with Renderer(scene, RenderSettings(**opts)) as renderer:
        frame = renderer.render(camera or scene.cameras[0])
        aovs = frame.aovs()
        tri = frame.gbuffer.triangle_id.numpy().reshape(height, width)
        view = RenderView(
            aovs["depth"], aovs["visibility"], frame.image, mesh_index(tri, [m.first_triangle for m in scene.meshes])
        )
        return Rendered(view, aovs["color"], tri, aovs["position"], scene)


def render_file(path: str | Path, device: str, width: int = 64, height: int = 48, **settings: object) -> Rendered:
    """``render`` of a USD file at its default time from its first camera."""
    return render(open_scene_source(path).scene_at(None), device, width, height, **settings)
