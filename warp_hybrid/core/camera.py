"""The kernel-side camera and the one camera ray every pass uses.

Screen space: x right, y down (row 0 at the top), pixel (x, y) has its centre at
(x + 0.5, y + 0.5).  The ray through image point (px, py) is
``forward + ndc_x * tan_x * right + ndc_y * tan_y * up`` with
``ndc_x = 2 px / width - 1`` and ``ndc_y = 1 - 2 py / height``: its component along
``forward`` is 1, so a ray parameter along it *is* the view depth.

**The sample point.** A frame samples every pixel at the same point inside it,
``CameraGPU.sample`` (offset from the pixel's top-left corner; (0.5, 0.5), the centre,
unless a supersampled frame jitters it): ``pixel_ray`` goes through (x + sample.x,
y + sample.y), and the raster coverage tests that point (``primary.coverage`` shifts
the snapped corners by 0.5 - sample in whole fixed-point units).  The offset is
snapped to the raster's fixed-point grid (``SAMPLE_GRID`` steps per pixel) so that
shift is exact and the coverage test and the camera ray sample the same point.
``sample_step`` is the spacing of a supersampled frame's samples in pixels ((1, 1)
with one sample per pixel): the ray differentials of the texture footprint span it.
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
    sample: wp.vec2
    sample_step: wp.vec2


#: Sample offsets are multiples of 1 / SAMPLE_GRID pixel: the raster's fixed-point
#: grid (``primary.coverage.SUBPIXEL``).
SAMPLE_GRID = 256
#: The pixel centre, the sample point of a frame with one sample per pixel.
PIXEL_CENTRE = (0.5, 0.5)


def snap_sample(offset: float) -> float:
    """A sample offset (pixels from the pixel's corner, in [0, 1]) on the fixed-point grid."""
    return round(float(offset) * SAMPLE_GRID) / SAMPLE_GRID


def make_camera_gpu(
    camera: Camera,
    width: int,
    height: int,
    sample: tuple[float, float] = PIXEL_CENTRE,
    sample_step: tuple[float, float] = (1.0, 1.0),
) -> CameraGPU:
    """Build the kernel-side camera for an image of ``width`` x ``height`` pixels that
    samples each pixel at ``sample`` (snapped to the fixed-point grid; default the
    centre) with samples ``sample_step`` pixels apart (see the module docstring)."""
    if not all(0.0 <= v <= 1.0 for v in sample):
        raise ValueError(f"a sample offset must lie in the pixel, [0, 1]^2, got {tuple(sample)}")
    if not all(0.0 < v <= 1.0 for v in sample_step):
        raise ValueError(f"the sample step must be in (0, 1] pixels, got {tuple(sample_step)}")
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
    c.sample = wp.vec2(snap_sample(sample[0]), snap_sample(sample[1]))
    c.sample_step = wp.vec2(float(sample_step[0]), float(sample_step[1]))
    return c


#: Rows ``box_rows`` adds on either side of a box's projection (rounding of the corners,
#: and the sample point anywhere in its pixel).
BOX_ROW_MARGIN = 2


def box_rows(cam: CameraGPU, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int] | None:
    """The image rows (first, stop) that the axis-aligned box ``lo``..``hi`` (the camera's
    frame) can cover, ``BOX_ROW_MARGIN`` wider on either side and clipped to the image
    (an empty span where it lies above or below it); None where the box reaches the near
    plane (its projection is unbounded there).  The host's copy of the rasterizer's
    projection (``primary.clipping.project``), for the rows only."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    d = corners - np.array([cam.origin[0], cam.origin[1], cam.origin[2]], dtype=np.float64)
    depth = d @ np.array([cam.forward[0], cam.forward[1], cam.forward[2]], dtype=np.float64)
    if not np.all(depth > float(cam.near)):
        return None
    up = d @ np.array([cam.up[0], cam.up[1], cam.up[2]], dtype=np.float64)
    half = 0.5 * float(cam.height)
    screen_y = half - up / depth * (half / float(cam.tan_y))
    first = max(int(np.floor(screen_y.min())) - BOX_ROW_MARGIN, 0)
    stop = min(int(np.ceil(screen_y.max())) + 1 + BOX_ROW_MARGIN, int(cam.height))
    return (first, stop) if first < stop else (0, 0)


#: C++ statements: ``ray``, the direction of the camera ray of the ``CameraGPU`` named
#: ``cam`` through image point (``px``, ``py``) (the module docstring's formula), one Warp
#: operation a statement as Warp's own code generator writes it, so the compiler fuses
#: nothing differently: written once for ``camera_ray`` and for the native row loops
#: that make their own rays (the resolve's, ``primary.kernels``), the same bits in both.
CAMERA_RAY_CPP = """
const float cr_ndc_x = wp::sub(wp::div(wp::mul(2.0f, px), (float)cam.width), 1.0f);
const float cr_ndc_y = wp::sub(1.0f, wp::div(wp::mul(2.0f, py), (float)cam.height));
const wp::vec3 ray = wp::add(
    wp::add(cam.forward, wp::mul(cam.right, wp::mul(cr_ndc_x, cam.tan_x))), wp::mul(cam.up, wp::mul(cr_ndc_y, cam.tan_y))
);
"""


@wp.func_native(CAMERA_RAY_CPP + "return ray;")
def camera_ray(cam: CameraGPU, px: float, py: float) -> wp.vec3:
    """Direction of the camera ray through image point (px, py) in pixels; not
    normalised (unit forward component)."""
    ...


@wp.func(inline=True)
def sample_spread(cam: CameraGPU) -> wp.vec2:
    """How far ``camera_ray``'s direction moves (per unit forward) for one sample step
    right and one down: ``2 tan_x / width`` and ``2 tan_y / height`` times
    ``sample_step`` (the angle a sample step subtends at the image centre)."""
    return wp.vec2(
        2.0 * cam.tan_x / float(cam.width) * cam.sample_step[0],
        2.0 * cam.tan_y / float(cam.height) * cam.sample_step[1],
    )


@wp.func(inline=True)
def pixel_ray(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """``camera_ray`` through the sample point of pixel (x, y) (its centre unless the
    frame is supersampled)."""
    return camera_ray(cam, float(x) + cam.sample[0], float(y) + cam.sample[1])


@wp.func(inline=True)
def pixel_ray_direction(cam: CameraGPU, x: int, y: int) -> wp.vec3:
    """Unit direction of the camera ray through the sample point of pixel (x, y)."""
    return wp.normalize(pixel_ray(cam, x, y))
