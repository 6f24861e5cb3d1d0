"""The mid-resolution ring's upsampling (``--ring``): fill the ring's untraced pixels
from its traced lattice, guided by the G-buffer (a joint bilateral filter; one Warp
module, compiled only with the ring).

The ring (``focus.ring``) is traced at every ``step``-th pixel in x and y.  What is
upsampled is the *effects* the tracer adds, not the image: the traced layer's difference
from the raster layer, which is shaded at every pixel.  An untraced ring pixel ``p``
gets

    traced(p) = raster(p) + sum_q w_q (traced(q) - raster(q)) / sum_q w_q

over lattice pixels ``q`` that were traced (inside the ring's outer shape and on the
screen), so the raster layer's full-rate detail (textures, silhouettes, highlights)
stays and only the traced effects (shadows, reflections, refractions) are at the
lattice's rate.  ``w_q = spatial x range``:

* spatial: the bilinear weights of the 2 x 2 lattice pixels around ``p`` (a linear
  signal is reproduced exactly, a smooth one to ``O(step^2)``); where none of them is
  usable, the tent of twice that radius over the 4 x 4 around ``p``; where none of those
  is either, ``traced(p) = raster(p)`` (the raster layer shows).
* range (the G-buffer as the guide, rejecting samples across edges): a background pixel
  takes background samples only and a surface pixel surface samples of the same material;
  ``exp(-(s / PLANE_SIGMA)^2)`` of ``s = |n_p . (P_q - P_p)| / |P_q - P_p|``, the sine of
  the angle the step to the sample makes with ``p``'s tangent plane (0 on a plane, about
  ``|P_q - P_p| / 2R`` on a sphere of radius ``R``, near 1 across a depth edge); and
  ``max(n_p . n_q, 0)^32`` (a crease between two faces; a normal 10 degrees off keeps 0.61).

The lattice pixels themselves keep their traced value.  Stage ``"upsample"``; the kernel
runs one launch item per row of the ring.
"""

from __future__ import annotations

import warp as wp

from ..core.gbuffer import GBuffer
from ..core.passes import FrameContext, RenderPass
from ..parallel import Launcher

wp.set_module_options({"enable_backward": False})

#: Width of the plane test: a sample whose step leaves the tangent plane at sine 0.1 keeps e^-1.
PLANE_SIGMA = wp.constant(0.1)
#: A total spatial x range weight below this is no usable sample (of at most 1).
MIN_WEIGHT = wp.constant(1.0e-3)


@wp.struct
class Guide:
    """The G-buffer channels the filter reads (arrays, not the whole ``GBufferArrays``)."""

    triangle_id: wp.array2d(dtype=wp.int32)
    material_id: wp.array2d(dtype=wp.int32)
    position: wp.array2d(dtype=wp.vec3)
    normal: wp.array2d(dtype=wp.vec3)


@wp.func
def range_weight(g: Guide, tri: int, material: int, pos: wp.vec3, n: wp.vec3, qx: int, qy: int) -> float:
    """The G-buffer's say on lattice pixel (qx, qy) as a sample for a pixel with triangle
    ``tri``, ``material``, position ``pos`` and normal ``n``."""
    tri_q = g.triangle_id[qy, qx]
    if tri < 0 or tri_q < 0:
        if tri < 0 and tri_q < 0:
            return 1.0
        return 0.0
    if g.material_id[qy, qx] != material:
        return 0.0
    step = g.position[qy, qx] - pos
    s = wp.abs(wp.dot(n, step)) / wp.max(wp.length(step), 1.0e-30)
    c = wp.max(wp.dot(n, g.normal[qy, qx]), 0.0)
    c = c * c
    c = c * c
    c = c * c
    c = c * c
    c = c * c  # the cosine to the 32nd
    return wp.exp(-(s * s) / (PLANE_SIGMA * PLANE_SIGMA)) * c


@wp.func
def traced_sample(spans: wp.array2d(dtype=wp.int32), qx: int, qy: int, width: int, height: int) -> bool:
    """Whether lattice pixel (qx, qy) was traced: on the screen and inside the ring's outer shape."""
    if qx < 0 or qy < 0 or qx >= width or qy >= height:
        return False
    return spans[0, qy] <= qx and qx < spans[1, qy]  # noqa: PLR1716 (Warp has no chained comparisons)


