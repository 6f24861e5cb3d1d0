"""Orbit, pan and zoom of a camera about a pivot (a turntable: the scene's up axis stays up).

Drags are shares of the frame (``dx`` of its width, ``dy`` of its height, down
positive).  Orbit turns by ``ORBIT_TURNS_PER_FRAME`` of a full turn per frame width
about the up axis (yaw) and half that per frame height about the camera's right axis
(pitch, kept within ``MAX_PITCH_DEG`` of the horizon); pan moves the camera and the
pivot so the scene at the pivot's depth follows the pointer; zoom moves the camera
towards the pivot (drag up) by ``exp(-dy * ZOOM_RATE)``.  The pivot starts at the
depth of the scene's bounding-box centre along the camera's view.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..scene.model import Camera

ORBIT_TURNS_PER_FRAME = 0.5
MAX_PITCH_DEG = 89.0
ZOOM_RATE = 2.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


class Navigator:
    """A camera pose under the user's control, started from a scene camera."""

    def __init__(self, camera: Camera, scene_centre: np.ndarray, up_axis: str = "Y") -> None:
        """Start at ``camera``'s pose; the pivot at the depth of ``scene_centre``."""
        self.base = camera
        self.up = np.array([0.0, 0.0, 1.0]) if up_axis.upper() == "Z" else np.array([0.0, 1.0, 0.0])
        forward = camera.forward
        depth = float(np.dot(np.asarray(scene_centre, float) - camera.position, forward))
        self.distance = max(depth, 10.0 * camera.near, 1e-6)
        self.pivot = camera.position + forward * self.distance
        self.yaw, self.pitch = self._angles(forward)

    def _horizontal_basis(self) -> tuple[np.ndarray, np.ndarray]:
        """Two unit vectors spanning the plane orthogonal to ``up``."""
        a = _unit(np.cross(self.up, [1.0, 0.0, 0.0] if abs(self.up[0]) < 0.9 else [0.0, 1.0, 0.0]))
        return a, np.cross(self.up, a)

    def _angles(self, forward: np.ndarray) -> tuple[float, float]:
        """Yaw and pitch (radians) of a view direction."""
        a, b = self._horizontal_basis()
        pitch = math.asin(float(np.clip(np.dot(forward, self.up), -1.0, 1.0)))
        limit = math.radians(MAX_PITCH_DEG)
        return math.atan2(float(np.dot(forward, b)), float(np.dot(forward, a))), float(np.clip(pitch, -limit, limit))

    def _forward(self) -> np.ndarray:
        a, b = self._horizontal_basis()
        horizontal = math.cos(self.yaw) * a + math.sin(self.yaw) * b
        return math.cos(self.pitch) * horizontal + math.sin(self.pitch) * self.up

    def _axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Right, up and forward of the current pose."""
        forward = self._forward()
        right = _unit(np.cross(forward, self.up))
        return right, np.cross(right, forward), forward

    def orbit(self, dx: float, dy: float) -> None:
        """Turn about the pivot: drag right turns the scene right, drag down tilts it down."""
        limit = math.radians(MAX_PITCH_DEG)
        self.yaw += dx * 2.0 * math.pi * ORBIT_TURNS_PER_FRAME
        self.pitch = float(np.clip(self.pitch + dy * math.pi * ORBIT_TURNS_PER_FRAME, -limit, limit))

    def pan(self, dx: float, dy: float, aspect: float) -> None:
        """Slide the camera and the pivot so the pivot's plane follows the pointer."""
        right, up, _ = self._axes()
        width = 2.0 * self.distance * self.base.tan_half_fov_x
        self.pivot = self.pivot - right * dx * width + up * dy * width / aspect

    def zoom(self, dy: float) -> None:
        """Move towards the pivot (drag up) or away from it (drag down)."""
        self.distance = max(self.distance * math.exp(dy * ZOOM_RATE), 2.0 * self.base.near)

    def camera(self) -> Camera:
        """The scene camera moved to the current pose (its lens and clipping kept)."""
        right, up, forward = self._axes()
        cam_to_world = np.eye(4)
        cam_to_world[:3, 0], cam_to_world[:3, 1], cam_to_world[:3, 2] = right, up, -forward
        cam_to_world[:3, 3] = self.pivot - forward * self.distance
        return dataclasses.replace(self.base, cam_to_world=cam_to_world)
