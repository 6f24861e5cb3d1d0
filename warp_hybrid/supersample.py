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
from .core.passes import FrameBuffers
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
            visibility_sum[y, x, i] = total
            visibility_count[y, x, i] = count


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
    """Per pixel: the box filter's mean colour, and the mean visibility where any
    sub-frame traced it (NaN elsewhere)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
        color[y, x] = color_sum[y, x] / samples
        for i in range(visibility.shape[2]):
            n = visibility_count[y, x, i]
            v = wp.nan
            if n > 0:
                v = visibility_sum[y, x, i] / float(n)
            visibility[y, x, i] = v


class SampleAccumulator:
    """The running sums of a supersampled frame's sub-frames (buffers reused across frames)."""

    def __init__(self, launcher: Launcher) -> None:
        """Run on ``launcher``'s device and threads."""
        self.launcher = launcher
        self._color: wp.array | None = None
        self._visibility: wp.array | None = None
        self._count: wp.array | None = None

    def _sums(self, buffers: FrameBuffers) -> None:
        shape = tuple(buffers.visibility.shape)
        if self._visibility is None or tuple(self._visibility.shape) != shape:
            device = self.launcher.device
            self._color = wp.empty(shape[:2], dtype=wp.vec3, device=device)
            self._visibility = wp.empty(shape, dtype=wp.float32, device=device)
            self._count = wp.empty(shape, dtype=wp.int32, device=device)

    def add(self, buffers: FrameBuffers, first: bool) -> None:
        """Add the sub-frame in ``buffers`` (``color``, ``visibility``); ``first`` starts the sums."""
        self._sums(buffers)
        inputs = [buffers.color, buffers.visibility, int(first), self._color, self._visibility, self._count]
        self.launcher.launch_pixels(accumulate_kernel, buffers.height, buffers.width, inputs)

    def average(self, buffers: FrameBuffers, samples: int) -> None:
        """Write the mean of the ``samples`` sub-frames added into ``buffers.color`` and
        ``buffers.visibility``."""
        inputs = [self._color, self._visibility, self._count, float(samples), buffers.color, buffers.visibility]
        self.launcher.launch_pixels(average_kernel, buffers.height, buffers.width, inputs)