@wp.func
def fill_pixel(
    spans: wp.array2d(dtype=wp.int32),
    g: Guide,
    raster: wp.array2d(dtype=wp.vec3),
    traced: wp.array2d(dtype=wp.vec3),
    step: int,
    x: int,
    y: int,
):
    """Write the upsampled traced value of untraced ring pixel (x, y) (module docstring):
    the 2 x 2 bilinear samples, else the 4 x 4 tent, else the raster value."""
    width = raster.shape[1]
    height = raster.shape[0]
    tri = g.triangle_id[y, x]
    material = g.material_id[y, x]
    pos = g.position[y, x]
    n = g.normal[y, x]
    x0 = (x // step) * step
    y0 = (y // step) * step
    inv = 1.0 / float(step)
    fx = float(x - x0) * inv
    fy = float(y - y0) * inv
    total = wp.vec3(0.0)
    total_w = float(0.0)
    for j in range(2):
        wy = 1.0 - fy
        if j == 1:
            wy = fy
        for i in range(2):
            wx = 1.0 - fx
            if i == 1:
                wx = fx
            qx = x0 + i * step
            qy = y0 + j * step
            if wx * wy > 0.0 and traced_sample(spans, qx, qy, width, height):
                w = wx * wy * range_weight(g, tri, material, pos, n, qx, qy)
                total += w * (traced[qy, qx] - raster[qy, qx])
                total_w += w
    if total_w <= MIN_WEIGHT:
        total = wp.vec3(0.0)
        total_w = float(0.0)
        for j in range(-1, 3):
            qy = y0 + j * step
            ty = wp.abs(float(qy - y)) * inv
            for i in range(-1, 3):
                qx = x0 + i * step
                if traced_sample(spans, qx, qy, width, height):
                    tx = wp.abs(float(qx - x)) * inv
                    w = (1.0 - 0.5 * tx) * (1.0 - 0.5 * ty) * range_weight(g, tri, material, pos, n, qx, qy)
                    total += w * (traced[qy, qx] - raster[qy, qx])
                    total_w += w
    out = raster[y, x]
    if total_w > MIN_WEIGHT:
        out = out + total / total_w
    traced[y, x] = out


@wp.kernel
def fill_ring_rows(
    spans: wp.array2d(dtype=wp.int32),
    g: Guide,
    raster: wp.array2d(dtype=wp.vec3),
    traced: wp.array2d(dtype=wp.vec3),
    step: int,
    row0: int,
    start: int,
    stride: int,
):
    """Row ``row0 + start + tid * stride``: its ring pixels (the outer span ``spans[0:2]``
    less the window's ``spans[2:4]``) off the lattice get ``fill_pixel``."""
    y = row0 + start + wp.tid() * stride
    a = spans[0, y]
    b = spans[1, y]
    inner_a = spans[2, y]
    inner_b = spans[3, y]
    lattice_row = y % step == 0  # its every step-th pixel was traced: skipped
    # Left of the window, then right of it (a row the window misses has inner_a == inner_b == 0).
    for x in range(a, wp.min(inner_a, b)):
        if not lattice_row or x % step != 0:
            fill_pixel(spans, g, raster, traced, step, x, y)
    for x in range(wp.max(inner_b, a), b):
        if not lattice_row or x % step != 0:
            fill_pixel(spans, g, raster, traced, step, x, y)


class RingUpsampler(RenderPass):
    """Fills the ring's untraced pixels of the traced layer (the "upsample" pass, after
    tracing, before composition); a frame whose region has no ring (none was planned, or
    the budget guard stopped before it) is left alone."""

    def __init__(self, launcher: Launcher) -> None:
        """Launch on ``launcher`` (rows split across its threads)."""
        self.launcher = launcher
        self._guide: Guide | None = None
        self._guided: GBuffer | None = None
        launcher.ensure_loaded(fill_ring_rows)

    def execute(self, frame: FrameContext) -> None:
        """Upsample ``frame.region``'s ring into the frame's traced layer."""
        assert frame.region is not None, "the focus pass runs first"
        ring = frame.region.ring
        if ring is None:
            return
        b = frame.buffers
        first, stop = ring.outer.y0, ring.outer.y1
        gb = b.gbuffer
        if self._guide is None or self._guided is not gb:  # a new G-buffer (a resize)
            self._guide, self._guided = Guide(), gb
            self._guide.triangle_id, self._guide.material_id = gb.triangle_id, gb.material_id
            self._guide.position, self._guide.normal = gb.position, gb.normal
        with frame.timer.stage("upsample"):
            inputs = [ring.spans, self._guide, b.raster_color, b.traced_color, ring.step, first]
            self.launcher.launch_items(fill_ring_rows, stop - first, inputs)
