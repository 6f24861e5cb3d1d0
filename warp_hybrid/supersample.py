"""Supersampling (``RenderSettings.spp``): the sub-pixel sample pattern and the box filter.

A frame with ``spp`` samples per pixel renders ``spp`` sub-frames through the same
passes, each sampling every pixel at one offset from its top-left corner
(``CameraGPU.sample``), and averages them; one sample per pixel is the pixel centre.

* **Pattern** (``sample_offsets``): stratified jitter.  The pixel is cut into an
  ``nx`` x ``ny`` grid of strata with ``nx * ny = spp`` (``strata``: ``ny`` the largest
  divisor of ``spp`` not above its square root, so a square grid for a square ``spp``
  and, for a prime, one row of ``spp`` columns: stratified in x, jittered in y).  Each
  stratum gets one uniform random point, drawn by ``numpy.random.default_rng(seed)``
  (the same offsets for the same ``spp`` and seed: a render is reproducible) and
  rounded to the nearest point of the raster's fixed-point grid
  (``core.camera.SAMPLE_GRID``) in the closed stratum (which may be its edge).
  Sub-frame ``k`` takes stratum ``(k % nx, k // nx)``, row-major.  The pattern is
  antithetic: the strata mirrored through the pixel centre (k and spp - 1 - k) take
  mirrored points (a stratum that is its own mirror, the centre one of an odd grid,
  takes the centre), so the offsets' mean is the pixel centre exactly.  Every pixel
  shares the frame's offsets, so a pattern whose mean strayed from the centre would
  shift the whole image against one rendered at the pixel centres.
* **Box filter** (``SampleAccumulator``): the sub-frames' linear colour is summed and
  divided by ``spp`` before exposure and tone mapping; the visibility AOV is the mean
  over the sub-frames that traced it (finite there), NaN where none did.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .core.camera import SAMPLE_GRID
from .core.pixel_list import listed_pixel
from .parallel import Launcher

wp.set_module_options({"enable_backward": False})

#: The most samples per pixel: every stratum is then at least one grid step wide.
MAX_SPP = SAMPLE_GRID


def strata(spp: int) -> tuple[int, int]:
    """The (columns, rows) of the strata grid of ``spp`` samples (see the module docstring)."""
    rows = next(d for d in range(math.isqrt(spp), 0, -1) if spp % d == 0)
    return spp // rows, rows


def sample_step(spp: int) -> tuple[float, float]:
    """The spacing of the samples in pixels: one stratum's width and height."""
    nx, ny = strata(spp)
    return 1.0 / nx, 1.0 / ny


