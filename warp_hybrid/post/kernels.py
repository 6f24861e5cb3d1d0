"""The post-processing kernels (one Warp module): the log-luminance sums of automatic
exposure and the exposure they give, exposure + tone mapping + 8-bit sRGB encode
(+ the luma FXAA reads), and FXAA on the 8-bit image.  Variants come from closures,
not copies.

The per-pixel kernels follow ``Launcher.launch_pixels`` (last inputs ``row0, row_step,
cols``): on the CPU a launch item is a whole row (argument copies are paid once per
row), on CUDA one pixel.  The tone map and FXAA also take the columns ``x0 <= x < x1``
they draw (all of them, or the part of a kept frame that changed).  The exposure
kernels run one thread (``wp.launch`` with ``dim=1``) and keep the frame's exposure in
device memory, so no stage reads it back.

No ``from __future__ import annotations`` here: the closures' kernel signatures use
local types, which Warp resolves from evaluated annotations."""

import warp as wp

from ..core.constants import luma709
from .aa import fxaa_pixel, luma_of_codes
from .color import Srgb8Encoder, srgb_quantize
from .exposure import LOG_DELTA, Exposure, exposure_from_log_sum, pairwise_sum
from .tonemap import OPERATORS

wp.set_module_options({"enable_backward": False})

LOG_DELTA_WP = wp.constant(LOG_DELTA)
FLOAT_MAX = wp.constant(3.4028234663852886e38)

MASK_NONE = "none"
MASK_BOOL = "bool"
MASK_ID = "id"


def _make_log_luminance_kernel(mask_kind: str) -> wp.Kernel:
    """Per row: the sum (float64) and count of ``log(delta + max(Y, 0))`` over the
    pixels with a finite Rec. 709 luminance Y that the mask selects: ``mask_kind``
    "none" = Y > 0, "bool" = mask true, "id" = mask >= 0 (an id buffer, -1 = miss).
    Each launch item adds its pixels' sum and count to its row's (``atomic_add``), so
    ``row_sum`` and ``row_count`` must start at zero; on the CPU an item is the whole
    row, summed in order."""
    mask_dtype = wp.int32 if mask_kind == MASK_ID else wp.bool

    @wp.kernel
    def log_luminance_pixels(
        color: wp.array2d(dtype=wp.vec3),
        mask: wp.array2d(dtype=mask_dtype),
        row_sum: wp.array(dtype=wp.float64),
        row_count: wp.array(dtype=wp.int32),
        row0: int,
        row_step: int,
        cols: int,
    ):
        r, c = wp.tid()
        y = row0 + r * row_step
        total = wp.float64(0.0)
        count = int(0)
        for x in range(c * cols, wp.min(c * cols + cols, color.shape[1])):
            lum = luma709(color[y, x])
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
        if count > 0:
            wp.atomic_add(row_sum, y, total)
            wp.atomic_add(row_count, y, count)

    return log_luminance_pixels


LOG_LUMINANCE_KERNELS = {kind: _make_log_luminance_kernel(kind) for kind in (MASK_NONE, MASK_BOOL, MASK_ID)}


@wp.kernel
def exposure_from_rows(
    row_sum: wp.array(dtype=wp.float64),
    row_count: wp.array(dtype=wp.int32),
    two: wp.float64,
    exposure: wp.array(dtype=Exposure),
):
    """One thread: the automatic exposure of the rows' log sums and counts (their
    total in numpy's order, so it equals the host's ``np.sum`` of them) into
    ``exposure[0]``; ``two`` = 2.0 (see ``exposure_from_log_sum``)."""
    count = wp.int64(0)
    for i in range(row_count.shape[0]):
        count += wp.int64(row_count[i])
    exposure[0] = exposure_from_log_sum(pairwise_sum(row_sum), count, two)


@wp.kernel
def fixed_exposure(ev: wp.float64, scale: float, exposure: wp.array(dtype=Exposure)):
    """One thread: a fixed exposure (EV and scale from the host) into ``exposure[0]``."""
    fixed = Exposure()
    fixed.ev = ev
    fixed.scale = scale
    exposure[0] = fixed


def _make_tonemap_kernel(operator: wp.Function, with_luma: bool) -> wp.Kernel:
    """Exposure (the scale in ``exposure[0]``), ``operator``, then the exact 8-bit sRGB
    code per channel; with ``with_luma`` also the FXAA luma of the codes
    (``luma_lut`` = ``aa.luma_table()``)."""

    @wp.kernel
    def tonemap_pixels(
        color: wp.array2d(dtype=wp.vec3),
        exposure: wp.array(dtype=Exposure),
        encoder: Srgb8Encoder,
        out: wp.array3d(dtype=wp.uint8),
        luma_lut: wp.array(dtype=wp.vec3),
        luma: wp.array2d(dtype=float),
        x0: int,
        x1: int,
        row0: int,
        row_step: int,
        cols: int,
    ):
        r, c = wp.tid()
        y = row0 + r * row_step
        scale = exposure[0].scale
        for x in range(wp.max(c * cols, x0), wp.min(c * cols + cols, x1)):
            tone = wp.static(operator)(color[y, x] * scale)
            red = srgb_quantize(tone[0], encoder)
            green = srgb_quantize(tone[1], encoder)
            blue = srgb_quantize(tone[2], encoder)
            out[y, x, 0] = wp.uint8(red)
            out[y, x, 1] = wp.uint8(green)
            out[y, x, 2] = wp.uint8(blue)
            if wp.static(with_luma):
                luma[y, x] = luma_of_codes(red, green, blue, luma_lut)

    return tonemap_pixels


TONEMAP_KERNELS = {
    (name, with_luma): _make_tonemap_kernel(op, with_luma)
    for name, op in OPERATORS.items()
    for with_luma in (False, True)
}


@wp.kernel
def fxaa_pixels(
    ldr: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    x0: int,
    x1: int,
    row0: int,
    row_step: int,
    cols: int,
):
    """FXAA over the 8-bit sRGB image ``ldr`` (its luma in ``luma``) into ``out``, in the
    columns ``x0 <= x < x1`` of the launched rows: each pixel ``ldr``'s colour, the edge
    pixels' then anti-aliased."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(wp.max(c * cols, x0), wp.min(c * cols + cols, x1)):
        for k in range(3):
            out[y, x, k] = ldr[y, x, k]
        fxaa_pixel(ldr, luma, out, x, y)
