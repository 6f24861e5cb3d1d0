"""The post-processing kernels (one Warp module): the log-luminance sums of automatic
exposure and the exposure they give, exposure + tone mapping + 8-bit sRGB encode
(+ the luma FXAA reads), and FXAA on the 8-bit image.  Variants come from closures,
not copies.

The per-pixel kernels follow ``Launcher.launch_pixels`` (last inputs ``row0, row_step,
cols``): on the CPU a launch item is a whole row (argument copies are paid once per
row), on CUDA one pixel.  The tone map and FXAA also take the columns ``x0 <= x < x1``
they draw (all of them, or the part of a kept frame that changed).  The exposure
kernels run one thread (``Launcher.launch_items`` of one item, so they queue behind the
pass in flight as any pass does) and keep the frame's exposure in device memory, so no
stage reads it back.

No ``from __future__ import annotations`` here: the closures' kernel signatures use
local types, which Warp resolves from evaluated annotations."""

import warp as wp

from ..core.native_rows import CHUNK_CPP, LAMBDA_HEADER_CPP, row_cpp
from .aa import LUMA_OF_CODES_CPP, fxaa_edge_pixels, fxaa_edge_span
from .color import SRGB_QUANTIZE_CPP, Srgb8Encoder
from .exposure import (
    LOG_COUNTS_CPP,
    LOG_FLOAT_CPP,
    LOG_LUMINANCE_CPP,
    LOG_TERM_CPP,
    Exposure,
    exposure_from_log_sum,
    pairwise_sum,
)
from .tonemap import CHANNEL_CPP

wp.set_module_options({"enable_backward": False})

MASK_NONE = "none"
MASK_BOOL = "bool"
MASK_ID = "id"


#: C++ condition: the mask ``mask_row`` (or, without one, the luminance ``l``) selects pixel
#: ``x`` (see ``_make_log_luminance_kernel``).
_MASK_TAKES_CPP = {MASK_NONE: "l > 0.0f", MASK_BOOL: "mask_row[x]", MASK_ID: "mask_row[x] >= 0"}


def _log_luminance_span_cpp(mask_kind: str) -> str:
    """The C++ body of ``_make_log_luminance_kernel``'s span function: for pixels
    ``x0 <= x < x1`` of row ``y``, a chunk at a time, the luminance and whether the pixel
    counts and its log term across the chunk (a loop the compiler vectorises), then the
    counted terms summed in order; returns (sum, count).  The colour's rows must be
    contiguous (``PostProcess`` checks)."""
    mask_row = (
        ""
        if mask_kind == MASK_NONE
        else f"const auto* mask_row = {row_cpp('mask', 'y', 'int' if mask_kind == MASK_ID else 'bool')};"
    )
    return (
        CHUNK_CPP
        + LAMBDA_HEADER_CPP
        + LOG_FLOAT_CPP
        + f"""
const wp::vec3* row = {row_cpp("color", "y", "wp::vec3")};
{mask_row}
double total = 0.0;
int count = 0;
double terms[CHUNK];
bool take[CHUNK];
for (int xs = x0; xs < x1; xs += CHUNK) {{
    const int n = x1 - xs < CHUNK ? x1 - xs : CHUNK;
    for (int j = 0; j < n; ++j) {{
        const int x = xs + j;
        const wp::vec3 c = row[x];
        {LOG_LUMINANCE_CPP}
        take[j] = {LOG_COUNTS_CPP} && {_MASK_TAKES_CPP[mask_kind]};  // (finite, selected)
        terms[j] = {LOG_TERM_CPP};
    }}
    for (int j = 0; j < n; ++j) {{
        if (take[j]) {{
            total = wp::add(total, terms[j]);
            ++count;
        }}
    }}
}}
return wp::vec2d(total, (double)count);
"""
    )


