"""FXAA: Lottes' FXAA 3.11 "quality" edge anti-aliasing (``@wp.func``), after Rodriguez's
well-known restatement of it.

Runs on the tone-mapped 8-bit sRGB image (as FXAA does on a display buffer); luma is
computed from the sRGB values (``0.299 R + 0.587 G + 0.114 B``).  The tone-mapping pass
writes that luma of every pixel beside the 8-bit image (``LUMA_OF_CODES_CPP``, from a
256-entry table per channel that reproduces the per-texel arithmetic bit for bit), so
the edge tests read one float per texel.  Per pixel:

1. Local contrast of the centre and its 4 neighbours; pixels whose luma range is below
   ``max(EDGE_THRESHOLD_MIN, EDGE_THRESHOLD * max luma)`` are returned unchanged (so a
   flat image is untouched, bit for bit).
2. Edge orientation from the 3x3 neighbourhood's second differences; the side with the
   steeper gradient is the other half of the edge.
3. Search along the edge (bilinear luma on the edge boundary, ``SEARCH_STEP_PX``: 12
   steps of 1, 1, 1, 1, 1, 1.5, 2, 2, 2, 2, 4, 8 pixels) until the luma departs from the edge's mean by a
   quarter of the local gradient on both ends.  The search filters the luma buffer
   itself, as FXAA filters its luma channel: luma is linear in the codes, so this is
   the luma of the filtered colour up to float rounding, at one float per tap instead
   of three codes.
4. The blend offset perpendicular to the edge is ``0.5 - distance to the nearer end /
   edge length`` (only if that end's luma confirms the direction), or the sub-pixel
   aliasing estimate ``SUBPIX * smoothstep(|lowpass - centre| / range)^2`` if larger;
   the output is the bilinear colour at the centre moved by that offset.

Settings: edge threshold 0.166 with a 0.0833 floor (FXAA 3.11's defaults) and
``SUBPIX = 0.5`` (FXAA's "sharper" end instead of its 0.75 default): a 1-px line
keeps about 80% of its encoded energy instead of about 69%.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..core.native_rows import CHUNK_CPP, row_cpp

EDGE_THRESHOLD = 0.166
EDGE_THRESHOLD_MIN = 0.0833
SUBPIX = wp.constant(0.5)
#: The edge search's steps (FXAA 3.11 quality preset 39): the first tap 1 px from the
#: boundary point, then one step per iteration.
SEARCH_STEP_PX = (1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0)
SEARCH_STEPS = wp.constant(len(SEARCH_STEP_PX))
#: How far (rows or columns) FXAA reads from the pixel it writes: the search's last
#: bilinear tap, half a pixel past its full length (the 3x3 test and the final colour
#: tap stay within 1).  A pixel's output changes only if its input changed this close.
FXAA_REACH_PX = max(1, math.ceil(sum(SEARCH_STEP_PX) + 0.5))
INV_255 = wp.constant(1.0 / 255.0)
LUMA_WEIGHTS = (0.299, 0.587, 0.114)  # Rec. 601, as FXAA


def luma_table() -> np.ndarray:
    """(256, 3) float32: the terms of the luma (``LUMA_WEIGHTS`` . sRGB values in
    [0, 1]) for each 8-bit code and channel, ``weight_c * (code * (1 / 255))`` in
    float32."""
    scaled = np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0)
    return np.stack([np.float32(w) * scaled for w in LUMA_WEIGHTS], axis=-1)


#: C++ expression: the luma of the 8-bit codes ``r, g, b`` from ``luma_table`` (``lut``, a
#: ``const wp::vec3*``), its three terms summed in channel order (the tone map writes it).
LUMA_OF_CODES_CPP = "lut[r][0] + lut[g][1] + lut[b][2]"


@wp.func(inline=True)
def _texel(img: wp.array3d(dtype=wp.uint8), x: int, y: int) -> wp.vec3:
    """Texel in [0, 1] with clamp-to-edge addressing."""
    yy = wp.clamp(y, 0, img.shape[0] - 1)
    xx = wp.clamp(x, 0, img.shape[1] - 1)
    return wp.vec3(float(img[yy, xx, 0]) * INV_255, float(img[yy, xx, 1]) * INV_255, float(img[yy, xx, 2]) * INV_255)


#: C++: the luma buffer's texel (x, y) with clamp-to-edge addressing.
_LUMA_AT_CPP = """
auto luma_at = [&](int x, int y) -> float {
    const int yy = wp::clamp(y, 0, (int)luma.shape[0] - 1);
    const int xx = wp::clamp(x, 0, (int)luma.shape[1] - 1);
    return *(const float*)((const char*)luma.data + (size_t)yy * luma.strides[0] + (size_t)xx * luma.strides[1]);
};
"""


@wp.func_native(_LUMA_AT_CPP + "return luma_at(x, y);")
def _luma(luma: wp.array2d(dtype=float), x: int, y: int) -> float:
    """Luma with clamp-to-edge addressing."""
    ...


@wp.func(inline=True)
def _bilinear(img: wp.array3d(dtype=wp.uint8), px: float, py: float) -> wp.vec3:
    """Bilinear colour at continuous pixel coordinates (pixel centres at i + 0.5).  Taps
    whose weight is exactly 0 are skipped (the blend offset moves along one axis only),
    which leaves the result unchanged bit for bit."""
    x = px - 0.5
    y = py - 0.5
    x0f = wp.floor(x)
    y0f = wp.floor(y)
    fx = x - x0f
    fy = y - y0f
    x0 = int(x0f)
    y0 = int(y0f)
    top = _texel(img, x0, y0)
    if fx > 0.0:
        top = top * (1.0 - fx) + _texel(img, x0 + 1, y0) * fx
    if fy > 0.0:
        bottom = _texel(img, x0, y0 + 1)
        if fx > 0.0:
            bottom = bottom * (1.0 - fx) + _texel(img, x0 + 1, y0 + 1) * fx
        return top * (1.0 - fy) + bottom * fy
    return top


@wp.func_native(
    _LUMA_AT_CPP
    + """