def sample_offsets(spp: int, seed: int = 0) -> np.ndarray:
    """(spp, 2) float64 offsets (x, y) in pixels from the pixel's top-left corner, one per
    stratum in row-major order, on the fixed-point grid, mirrored pairwise through the
    centre (see the module docstring); (0.5, 0.5) for one sample."""
    n = np.array(strata(spp), dtype=np.int64)
    half = spp // 2
    k = np.arange(half)
    cell = np.stack([k % n[0], k // n[0]], axis=1)
    jitter = np.random.default_rng(seed).random((half, 2))
    steps = np.rint((cell + jitter) / n * SAMPLE_GRID)
    # The grid points of the closed stratum (one at least: strata are >= 1 step wide).
    first = -(-cell * SAMPLE_GRID // n)
    last = (cell + 1) * SAMPLE_GRID // n
    points = np.clip(steps, first, last) / SAMPLE_GRID
    centre = np.full((spp % 2, 2), 0.5)
    return np.concatenate([points, centre, 1.0 - points[::-1]])


@wp.func
def _add_sample(
    y: int,
    x: int,
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
    first: int,
    consume: int,
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
):
    """Add pixel (x, y)'s colour and finite visibility to the sums (``first``: start
    them; ``consume``: set the visibility read back to NaN, for the next sample)."""
    rgb = color[y, x]
    if first == 0:
        rgb = color_sum[y, x] + rgb
    color_sum[y, x] = rgb
    for i in range(visibility.shape[2]):
        v = visibility[y, x, i]
        total = float(0.0)
        count = int(0)
        if first == 0:
            total = visibility_sum[y, x, i]
            count = visibility_count[y, x, i]
        if not wp.isnan(v):
            total += v
            count += 1
            if consume != 0:
                visibility[y, x, i] = wp.nan
        visibility_sum[y, x, i] = total
        visibility_count[y, x, i] = count


@wp.func
def _average(
    y: int,
    x: int,
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
    samples: float,
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
):
    """Pixel (x, y)'s box-filtered colour, and its mean visibility where any sample
    traced it (NaN elsewhere)."""
    color[y, x] = color_sum[y, x] / samples
    for i in range(visibility.shape[2]):
        n = visibility_count[y, x, i]
        v = wp.nan
        if n > 0:
            v = visibility_sum[y, x, i] / float(n)
        visibility[y, x, i] = v


@wp.kernel
def accumulate_kernel(
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
    first: int,
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: add one sub-frame's colour and finite visibility to the sums (``first``:
    start them)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
        _add_sample(y, x, color, visibility, first, 0, color_sum, visibility_sum, visibility_count)


@wp.kernel
def average_kernel(
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
    samples: float,
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: the box filter's mean colour and visibility (``_average``)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
        _average(y, x, color_sum, visibility_sum, visibility_count, samples, color, visibility)


@wp.kernel
def listed_accumulate_kernel(
    pixels: wp.array(dtype=wp.int32),
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
    first: int,
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
    start: int,
    step: int,
):
    """Per listed pixel: add one sample's colour and finite visibility to the sums,
    leaving the visibility read NaN again (the next sample writes only where it hits)."""
    xy = listed_pixel(pixels, start + wp.tid() * step, color.shape[1], color.shape[0])
    if xy[0] >= 0:
        _add_sample(xy[1], xy[0], color, visibility, first, 1, color_sum, visibility_sum, visibility_count)


@wp.kernel
def listed_average_kernel(
    pixels: wp.array(dtype=wp.int32),
    color_sum: wp.array2d(dtype=wp.vec3),
    visibility_sum: wp.array3d(dtype=wp.float32),
    visibility_count: wp.array3d(dtype=wp.int32),
    samples: float,
    color: wp.array2d(dtype=wp.vec3),
    visibility: wp.array3d(dtype=wp.float32),
    start: int,
    step: int,
):
    """Per listed pixel: the box filter's mean colour and visibility (``_average``)."""
    xy = listed_pixel(pixels, start + wp.tid() * step, color.shape[1], color.shape[0])
    if xy[0] >= 0:
        _average(xy[1], xy[0], color_sum, visibility_sum, visibility_count, samples, color, visibility)


class SampleAccumulator:
    """The running sums of a supersampled frame's sub-frames (buffers reused across
    frames): over every pixel, or over the pixels of a list (a supersampled focus
    window)."""

    def __init__(self, launcher: Launcher) -> None:
        """Run on ``launcher``'s device and threads."""
        self.launcher = launcher
        self._color: wp.array | None = None
        self._visibility: wp.array | None = None
        self._count: wp.array | None = None

    def _sums(self, visibility: wp.array) -> None:
        shape = tuple(visibility.shape)
        if self._visibility is None or tuple(self._visibility.shape) != shape:
            device = self.launcher.device
            self._color = wp.empty(shape[:2], dtype=wp.vec3, device=device)
            self._visibility = wp.empty(shape, dtype=wp.float32, device=device)
            self._count = wp.empty(shape, dtype=wp.int32, device=device)

    def add(
        self, color: wp.array, visibility: wp.array, first: bool, pixels: wp.array | None = None, count: int = 0
    ) -> None:
        """Add one sample's ``color`` (H, W) and ``visibility`` (H, W, L); ``first``
        starts the sums.  With ``pixels``: only the first ``count`` listed pixels, and
        their visibility is set back to NaN once read (see ``listed_accumulate_kernel``)."""
        self._sums(visibility)
        sums = [self._color, self._visibility, self._count]
        if pixels is None:
            h, w = color.shape
            self.launcher.launch_pixels(accumulate_kernel, h, w, [color, visibility, int(first), *sums])
        else:
            self.launcher.launch_items(listed_accumulate_kernel, count, [pixels, color, visibility, int(first), *sums])

    def average(
        self, samples: int, color: wp.array, visibility: wp.array, pixels: wp.array | None = None, count: int = 0
    ) -> None:
        """Write the mean of the ``samples`` samples added into ``color`` and
        ``visibility`` (with ``pixels``: only at the first ``count`` listed pixels)."""
        inputs = [self._color, self._visibility, self._count, float(samples), color, visibility]
        if pixels is None:
            h, w = color.shape
            self.launcher.launch_pixels(average_kernel, h, w, inputs)
        else:
            self.launcher.launch_items(listed_average_kernel, count, [pixels, *inputs])
