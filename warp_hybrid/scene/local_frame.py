"""The scene's local frame: where float32 coordinates are measured from.

A float32 coordinate x carries an absolute rounding error of up to 2^-24 |x|, so a
scene 1e5 units from the world origin is quantised to 0.008 units before any ray is
cast: a 1-unit room loses its shape, shadow rays start centimetres off their surface.
Loaders therefore compute world positions in float64 and store everything the device
sees (points, cameras, lights) relative to a *local origin* ``Scene.origin`` (float64),
so precision follows the camera, not the world origin: world = local + origin.

The origin is the default (first) camera's position snapped to a multiple of
``Q = 2^ceil(log2(ORIGIN_GRID_NEARS * near))`` on each axis (``choose_origin``), chosen
once per scene source.  So:

* a camera within ``Q / 2`` (about 4096 near distances) of the world origin keeps the
  world frame (origin exactly 0: such scenes are stored as they always were);
* otherwise the camera ends up within ``Q / 2`` of the local origin, and a point at
  view distance ``d`` has coordinates below ``Q / 2 + d``: its relative error is at most
  ``2^-24 (1 + 2^13 near / d)``, whatever the scene's distance from the world origin or
  its scale (``Q`` scales with the camera's near distance);
* the origin is a multiple of a power of two, so subtracting it from a float64 world
  position is exact.

**The representable range** (``frame_problem``, applied to every scene a loader
returns): that precision holds while

* every local coordinate (points, cameras, positioned lights) stays within
  ``MAX_LOCAL_COORDINATE`` = 2^30 (about 1.07e9) units: beyond it the squared distances
  and the products the kernels form leave float32's range (a 1e10-unit scene renders
  streaks; 3e9 still renders the 1-unit image, so 2^30 keeps a margin), and
* the origin lies within ``MAX_ORIGIN_NEARS`` = 2^42 near distances of the world origin
  (4.4e10 units for a 1 cm near plane): beyond it float64 world positions are coarser
  than float32's steps inside the local frame (a room 1e15 units out breaks up).

A scene beyond either is refused with an error naming the file and the prim; the
scale itself (1e-9 .. 1e9) does not matter.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .model import Camera, Light, LightKind

#: The snapping grid of the origin, in near distances of the default camera.
ORIGIN_GRID_NEARS = 2.0**13
#: The largest coordinate magnitude in the local frame (see the module docs).
MAX_LOCAL_COORDINATE = 2.0**30
#: The furthest origin from the world origin, in near distances of the default camera.
MAX_ORIGIN_NEARS = 2.0**42


def choose_origin(camera: Camera) -> np.ndarray:
    """The local origin (float64 (3,)) for a scene whose default camera is ``camera``
    (world space): its position snapped to the grid of the module docstring."""
    near = float(camera.near)
    if not (near > 0.0 and math.isfinite(near)):
        near = 1.0
    q = 2.0 ** math.ceil(math.log2(ORIGIN_GRID_NEARS * near))
    return np.round(np.asarray(camera.position, dtype=np.float64) / q) * q


def local_points(world: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """World positions (any float dtype, (..., 3)) relative to ``origin``, as float32
    (the difference taken in float64)."""
    if not origin.any():
        return np.asarray(world, dtype=np.float32)
    return (np.asarray(world, dtype=np.float64) - origin).astype(np.float32)


def local_camera(camera: Camera, origin: np.ndarray) -> Camera:
    """``camera`` (world space) moved into the frame of ``origin``."""
    if not origin.any():
        return camera
    m = np.array(camera.cam_to_world, dtype=np.float64)
    m[:3, 3] -= origin
    return replace(camera, cam_to_world=m)


def local_light(light: Light, origin: np.ndarray) -> Light:
    """``light`` (world space) moved into the frame of ``origin`` (only its position
    moves; directions and extents are the same in every frame)."""
    if not origin.any():
        return light
    p = np.asarray(light.position, dtype=np.float64) - origin
    return replace(light, position=(float(p[0]), float(p[1]), float(p[2])))


def frame_problem(
    points: np.ndarray, cameras: list[Camera], lights: list[Light], origin: np.ndarray
) -> tuple[str, int | str] | None:
    """Why a scene in the frame of ``origin`` is beyond the representable range (module
    docs), with what is at fault (a point index, or a camera's or light's name); None
    when it is within it."""
    if cameras:
        near = float(cameras[0].near)
        furthest = float(np.abs(origin).max()) if origin.size else 0.0
        if furthest > MAX_ORIGIN_NEARS * near:
            problem = (
                f"lies {furthest:.3g} units from the world origin, more than 2^42 near distances of its camera "
                f"({MAX_ORIGIN_NEARS * near:.3g} units for its near {near:g}): beyond float64's precision there"
            )
            return problem, cameras[0].name
    limit = MAX_LOCAL_COORDINATE
    what = f"beyond the representable range (|coordinate| <= 2^30 = {limit:.3g} around the camera)"
    # Two plain reductions first (an animated scene runs this every frame): only a scene
    # that may be beyond the range (or holds a NaN, which they do not order) looks point by point.
    if len(points) and not (float(points.max()) <= limit and float(points.min()) >= -limit):
        big = np.abs(points).max(axis=1) > limit
        if big.any():
            i = int(np.flatnonzero(big)[0])
            return f"point {i} ({np.asarray(points[i], dtype=np.float64).tolist()}) is {what}", i
    for camera in cameras:
        if np.abs(camera.position).max() > limit:
            return f"the camera position {camera.position.tolist()} is {what}", camera.name
    for light in lights:
        if light.kind != LightKind.DISTANT and max(abs(c) for c in light.position) > limit:
            return f"the light position {list(light.position)} is {what}", light.name
    return None
