"""The kernel-side camera and the one camera ray every pass uses.

Screen space: x right, y down (row 0 at the top), pixel (x, y) has its centre at
(x + 0.5, y + 0.5).  The ray through image point (px, py) is
``forward + ndc_x * tan_x * right + ndc_y * tan_y * up`` with
``ndc_x = 2 px / width - 1`` and ``ndc_y = 1 - 2 py / height``: its component along
``forward`` is 1, so a ray parameter along it *is* the view depth.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import warp as wp

if TYPE_CHECKING:
    from ..scene.model import Camera


@wp.struct
class CameraGPU:
    """A pinhole camera for one image size (see the module docstring)."""

    origin: wp.vec3
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    tan_x: float
    tan_y: float
    width: int
    height: int
    near: float
    far: float


def make_camera_gpu(camera: Camera, width: int, height: int) -> CameraGPU:
    """Build the kernel-side camera for an image of ``width`` x ``height`` pixels."""
    m = np.asarray(camera.cam_to_world, dtype=np.float64)
    right = m[:3, 0] / np.linalg.norm(m[:3, 0])
    up = m[:3, 1] / np.linalg.norm(m[:3, 1])
    forward = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    c = CameraGPU()
    c.origin = wp.vec3(*m[:3, 3].tolist())
    c.right = wp.vec3(*right.tolist())
    c.up = wp.vec3(*up.tolist())
    c.forward = wp.vec3(*forward.tolist())
    c.tan_x = float(camera.tan_half_fov_x)
    c.tan_y = float(camera.tan_half_fov_y(width, height))
    c.width = int(width)
    c.height = int(height)
    c.near = float(camera.near)
    c.far = float(camera.far)
    return c


@wp.func(inline=True)
def camera_ray(cam: CameraGPU, px: float, py: float) -> wp.vec3:
    """Direction of the camera ray through image point (px, py) in pixels; not
    normalised (unit forward component)."""
    ndc_x = 2.0 * px / float(cam.width) - 1.0
    ndc_y = 1.0 - 2.0 * py / float(cam.height)
    return cam.forward + cam.right * (ndc_x * cam.tan_x) + cam.up * (ndc_y * cam.tan_y)


@wp.func(inline=True)
def pixel_ray(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """``camera_ray`` through the centre of pixel (x, y)."""
    return camera_ray(cam, float(x) + 0.5, float(y) + 0.5)


@wp.func(inline=True)
def pixel_ray_direction(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """Unit direction of the camera ray through the centre of pixel (x, y)."""
    return wp.normalize(pixel_ray(cam, x, y))
