"""UsdGeom.Camera -> ``Camera``, camera selection, and a framing camera for stages
that have none.

A USD camera is evaluated with ``UsdGeom.Camera.GetCamera(time)`` (a ``Gf.Camera``:
focal length, horizontal/vertical aperture, clipping range, world transform).  Its
``cam_to_world`` is the world transform with scale and shear removed (the closest
rotation), so the view is defined by the apertures alone.

Framing camera (stage without cameras): 50 mm lens on a 36 x 24 aperture, looking at
the centre of the scene's bounding box from the front and 20 degrees above
(front = +Z for a Y-up stage, -Y for a Z-up stage), far enough away that the bounding
sphere fits the vertical field of view of a 4:3 image; near/far clip the sphere with
margin.
"""

from __future__ import annotations

import math

import numpy as np
from pxr import Gf, Usd, UsdGeom

from ...errors import RenderSettingsError
from ..model import Camera
from .validate import Diagnostics

FRAMING_CAMERA_NAME = "<framing camera>"


def _closest_rotation(m3: np.ndarray) -> np.ndarray:
    u, _s, vt = np.linalg.svd(m3)
    return u @ vt


def read_camera(prim: Usd.Prim, time: float, diag: Diagnostics) -> Camera:
    """The camera ``prim`` at ``time`` in world space."""
    name = str(prim.GetPath())
    gf = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode(time))
    if gf.projection != Gf.Camera.Perspective:
        diag.warn("orthographic projection is not supported; rendered as a perspective camera", name)
    if abs(gf.horizontalApertureOffset) > 0 or abs(gf.verticalApertureOffset) > 0:
        diag.warn("aperture offsets are not supported, ignored", name)
    row = np.array(gf.transform, dtype=np.float64)
    cam_to_world = np.eye(4)
    cam_to_world[:3, :3] = _closest_rotation(row[:3, :3].T)
    cam_to_world[:3, 3] = row[3, :3]
    clip = gf.clippingRange
    return Camera(
        name=name,
        cam_to_world=cam_to_world,
        focal_length=float(gf.focalLength),
        horizontal_aperture=float(gf.horizontalAperture),
        vertical_aperture=float(gf.verticalAperture),
        near=float(clip.min),
        far=float(clip.max),
    )


def framing_camera(bounds_min: np.ndarray, bounds_max: np.ndarray, up_axis: str = "Y") -> Camera:
    """A camera that frames the box ``[bounds_min, bounds_max]`` (see module docs)."""
    lo, hi = np.asarray(bounds_min, dtype=np.float64), np.asarray(bounds_max, dtype=np.float64)
    centre = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    if not radius > 0.0:
        radius = 1.0
    if up_axis == "Z":
        up, back = np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0])
    else:
        up, back = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    elevation = math.radians(20.0)
    view_from = back * math.cos(elevation) + up * math.sin(elevation)
    focal, h_ap, v_ap = 50.0, 36.0, 24.0
    tan_y = h_ap / (2.0 * focal) * 3.0 / 4.0
    distance = radius / math.sin(math.atan(tan_y))
    eye = centre + distance * view_from
    forward = -view_from
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, -forward, eye
    near = max(distance - 1.5 * radius, distance * 1e-3)
    return Camera(FRAMING_CAMERA_NAME, m, focal, h_ap, v_ap, near, distance + 2.0 * radius)


def select_camera(cameras: list[Camera], prim_path: str | None = None, source: str | None = None) -> Camera:
    """The camera named ``prim_path``, or the first one when it is None.

    Raises ``RenderSettingsError`` listing the available cameras when the path is
    unknown or the list is empty; the message starts with ``source`` (the scene
    file) when given.
    """
    where = f"{source}: " if source else ""
    if prim_path is None:
        if not cameras:
            raise RenderSettingsError(f"{where}the scene has no camera")
        return cameras[0]
    for cam in cameras:
        if cam.name == prim_path:
            return cam
    names = ", ".join(c.name for c in cameras) or "none"
    raise RenderSettingsError(f"{where}camera {prim_path!r} not found (cameras: {names})")