const float x = wp::sub(px, 0.5f);
const float y = wp::sub(py, 0.5f);
const float x0f = wp::floor(x);
const float y0f = wp::floor(y);
const float fx = wp::sub(x, x0f);
const float fy = wp::sub(y, y0f);
const int x0 = (int)x0f;
const int y0 = (int)y0f;
float top = luma_at(x0, y0);
if (fx > 0.0f) top = wp::add(wp::mul(top, wp::sub(1.0f, fx)), wp::mul(luma_at(x0 + 1, y0), fx));
if (!(fy > 0.0f)) return top;
float bottom = luma_at(x0, y0 + 1);
if (fx > 0.0f) bottom = wp::add(wp::mul(bottom, wp::sub(1.0f, fx)), wp::mul(luma_at(x0 + 1, y0 + 1), fx));
return wp::add(wp::mul(top, wp::sub(1.0f, fy)), wp::mul(bottom, fy));
"""
)
def _bilinear_luma(luma: wp.array2d(dtype=float), px: float, py: float) -> float:
    """Bilinear luma at continuous pixel coordinates (``_bilinear``'s taps, on the luma
    buffer), in native code (Warp's 2-D indexing and clamps cost the edge search a
    fifth of its time)."""
    ...


@wp.func_native(
    "static const float steps[] = {" + ", ".join(f"{v!r}f" for v in SEARCH_STEP_PX) + "};\nreturn steps[i];"
)
def _search_step(i: int) -> float:
    """The search's step length (pixels) at iteration i >= 1 (``SEARCH_STEP_PX``), from a
    static table (a Warp vector constant is built again on every call)."""
    ...


@wp.func
def fxaa_edge(
    img: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    x: int,
    y: int,
    lc: float,
    lu: float,
    ld: float,
    ll: float,
    lr: float,
    rng: float,
) -> wp.vec3:
    """Steps 2-4 for a pixel that passed the contrast test: the blended colour in [0, 1]."""
    lul = _luma(luma, x - 1, y - 1)
    lur = _luma(luma, x + 1, y - 1)
    ldl = _luma(luma, x - 1, y + 1)
    ldr = _luma(luma, x + 1, y + 1)
    lud = lu + ld
    llr = ll + lr
    left_corners = lul + ldl
    right_corners = lur + ldr
    up_corners = lul + lur
    down_corners = ldl + ldr
    edge_h = wp.abs(-2.0 * ll + left_corners) + wp.abs(-2.0 * lc + lud) * 2.0 + wp.abs(-2.0 * lr + right_corners)
    edge_v = wp.abs(-2.0 * lu + up_corners) + wp.abs(-2.0 * lc + llr) * 2.0 + wp.abs(-2.0 * ld + down_corners)
    horizontal = edge_h >= edge_v

    # neighbours across the edge: 1 at the negative side, 2 at the positive side
    luma1 = ll
    luma2 = lr
    if horizontal:
        luma1 = lu
        luma2 = ld
    g1 = luma1 - lc
    g2 = luma2 - lc
    gradient_scaled = 0.25 * wp.max(wp.abs(g1), wp.abs(g2))
    step = 1.0
    local_avg = 0.5 * (luma2 + lc)
    if wp.abs(g1) >= wp.abs(g2):
        step = -1.0
        local_avg = 0.5 * (luma1 + lc)

    cx = float(x) + 0.5
    cy = float(y) + 0.5
    # start on the boundary between the two sides; walk along the edge (ox, oy)
    bx = cx
    by = cy
    ox = 0.0
    oy = 1.0
    if horizontal:
        by = cy + 0.5 * step
        ox = 1.0
        oy = 0.0
    else:
        bx = cx + 0.5 * step
    # walk each end outward until the luma departs from the edge's mean (the two
    # ends are independent: each stops at its own first departure)
    p1x = bx - ox
    p1y = by - oy
    end1 = _bilinear_luma(luma, p1x, p1y) - local_avg
    i = int(1)
    while i < SEARCH_STEPS and wp.abs(end1) < gradient_scaled:
        s = _search_step(i)
        p1x -= ox * s
        p1y -= oy * s
        end1 = _bilinear_luma(luma, p1x, p1y) - local_avg
        i += 1
    p2x = bx + ox
    p2y = by + oy
    end2 = _bilinear_luma(luma, p2x, p2y) - local_avg
    i = int(1)
    while i < SEARCH_STEPS and wp.abs(end2) < gradient_scaled:
        s = _search_step(i)
        p2x += ox * s
        p2y += oy * s
        end2 = _bilinear_luma(luma, p2x, p2y) - local_avg
        i += 1

    d1 = cy - p1y
    d2 = p2y - cy
    if horizontal:
        d1 = cx - p1x
        d2 = p2x - cx
    nearer_end = end2
    dist = d2
    if d1 < d2:
        nearer_end = end1
        dist = d1
    offset = 0.0
    if (nearer_end < 0.0) != (lc < local_avg):
        offset = 0.5 - dist / (d1 + d2)

    low_pass = (2.0 * (lud + llr) + left_corners + right_corners) / 12.0
    sub1 = wp.clamp(wp.abs(low_pass - lc) / rng, 0.0, 1.0)
    sub2 = (-2.0 * sub1 + 3.0) * sub1 * sub1
    offset = wp.max(offset, sub2 * sub2 * SUBPIX)

    if horizontal:
        return _bilinear(img, cx, cy + offset * step)
    return _bilinear(img, cx + offset * step, cy)


def _float32_cpp(value: float) -> str:
    """``value`` rounded to float32, as an exact C++ float literal (hexadecimal)."""
    return f"{float(np.float32(value)).hex()}f"


#: C++ statements: the luma range ``rng`` and maximum ``lmax`` of a pixel's luma ``lc``
#: and its four neighbours' ``lu, ld, ll, lr`` (step 1).
_RANGE_CPP = """
const float lmin = wp::min(lc, wp::min(wp::min(lu, ld), wp::min(ll, lr)));
const float lmax = wp::max(lc, wp::max(wp::max(lu, ld), wp::max(ll, lr)));
const float rng = lmax - lmin;
"""

#: C++ statements: whether that range passes the contrast test (``edge``, bool).
_EDGE_TEST_CPP = (
    f"const bool edge = rng >= wp::max({_float32_cpp(EDGE_THRESHOLD_MIN)}, lmax * {_float32_cpp(EDGE_THRESHOLD)});"
)


def _edge_at(x: str, left: str, right: str) -> str:
    """C++ statements: ``edge`` for the pixel at column ``x`` of the rows ``row``, ``up``
    and ``down``, its left and right neighbours at columns ``left`` and ``right``."""
    return (
        f"const float lc = row[{x}]; const float lu = up[{x}]; const float ld = down[{x}];"
        f" const float ll = row[{left}]; const float lr = row[{right}];" + _RANGE_CPP + _EDGE_TEST_CPP
    )


@wp.func_native(_RANGE_CPP + "return rng;")
def luma_range(lc: float, lu: float, ld: float, ll: float, lr: float) -> float:
    """Step 1's luma range of the centre ``lc`` and its neighbours up, down, left and right."""
    ...


