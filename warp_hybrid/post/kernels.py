"""The post-processing kernels (one Warp module): exposure + tone mapping + 8-bit sRGB
encode, and FXAA on the 8-bit image.  One tone-mapping kernel per operator, generated
from one closure."""

from __future__ import annotations

import warp as wp

from .aa import fxaa_pixel
from .color import Srgb8Encoder, srgb_quantize
from .tonemap import OPERATORS

wp.set_module_options({"enable_backward": False})


def _make_tonemap_kernel(operator: wp.Function) -> wp.Kernel:
    """Exposure, ``operator``, then the exact 8-bit sRGB code per channel."""

    @wp.kernel
    def tonemap_pixels(
        color: wp.array2d(dtype=wp.vec3),
        scale: float,
        encoder: Srgb8Encoder,
        out: wp.array3d(dtype=wp.uint8),
        row0: int,
        row_step: int,
    ):
        r, x = wp.tid()
        y = row0 + r * row_step
        c = wp.static(operator)(color[y, x] * scale)
        for k in range(3):
            out[y, x, k] = wp.uint8(srgb_quantize(c[k], encoder))

    return tonemap_pixels


TONEMAP_KERNELS = {name: _make_tonemap_kernel(op) for name, op in OPERATORS.items()}


@wp.kernel
def fxaa_pixels(ldr: wp.array3d(dtype=wp.uint8), out: wp.array3d(dtype=wp.uint8), row0: int, row_step: int):
    """FXAA over the 8-bit sRGB image ``ldr`` into ``out``."""
    r, x = wp.tid()
    y = row0 + r * row_step
    c = fxaa_pixel(ldr, x, y)
    for k in range(3):
        out[y, x, k] = wp.uint8(int(wp.clamp(c[k], 0.0, 1.0) * 255.0 + 0.5))
