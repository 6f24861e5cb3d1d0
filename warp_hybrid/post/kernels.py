"""The post-processing kernels (one Warp module): the log-luminance sums of automatic
exposure, exposure + tone mapping + 8-bit sRGB encode (+ the luma FXAA reads), and
FXAA on the 8-bit image.  Kernels process whole rows (the launcher's items are rows:
``row0 + tid * row_step``), so per-launch-item overhead and argument copies are paid
once per row.  Variants come from closures, not copies.

No ``from __future__ import annotations`` here: the closures' kernel signatures use
local types, which Warp resolves from evaluated annotations."""

import warp as wp

from .aa import fxaa_pixel, luma_of_codes
from .color import LUMA_709, Srgb8Encoder, srgb_quantize
from .exposure import LOG_DELTA
from .tonemap import OPERATORS

wp.set_module_options({"enable_backward": False})

LOG_DELTA_WP = wp.constant(LOG_DELTA)
Y709_R = wp.constant(LUMA_709[0])
Y709_G = wp.constant(LUMA_709[1])
Y709_B = wp.constant(LUMA_709[2])
FLOAT_MAX = wp.constant(3.4028234663852886e38)

MASK_NONE = "none"
MASK_BOOL = "bool"
MASK_ID = "id"


def _make_log_luminance_kernel(mask_kind: str) -> wp.Kernel:
    """Per row: the sum (float64) and count of ``log(delta + max(Y, 0))`` over the
    pixels with a finite Rec. 709 luminance Y that the mask selects: ``mask_kind``
    "none" = Y > 0, "bool" = mask true, "id" = mask >= 0 (an id buffer, -1 = miss)."""
    mask_dtype = wp.int32 if mask_kind == MASK_ID else wp.bool

    @wp.kernel
    def log_luminance_rows(
        color: wp.array2d(dtype=wp.vec3),
        mask: wp.array2d(dtype=mask_dtype),
        row_sum: wp.array(dtype=wp.float64),
        row_count: wp.array(dtype=wp.int32),
        row0: int,
        row_step: int,
    ):
        y = row0 + wp.tid() * row_step
        total = wp.float64(0.0)
        count = int(0)
        for x in range(color.shape[1]):
            c = color[y, x]
            lum = c[0] * Y709_R + c[1] * Y709_G + c[2] * Y709_B
            take = wp.abs(lum) <= FLOAT_MAX  # finite (wp.isfinite is an out-of-line call)
            if wp.static(mask_kind == MASK_NONE):
                take = take and lum > 0.0
            elif wp.static(mask_kind == MASK_BOOL):
                take = take and mask[y, x]
            else:
                take = take and mask[y, x] >= 0
            if take:
                total += wp.float64(wp.log(LOG_DELTA_WP + wp.max(lum, 0.0)))
                count += 1
        row_sum[y] = total
        row_count[y] = count

    return log_luminance_rows


LOG_LUMINANCE_KERNELS = {kind: _make_log_luminance_kernel(kind) for kind in (MASK_NONE, MASK_BOOL, MASK_ID)}


def _make_tonemap_kernel(operator: wp.Function, with_luma: bool) -> wp.Kernel:
    """Exposure, ``operator``, then the exact 8-bit sRGB code per channel; with
    ``with_luma`` also the FXAA luma of the codes (``luma_lut`` = ``aa.luma_table()``)."""

    @wp.kernel
    def tonemap_rows(
        color: wp.array2d(dtype=wp.vec3),
        scale: float,
        encoder: Srgb8Encoder,
        out: wp.array3d(dtype=wp.uint8),
        luma_lut: wp.array(dtype=wp.vec3),
        luma: wp.array2d(dtype=float),
        row0: int,
        row_step: int,
    ):
        y = row0 + wp.tid() * row_step
        for x in range(color.shape[1]):
            c = wp.static(operator)(color[y, x] * scale)
            r = srgb_quantize(c[0], encoder)
            g = srgb_quantize(c[1], encoder)
            b = srgb_quantize(c[2], encoder)
            out[y, x, 0] = wp.uint8(r)
            out[y, x, 1] = wp.uint8(g)
            out[y, x, 2] = wp.uint8(b)
            if wp.static(with_luma):
                luma[y, x] = luma_of_codes(r, g, b, luma_lut)

    return tonemap_rows


TONEMAP_KERNELS = {
    (name, with_luma): _make_tonemap_kernel(op, with_luma)
    for name, op in OPERATORS.items()
    for with_luma in (False, True)
}


@wp.kernel
def fxaa_rows(
    ldr: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    row0: int,
    row_step: int,
):
    """FXAA over the 8-bit sRGB image ``ldr`` (its luma in ``luma``) into ``out``, which
    holds a copy of ``ldr`` (only the edge pixels are written)."""
    y = row0 + wp.tid() * row_step
    for x in range(ldr.shape[1]):
        fxaa_pixel(ldr, luma, out, x, y)