def _make_log_luminance_kernel(mask_kind: str) -> wp.Kernel:
    """Per row: the sum (float64) and count of ``log(delta + max(Y, 0))`` over the
    pixels with a finite Rec. 709 luminance Y that the mask selects: ``mask_kind``
    "none" = Y > 0, "bool" = mask true, "id" = mask >= 0 (an id buffer, -1 = miss).
    Each launch item adds its pixels' sum and count to its row's (``atomic_add``), so
    ``row_sum`` and ``row_count`` must start at zero; on the CPU an item is the whole
    row, summed in order (a native row loop: ``_log_luminance_span_cpp``)."""
    mask_dtype = wp.int32 if mask_kind == MASK_ID else wp.bool

    @wp.func_native(_log_luminance_span_cpp(mask_kind))
    def span(
        color: wp.array2d(dtype=wp.vec3), mask: wp.array2d(dtype=mask_dtype), y: int, x0: int, x1: int
    ) -> wp.vec2d:
        """Pixels ``x0 <= x < x1`` of row ``y``: their logs' sum and count."""
        ...

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
        first = c * cols
        stop = wp.min(first + cols, color.shape[1])
        if first < stop:
            sums = span(color, mask, y, first, stop)
            if sums[1] > wp.float64(0.0):
                wp.atomic_add(row_sum, y, sums[0])
                wp.atomic_add(row_count, y, int(sums[1]))

    return log_luminance_pixels


LOG_LUMINANCE_KERNELS = {kind: _make_log_luminance_kernel(kind) for kind in (MASK_NONE, MASK_BOOL, MASK_ID)}


@wp.kernel
def exposure_from_rows(
    row_sum: wp.array(dtype=wp.float64),
    row_count: wp.array(dtype=wp.int32),
    two: wp.float64,
    exposure: wp.array(dtype=Exposure),
    start: int,
    step: int,
):
    """One thread: the automatic exposure of the rows' log sums and counts (their
    total in numpy's order, so it equals the host's ``np.sum`` of them) into
    ``exposure[0]``; ``two`` = 2.0 (see ``exposure_from_log_sum``); ``start, step``:
    ``launch_items``'s (one item)."""
    count = wp.int64(0)
    for i in range(row_count.shape[0]):
        count += wp.int64(row_count[i])
    exposure[0] = exposure_from_log_sum(pairwise_sum(row_sum), count, two)


@wp.kernel
def fixed_exposure(ev: wp.float64, scale: float, exposure: wp.array(dtype=Exposure), start: int, step: int):
    """One thread: a fixed exposure (EV and scale from the host) into ``exposure[0]``
    (``start, step``: ``launch_items``'s, one item)."""
    fixed = Exposure()
    fixed.ev = ev
    fixed.scale = scale
    exposure[0] = fixed


def _tonemap_span_cpp(operator: str, with_luma: bool) -> str:
    """The C++ body of ``_make_tonemap_kernel``'s span function: for pixels ``x0 <= x < x1``
    of row ``y``, a chunk at a time, the curve on every channel (one flat loop over the
    chunk's floats, which the compiler vectorises), their 8-bit codes, the bytes, and (with
    ``with_luma``) the luma, and beside each row's first and last pixel the spare columns of
    ``aa.luma_buffer``.  The colour and the 8-bit image must be contiguous (``PostProcess``
    checks the colour and allocates the others); the luma is ``aa.luma_buffer``'s view."""
    luma_loop = luma_edges = ""
    if with_luma:
        # (the spare columns of ``aa.luma_buffer`` beside the row: its first and last luma)
        luma_edges = f"""
{{
    float* luma_row = {row_cpp("luma", "y", "float", const=False)};
    if (x0 == 0) luma_row[-1] = luma_row[0];
    if (x1 == (int)luma.shape[1]) luma_row[x1] = luma_row[x1 - 1];
}}"""
        luma_loop = f"""
    float* luma_out = {row_cpp("luma", "y", "float", const=False)} + xs;
    for (int j = 0; j < n / 3; ++j) {{
        const int r = codes[3 * j];
        const int g = codes[3 * j + 1];
        const int b = codes[3 * j + 2];
        luma_out[j] = {LUMA_OF_CODES_CPP};
    }}"""
    return (
        CHUNK_CPP
        + LAMBDA_HEADER_CPP
        + f"""
const float* row = {row_cpp("color", "y", "float")};
wp::uint8* bytes = {row_cpp("out", "y", "wp::uint8", const=False)};
const wp::vec2* cells = enc.cells.data;
float tone[3 * CHUNK];
int codes[3 * CHUNK];
for (int xs = x0; xs < x1; xs += CHUNK) {{
    const int n = 3 * (x1 - xs < CHUNK ? x1 - xs : CHUNK);
    const float* in = row + 3 * xs;
    for (int i = 0; i < n; ++i) {{
        const float x = in[i] * scale;
        {CHANNEL_CPP[operator]}
        tone[i] = t;
    }}
    for (int i = 0; i < n; ++i) {{
        const float x = tone[i];
        {SRGB_QUANTIZE_CPP}
        codes[i] = code;
    }}
    for (int i = 0; i < n; ++i) bytes[3 * xs + i] = (wp::uint8)codes[i];{luma_loop}
}}{luma_edges}
"""
    )