@wp.func_native(
    CHUNK_CPP
    + f"""
const int h = luma.shape[0];
const int w = luma.shape[1];
const float* row = {row_cpp("luma", "y", "float")};
const float* up = {row_cpp("luma", "y > 0 ? y - 1 : 0", "float")};
const float* down = {row_cpp("luma", "y + 1 < h ? y + 1 : h - 1", "float")};
const wp::uint8* src = {row_cpp("img", "y", "wp::uint8")};
wp::uint8* dst = {row_cpp("out", "y", "wp::uint8", const=False)};
for (int i = 3 * x0; i < 3 * x1; ++i) dst[i] = src[i];
wp::int32* list = {row_cpp("edges", "y", "wp::int32", const=False)} + x0;
int n = 0;
if (x0 == 0 && x1 > 0) {{
    {_edge_at("0", "0", "w > 1 ? 1 : 0")}
    if (edge) list[n++] = 0;
}}
const int inner0 = x0 > 1 ? x0 : 1;
const int inner1 = x1 < w - 1 ? x1 : w - 1;
bool flags[CHUNK];
for (int xs = inner0; xs < inner1; xs += CHUNK) {{
    const int m = inner1 - xs < CHUNK ? inner1 - xs : CHUNK;
    for (int i = 0; i < m; ++i) {{
        {_edge_at("xs + i", "xs + i - 1", "xs + i + 1")}
        flags[i] = edge;
    }}
    for (int i = 0; i < m; ++i)
        if (flags[i]) list[n++] = xs + i;
}}
if (w > 1 && x1 == w && x0 <= w - 1) {{
    {_edge_at("w - 1", "w - 2", "w - 1")}
    if (edge) list[n++] = w - 1;
}}
return n;
"""
)
def fxaa_edge_pixels(
    img: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    edges: wp.array2d(dtype=wp.int32),
    y: int,
    x0: int,
    x1: int,
) -> int:
    """Step 1 over pixels ``x0 <= x < x1`` of row ``y``: copies their colour from ``img``
    to ``out`` and lists, in ``edges[y, x0:]`` in order, the pixels whose luma range
    (``luma_range``) is at least ``max(EDGE_THRESHOLD_MIN, EDGE_THRESHOLD * max luma)``;
    returns how many.  A native row loop the compiler vectorises across pixels (the
    border columns, whose neighbours clamp to the edge, apart)."""
    ...


@wp.func(inline=True)
def fxaa_pixel(
    img: wp.array3d(dtype=wp.uint8), luma: wp.array2d(dtype=float), out: wp.array3d(dtype=wp.uint8), x: int, y: int
):
    """Write the anti-aliased 8-bit colour of pixel (x, y) of ``img`` (luma beside it in
    ``luma``), one ``fxaa_edge_pixels`` listed (it passed the contrast test), into ``out``."""
    lc = luma[y, x]
    lu = _luma(luma, x, y - 1)
    ld = _luma(luma, x, y + 1)
    ll = _luma(luma, x - 1, y)
    lr = _luma(luma, x + 1, y)
    c = fxaa_edge(img, luma, x, y, lc, lu, ld, ll, lr, luma_range(lc, lu, ld, ll, lr))
    for k in range(3):
        out[y, x, k] = wp.uint8(int(wp.clamp(c[k], 0.0, 1.0) * 255.0 + 0.5))
