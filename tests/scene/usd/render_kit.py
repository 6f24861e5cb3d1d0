"""Tiny renders for the USD feature tests: a camera on +Z looking down -Z, linear AOVs."""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom

from warp_hybrid import Renderer, RenderSettings
from warp_hybrid.scene.model import Scene

FOCAL, APERTURE = 50.0, 36.0  # tan(hfov / 2) = 0.36


def add_camera(stage: Usd.Stage, distance: float, path: str = "/World/Cam") -> None:
    """A camera at (0, 0, ``distance``) looking down -Z (+Y up)."""
    cam = UsdGeom.Camera.Define(stage, path)
    cam.CreateFocalLengthAttr(FOCAL)
    cam.CreateHorizontalApertureAttr(APERTURE)
    cam.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, distance))


def pixel_rays(width: int, height: int) -> np.ndarray:
    """(H, W, 3) camera-space directions through the pixel centres, forward component 1
    (so a ray parameter is the view depth), for ``add_camera``'s camera."""
    tx = APERTURE / (2 * FOCAL)
    ty = tx * height / width
    i = (np.arange(width) + 0.5) / width * 2 - 1
    j = 1 - (np.arange(height) + 0.5) / height * 2
    x, y = np.meshgrid(i * tx, j * ty)
    return np.stack([x, y, -np.ones_like(x)], axis=-1)


def render_aovs(scene: Scene, width: int = 48, height: int = 36, **settings: object) -> dict[str, np.ndarray]:
    """The AOVs of a raster-mode frame from the scene's first camera (no AA, exposure 0,
    no tone mapping): depth, albedo, color (linear) and the rest."""
    opts = dict(width=width, height=height, mode="raster", antialias=False, exposure_ev=0.0, tonemap="none")
    opts.update(settings)
    with Renderer(scene, RenderSettings(**opts)) as renderer:
        return renderer.render(scene.cameras[0]).aovs()