def _make_tonemap_kernel(operator: str, with_luma: bool) -> wp.Kernel:
    """Exposure (the scale in ``exposure[0]``), the curve ``operator`` (``tonemap.CHANNEL_CPP``),
    then the exact 8-bit sRGB code per channel (``color.SRGB_QUANTIZE_CPP``); with
    ``with_luma`` also the FXAA luma of the codes (``aa.LUMA_OF_CODES_CPP``).
    The same bits as ``OPERATORS[operator]`` and ``srgb_quantize`` pixel by pixel, in a
    native row loop the compiler vectorises across pixels."""

    @wp.func_native(_tonemap_span_cpp(operator, with_luma))
    def span(
        color: wp.array2d(dtype=wp.vec3),
        scale: float,
        enc: Srgb8Encoder,
        out: wp.array3d(dtype=wp.uint8),
        luma: wp.array2d(dtype=float),
        y: int,
        x0: int,
        x1: int,
    ):
        """Pixels ``x0 <= x < x1`` of row ``y`` (``_tonemap_span_cpp``)."""
        ...

    @wp.kernel
    def tonemap_pixels(
        color: wp.array2d(dtype=wp.vec3),
        exposure: wp.array(dtype=Exposure),
        encoder: Srgb8Encoder,
        out: wp.array3d(dtype=wp.uint8),
        luma: wp.array2d(dtype=float),
        x0: int,
        x1: int,
        row0: int,
        row_step: int,
        cols: int,
    ):
        r, c = wp.tid()
        y = row0 + r * row_step
        first = wp.max(c * cols, x0)
        stop = wp.min(c * cols + cols, x1)
        if first < stop:
            span(color, exposure[0].scale, encoder, out, luma, y, first, stop)

    return tonemap_pixels


TONEMAP_KERNELS = {
    (name, with_luma): _make_tonemap_kernel(name, with_luma) for name in CHANNEL_CPP for with_luma in (False, True)
}


@wp.kernel
def fxaa_pixels(
    ldr: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    edges: wp.array2d(dtype=wp.int32),
    x0: int,
    x1: int,
    row0: int,
    row_step: int,
    cols: int,
):
    """FXAA over the 8-bit sRGB image ``ldr`` (its luma in ``luma``) into ``out``, in the
    columns ``x0 <= x < x1`` of the launched rows: each pixel ``ldr``'s colour, the edge
    pixels' then anti-aliased (``edges``: (H, W) scratch, where each launch item lists
    its edge pixels)."""
    r, c = wp.tid()
    y = row0 + r * row_step
    first = wp.max(c * cols, x0)
    stop = wp.min(c * cols + cols, x1)
    if first < stop:
        n = fxaa_edge_pixels(ldr, luma, out, edges, y, first, stop)
        if n > 0:
            fxaa_edge_span(ldr, luma, out, edges, y, first, n)
