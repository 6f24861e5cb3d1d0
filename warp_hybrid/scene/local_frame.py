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
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .model import Camera, Light

#: The snapping grid of the origin, in near distances of the default camera.
ORIGIN_GRID_NEARS = 2.0**13


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
