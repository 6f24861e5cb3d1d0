"""UsdGeom.Camera -> ``Camera``, camera selection, and a framing camera for stages
that have none.

A USD camera is evaluated with ``UsdGeom.Camera.GetCamera(time)`` (a ``Gf.Camera``:
focal length, horizontal/vertical aperture, clipping range, world transform) and
placed as ``Gf.Frustum.Transform`` places its frustum (``world_frustum``): the
position and rotation of the transformed frustum make ``cam_to_world`` (a rigid
transform), its window on the plane at distance 1 gives the effective apertures (the
authored ones, unless the scale is not uniform) and its near/far the clipping range in
world units (a camera under a 1e-3 scale clips at 1e-3 of its authored range).

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

from ...errors import RenderSettingsError, SceneError
from ..camera_check import camera_problem
from ..model import Camera
from .validate import Diagnostics

FRAMING_CAMERA_NAME = "<framing camera>"


def world_frustum(gf: Gf.Camera) -> Gf.Frustum:
    """The camera's frustum in world space as USD defines it: the camera-space frustum
    (apertures, focal length, clipping range) transformed by the camera's
    local-to-world matrix with ``Gf.Frustum.Transform``, so a scaled camera's clipping
    range scales with it (along its view axis) and a non-uniform scale changes its
    field of view, while shear is dropped."""
    local = Gf.Camera(gf)
    local.transform = Gf.Matrix4d(1.0)
    frustum = local.frustum
    frustum.Transform(gf.transform)
    return frustum


def _matrix(m: Gf.Matrix4d) -> np.ndarray:
    """A ``Gf.Matrix4d`` as a float64 (4, 4) array."""
    return np.array(m, dtype=np.float64).reshape(4, 4)


def read_camera(prim: Usd.Prim, time: float, diag: Diagnostics) -> Camera:
    """The camera ``prim`` at ``time`` in world space (``world_frustum``); a
    ``SceneError`` naming the file and the prim when its authored values break
    ``scene.camera_check``'s rule."""
    name = str(prim.GetPath())
    gf = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode(time))
    clip = gf.clippingRange
    problem = camera_problem(
        float(gf.focalLength), float(gf.horizontalAperture), float(clip.min), float(clip.max), _matrix(gf.transform)
    )
    if problem is not None:
        raise SceneError(diag.path, problem, name)
    if gf.projection != Gf.Camera.Perspective:
        diag.warn("orthographic projection is not supported; rendered as a perspective camera", name)
    if abs(gf.horizontalApertureOffset) > 0 or abs(gf.verticalApertureOffset) > 0:
        diag.warn("aperture offsets are not supported, ignored", name)
    frustum = world_frustum(gf)
    rotation = np.array(Gf.Matrix4d().SetRotate(frustum.GetRotation()), dtype=np.float64)
    cam_to_world = np.eye(4)
    cam_to_world[:3, :3] = rotation[:3, :3].T
    cam_to_world[:3, 3] = np.array(frustum.GetPosition(), dtype=np.float64)
    window = frustum.GetWindow()
    near, far = frustum.GetNearFar().min, frustum.GetNearFar().max
    focal = float(gf.focalLength)
    return Camera(
        name=name,
        cam_to_world=cam_to_world,
        focal_length=focal,
        horizontal_aperture=focal * float(window.max[0] - window.min[0]),
        vertical_aperture=focal * float(window.max[1] - window.min[1]),
        near=float(near),
        far=float(far),
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
