"""The one rule for a camera the renderer can draw through.

A camera is refused (never rendered into a black or garbled frame) when its focal
length or horizontal aperture is not a positive finite number, its clipping range is
not ``0 < near < far`` with both finite (negative, inverted or ``(0, 0)``), or its
transform is not finite or collapses space (a camera scaled by 0: a singular matrix).
``camera_problem`` states the rule; the USD loader applies it to the authored values
(``usd.camera.read_camera``, naming the file and the prim) and the renderer to the
``Camera`` it is handed (``check_camera``).
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np

from ..errors import ArgumentTypeError, RenderSettingsError
from .model import Camera

#: A transform whose smallest singular value is below this share of its largest
#: collapses a direction (a scale of 0 along some axis): no image can be formed.
SINGULAR_RATIO = 1e-12


def _positive(value: object) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value) and value > 0.0


def camera_problem(
    focal_length: float, horizontal_aperture: float, near: float, far: float, transform: np.ndarray
) -> str | None:
    """What makes these camera values unusable (the USD attribute named), or None.
    ``transform`` is the camera's local-to-world matrix (4x4 or its 3x3 linear part)."""
    if not _positive(focal_length):
        return f"focalLength must be a positive finite number, got {focal_length!r}"
    if not _positive(horizontal_aperture):
        return f"horizontalAperture must be a positive finite number, got {horizontal_aperture!r}"
    if not (_positive(near) and isinstance(far, Real) and math.isfinite(far) and far > near):
        return f"clippingRange must be finite with 0 < near < far, got ({near!r}, {far!r})"
    m = np.asarray(transform, dtype=np.float64)
    if not np.isfinite(m).all():
        return "its transform is not finite"
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    if not s[-1] > SINGULAR_RATIO * s[0]:
        return "its transform scales it by 0 (a singular matrix): it has no view"
    return None


def check_camera(camera: object, argument: str = "camera") -> Camera:
    """``camera`` when it is a usable ``Camera``; an ``ArgumentTypeError`` naming
    ``argument`` when it is not a ``Camera`` at all, a ``RenderSettingsError`` naming
    the camera when its values break the rule."""
    if not isinstance(camera, Camera):
        raise ArgumentTypeError(
            f"{argument} must be a warp_hybrid.scene.model.Camera (e.g. scene.cameras[0]), "
            f"got {type(camera).__name__} {camera!r}"
        )
    problem = camera_problem(
        camera.focal_length, camera.horizontal_aperture, camera.near, camera.far, camera.cam_to_world
    )
    if problem is not None:
        raise RenderSettingsError(f"camera {camera.name}: {problem}")
    return camera
