"""FXAA: Lottes' FXAA 3.11 "quality" edge anti-aliasing (``@wp.func``), after Rodriguez's
well-known restatement of it.

Runs on the tone-mapped 8-bit sRGB image (as FXAA does on a display buffer); luma is
computed from the sRGB values (``0.299 R + 0.587 G + 0.114 B``).  The tone-mapping pass
writes that luma of every pixel beside the 8-bit image (``LUMA_OF_CODES_CPP``: each
channel's weight times its code times 1/255, in float32, summed in channel order), so
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

import itertools
import math

import warp as wp

from ..core.native_rows import CHUNK_CPP, LAMBDA_HEADER_CPP, float_literal, row_cpp

EDGE_THRESHOLD = 0.166
EDGE_THRESHOLD_MIN = 0.0833
SUBPIX = 0.5
#: The edge search's steps (FXAA 3.11 quality preset 39): the first tap 1 px from the
#: boundary point, then one step per iteration.
SEARCH_STEP_PX = (1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0)
#: Each search tap's distance from the first (``SEARCH_STEP_PX``'s running sums past the
#: first step): multiples of 0.5, so a tap's position is exact however it is summed.
SEARCH_OFFSETS_PX = tuple(float(v) for v in itertools.accumulate(SEARCH_STEP_PX[1:], initial=0.0))
#: How many of each end's search taps are read first: a walk that departs among them
#: (most do) reads no more.
FIRST_SEARCH_TAPS = 4
#: How far (rows or columns) FXAA reads from the pixel it writes: the search's last
#: bilinear tap, half a pixel past its full length (the 3x3 test and the final colour
#: tap stay within 1).  A pixel's output changes only if its input changed this close.
FXAA_REACH_PX = max(1, math.ceil(sum(SEARCH_STEP_PX) + 0.5))


def luma_buffer(height: int, width: int, device: wp.context.Device | str) -> wp.array:
    """The luma buffer the tone map writes and FXAA reads: (height, width) floats, a view of
    rows two floats longer, a spare column on each side that the tone map keeps equal to
    the row's first and last pixel (the edge-clamped luma), so the search reads a tap's two
    columns as one 64-bit load (``fxaa_edge_span``; the columns must be contiguous)."""
    return wp.zeros((height, width + 2), dtype=float, device=device)[:, 1 : width + 1]


LUMA_WEIGHTS = (0.299, 0.587, 0.114)  # Rec. 601, as FXAA


#: C++ expression: the luma of the 8-bit codes ``r, g, b`` (ints), ``LUMA_WEIGHTS`` . the
#: sRGB values: per channel ``weight * (code * (1 / 255))`` in float32, the three terms
#: summed in channel order (the tone map writes it).
LUMA_OF_CODES_CPP = (
    f"wp::add(wp::add(wp::mul({float_literal(LUMA_WEIGHTS[0])}, wp::mul((float)r, {float_literal(1.0 / 255.0)})),"
    f" wp::mul({float_literal(LUMA_WEIGHTS[1])}, wp::mul((float)g, {float_literal(1.0 / 255.0)}))),"
    f" wp::mul({float_literal(LUMA_WEIGHTS[2])}, wp::mul((float)b, {float_literal(1.0 / 255.0)})))"
)


#: C++: the luma buffer's texel (x, y) with clamp-to-edge addressing (by an int index, which
#: a loop across pixels gathers in 16 lanes; a byte offset in size_t took two gathers of 8).
_LUMA_AT_CPP = """
const float* const luma_floats = (const float*)luma.data;
const int luma_row = luma.strides[0] / (int)sizeof(float), luma_col = luma.strides[1] / (int)sizeof(float);
auto luma_at = [&](int x, int y) WH_INLINE -> float {
    const int yy = wp::clamp(y, 0, (int)luma.shape[0] - 1);
    const int xx = wp::clamp(x, 0, (int)luma.shape[1] - 1);
    return luma_floats[yy * luma_row + xx * luma_col];
};
"""


#: C++ statements: the luma range ``rng`` and maximum ``lmax`` of a pixel's luma ``lc``
#: and its four neighbours' ``lu, ld, ll, lr`` (step 1).
_RANGE_CPP = """
const float lmin = wp::min(lc, wp::min(wp::min(lu, ld), wp::min(ll, lr)));
const float lmax = wp::max(lc, wp::max(wp::max(lu, ld), wp::max(ll, lr)));
const float rng = lmax - lmin;
"""

#: C++ statements: whether that range passes the contrast test (``edge``, bool).
_EDGE_TEST_CPP = (
    f"const bool edge = rng >= wp::max({float_literal(EDGE_THRESHOLD_MIN)}, lmax * {float_literal(EDGE_THRESHOLD)});"
)


def _edge_at(x: str, left: str, right: str) -> str:
    """C++ statements: ``edge`` for the pixel at column ``x`` of the rows ``row``, ``up``
    and ``down``, its left and right neighbours at columns ``left`` and ``right``."""
    return (
        f"const float lc = row[{x}]; const float lu = up[{x}]; const float ld = down[{x}];"
        f" const float ll = row[{left}]; const float lr = row[{right}];" + _RANGE_CPP + _EDGE_TEST_CPP
    )


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


#: C++: steps 2-4 (module docstring) for the edge pixels a row's contrast test listed,
#: ``CHUNK`` of them at a time: the orientation, the sub-pixel estimate and the final
#: colour tap in loops across the chunk's pixels (the compiler vectorises them; the taps
#: are gathers), the searches pixel by pixel, each across its taps: the first
#: ``FIRST_SEARCH_TAPS`` taps of both ends at once (their positions, ``SEARCH_OFFSETS_PX``
#: from the first, do not depend on the lumas), then each end's first departing one, and
#: only where an end has none among them the rest of the taps likewise; walked tap by tap,
#: each read waited on the last one's test.  A tap read past where its end stops changes
#: nothing.
#: One Warp operation a call, so the compiler fuses nothing and every pixel gets the
#: scalar arithmetic; a bilinear tap of weight exactly 0 adds 0 to a finite luma or code,
#: so taking every tap changes no bit against skipping it.
_EDGE_SPAN_CPP = (
    CHUNK_CPP
    + LAMBDA_HEADER_CPP
    + _LUMA_AT_CPP
    + f"""
constexpr float INV_255 = {float_literal(1.0 / 255.0)};  // (float32, as Warp rounds the constant)
constexpr int SEARCH_TAPS = {len(SEARCH_OFFSETS_PX)};
constexpr int FIRST_TAPS = {FIRST_SEARCH_TAPS};
static const float search_offsets[] = {{{", ".join(float_literal(v) for v in SEARCH_OFFSETS_PX)}}};
const int* list = {row_cpp("edges", "y", "int")} + x0;
wp::uint8* dst = {row_cpp("out", "y", "wp::uint8", const=False)};
const char* codes = (const char*)img.data;
// (byte offsets as ints, as ``luma_at``'s index)
const int code_row = img.strides[0], code_col = img.strides[1], code_channel = img.strides[2];
auto code = [&](int x, int yy, int k) WH_INLINE -> float {{
    const int ty = wp::clamp(yy, 0, (int)img.shape[0] - 1);
    const int tx = wp::clamp(x, 0, (int)img.shape[1] - 1);
    return wp::mul((float)*(const wp::uint8*)(codes + (ty * code_row + tx * code_col + k * code_channel)), INV_255);
}};
// bilinear luma and colour channel k at continuous pixel coordinates (pixel centres at i + 0.5)
// (a tap's two columns of a row as one 64-bit load, ``luma_buffer``'s spare columns standing
// for the clamped ones: the pair at x0 clamped to [-1, width - 1] holds what ``luma_at``
// reads at x0 and x0 + 1; a loop across pixels gathers one 64-bit lane a pair)
auto luma_pair = [&](const int x0, const int y, float& left, float& right) WH_INLINE {{
    const int yy = wp::clamp(y, 0, (int)luma.shape[0] - 1);
    const int xx = wp::clamp(x0, -1, (int)luma.shape[1] - 1);
    wh_load2(luma_floats + (yy * luma_row + xx), left, right);
}};
auto bilinear_luma = [&](float px, float py) WH_INLINE -> float {{
    const float bx = wp::sub(px, 0.5f), by = wp::sub(py, 0.5f);
    const float x0f = wp::floor(bx), y0f = wp::floor(by);
    const float fx = wp::sub(bx, x0f), fy = wp::sub(by, y0f);
    const int x0 = (int)x0f, y0 = (int)y0f;
    float a00, a01, a10, a11;
    luma_pair(x0, y0, a00, a01);
    luma_pair(x0, y0 + 1, a10, a11);
    return wh_lerp(wh_lerp(a00, a01, fx), wh_lerp(a10, a11, fx), fy);
}};
auto bilinear_code = [&](float px, float py, int k) WH_INLINE -> float {{
    const float bx = wp::sub(px, 0.5f), by = wp::sub(py, 0.5f);
    const float x0f = wp::floor(bx), y0f = wp::floor(by);
    const float fx = wp::sub(bx, x0f), fy = wp::sub(by, y0f);
    const int x0 = (int)x0f, y0 = (int)y0f;
    return wh_lerp(wh_lerp(code(x0, y0, k), code(x0 + 1, y0, k), fx),
                   wh_lerp(code(x0, y0 + 1, k), code(x0 + 1, y0 + 1, k), fx), fy);
}};
float cxs[CHUNK], cys[CHUNK], lcs[CHUNK], avg[CHUNK], grad[CHUNK], steps[CHUNK], ox[CHUNK], oy[CHUNK];
float p1x[CHUNK], p1y[CHUNK], p2x[CHUNK], p2y[CHUNK], end1[CHUNK], end2[CHUNK], sub[CHUNK];
float first1[FIRST_TAPS][CHUNK], first2[FIRST_TAPS][CHUNK];
int stop1[CHUNK], stop2[CHUNK];
bool horizontal[CHUNK];
wp::uint8 rgb[3][CHUNK];
for (int s0 = 0; s0 < n; s0 += CHUNK) {{
    const int m = n - s0 < CHUNK ? n - s0 : CHUNK;
    // step 2: the edge's orientation, its two sides, the search's start (and step 4's
    // sub-pixel estimate); its stores go only to the chunk's own arrays, which the
    // compiler could not tell apart from the gathered luma reads without being told
    #pragma clang loop vectorize(assume_safety)
    for (int j = 0; j < m; ++j) {{
        const int x = list[s0 + j];
        const float lc = luma_at(x, y), lu = luma_at(x, y - 1), ld = luma_at(x, y + 1);
        const float ll = luma_at(x - 1, y), lr = luma_at(x + 1, y);
        {_RANGE_CPP}
        const float lul = luma_at(x - 1, y - 1), lur = luma_at(x + 1, y - 1);
        const float ldl = luma_at(x - 1, y + 1), ldr = luma_at(x + 1, y + 1);
        const float lud = wp::add(lu, ld), llr = wp::add(ll, lr);
        const float left_corners = wp::add(lul, ldl), right_corners = wp::add(lur, ldr);
        const float up_corners = wp::add(lul, lur), down_corners = wp::add(ldl, ldr);
        const float edge_h = wp::add(wp::add(wp::abs(wp::add(wp::mul(-2.0f, ll), left_corners)),
                                             wp::mul(wp::abs(wp::add(wp::mul(-2.0f, lc), lud)), 2.0f)),
                                     wp::abs(wp::add(wp::mul(-2.0f, lr), right_corners)));
        const float edge_v = wp::add(wp::add(wp::abs(wp::add(wp::mul(-2.0f, lu), up_corners)),
                                             wp::mul(wp::abs(wp::add(wp::mul(-2.0f, lc), llr)), 2.0f)),
                                     wp::abs(wp::add(wp::mul(-2.0f, ld), down_corners)));
        const bool h = edge_h >= edge_v;
        const float luma1 = h ? lu : ll, luma2 = h ? ld : lr;
        const float g1 = wp::sub(luma1, lc), g2 = wp::sub(luma2, lc);
        const bool negative = wp::abs(g1) >= wp::abs(g2);
        const float step = negative ? -1.0f : 1.0f;
        const float local_avg = wp::mul(0.5f, wp::add(negative ? luma1 : luma2, lc));
        const float cx = wp::add((float)x, 0.5f), cy = wp::add((float)y, 0.5f);
        const float bx = h ? cx : wp::add(cx, wp::mul(0.5f, step));
        const float by = h ? wp::add(cy, wp::mul(0.5f, step)) : cy;
        ox[j] = h ? 1.0f : 0.0f;
        oy[j] = h ? 0.0f : 1.0f;
        p1x[j] = wp::sub(bx, ox[j]); p1y[j] = wp::sub(by, oy[j]);
        p2x[j] = wp::add(bx, ox[j]); p2y[j] = wp::add(by, oy[j]);
        grad[j] = wp::mul(0.25f, wp::max(wp::abs(g1), wp::abs(g2)));
        avg[j] = local_avg;
        steps[j] = step;
        cxs[j] = cx; cys[j] = cy; lcs[j] = lc;
        horizontal[j] = h;
        const float low_pass = wp::div(wp::add(wp::add(wp::mul(2.0f, wp::add(lud, llr)), left_corners), right_corners),
                                       12.0f);
        const float sub1 = wp::clamp(wp::div(wp::abs(wp::sub(low_pass, lc)), rng), 0.0f, 1.0f);
        const float sub2 = wp::mul(wp::mul(wp::add(wp::mul(-2.0f, sub1), 3.0f), sub1), sub1);
        sub[j] = wp::mul(wp::mul(sub2, sub2), {float_literal(SUBPIX)});
    }}
    // step 3: each end walks outward until its luma departs from the edge's mean.  Where a
    // walk's taps lie does not depend on the lumas, only where it stops does: the first
    // few taps of both ends are read for every pixel of the chunk, tap by tap across the
    // pixels (no chain of dependent reads); a pixel with an end that walks past them reads
    // the rest, across its taps; each end stops at its first departing tap (or its last)
    for (int i = 0; i < FIRST_TAPS; ++i) {{
        #pragma clang loop vectorize(assume_safety)
        for (int j = 0; j < m; ++j) {{
            const float dx = wp::mul(ox[j], search_offsets[i]), dy = wp::mul(oy[j], search_offsets[i]);
            first1[i][j] = wp::sub(bilinear_luma(wp::sub(p1x[j], dx), wp::sub(p1y[j], dy)), avg[j]);
            first2[i][j] = wp::sub(bilinear_luma(wp::add(p2x[j], dx), wp::add(p2y[j], dy)), avg[j]);
        }}
    }}
    // the first departing tap of an end among its first taps (FIRST_TAPS where none does)
    for (int j = 0; j < m; ++j) {{
        int at1 = FIRST_TAPS, at2 = FIRST_TAPS;
        for (int i = FIRST_TAPS - 1; i >= 0; --i) {{
            at1 = wp::abs(first1[i][j]) >= grad[j] ? i : at1;
            at2 = wp::abs(first2[i][j]) >= grad[j] ? i : at2;
        }}
        stop1[j] = at1;
        stop2[j] = at2;
    }}
    for (int j = 0; j < m; ++j) {{
        const float gj = grad[j], aj = avg[j], sx = ox[j], sy = oy[j];
        const float x1 = p1x[j], y1 = p1y[j], x2 = p2x[j], y2 = p2y[j];
        int i1 = stop1[j], i2 = stop2[j];
        float e1 = i1 < FIRST_TAPS ? first1[i1][j] : 0.0f, e2 = i2 < FIRST_TAPS ? first2[i2][j] : 0.0f;
        if (i1 == FIRST_TAPS || i2 == FIRST_TAPS) {{
            // (the rest of the taps of both ends, across the taps)
            float e1s[SEARCH_TAPS], e2s[SEARCH_TAPS];
            #pragma clang loop vectorize(enable)
            for (int i = FIRST_TAPS; i < SEARCH_TAPS; ++i) {{
                const float dx = wp::mul(sx, search_offsets[i]), dy = wp::mul(sy, search_offsets[i]);
                e1s[i] = wp::sub(bilinear_luma(wp::sub(x1, dx), wp::sub(y1, dy)), aj);
                e2s[i] = wp::sub(bilinear_luma(wp::add(x2, dx), wp::add(y2, dy)), aj);
            }}
            // the first departing tap among taps FIRST_TAPS .. SEARCH_TAPS - 2, else the last
            auto stop = [&](const float* es) WH_INLINE -> int {{
                int at = SEARCH_TAPS - 1;
                for (int i = SEARCH_TAPS - 2; i >= FIRST_TAPS; --i) at = wp::abs(es[i]) >= gj ? i : at;
                return at;
            }};
            if (i1 == FIRST_TAPS) {{
                i1 = stop(e1s);
                e1 = e1s[i1];
            }}
            if (i2 == FIRST_TAPS) {{
                i2 = stop(e2s);
                e2 = e2s[i2];
            }}
        }}
        p1x[j] = wp::sub(x1, wp::mul(sx, search_offsets[i1])); p1y[j] = wp::sub(y1, wp::mul(sy, search_offsets[i1]));
        p2x[j] = wp::add(x2, wp::mul(sx, search_offsets[i2])); p2y[j] = wp::add(y2, wp::mul(sy, search_offsets[i2]));
        end1[j] = e1; end2[j] = e2;
    }}
    // step 4: the blend offset and the colour there, as 8-bit codes (stored after the
    // loop: the pixels' scattered byte stores kept it from vectorising)
    #pragma clang loop vectorize(enable)
    for (int j = 0; j < m; ++j) {{
        const bool h = horizontal[j];
        const float cx = cxs[j], cy = cys[j];
        const float d1 = h ? wp::sub(cx, p1x[j]) : wp::sub(cy, p1y[j]);
        const float d2 = h ? wp::sub(p2x[j], cx) : wp::sub(p2y[j], cy);
        const float nearer_end = d1 < d2 ? end1[j] : end2[j];
        const float dist = d1 < d2 ? d1 : d2;
        const bool confirmed = (nearer_end < 0.0f) != (lcs[j] < avg[j]);
        float offset = confirmed ? wp::sub(0.5f, wp::div(dist, wp::add(d1, d2))) : 0.0f;
        offset = wp::max(offset, sub[j]);
        const float shift = wp::mul(offset, steps[j]);
        const float px = h ? cx : wp::add(cx, shift), py = h ? wp::add(cy, shift) : cy;
        for (int k = 0; k < 3; ++k)
            rgb[k][j] = (wp::uint8)(int)wp::add(wp::mul(wp::clamp(bilinear_code(px, py, k), 0.0f, 1.0f), 255.0f), 0.5f);
    }}
    for (int j = 0; j < m; ++j)
        for (int k = 0; k < 3; ++k) dst[3 * list[s0 + j] + k] = rgb[k][j];
}}
"""
)


@wp.func_native(_EDGE_SPAN_CPP)
def fxaa_edge_span(
    img: wp.array3d(dtype=wp.uint8),
    luma: wp.array2d(dtype=float),
    out: wp.array3d(dtype=wp.uint8),
    edges: wp.array2d(dtype=wp.int32),
    y: int,
    x0: int,
    n: int,
):
    """Steps 2-4 for the ``n`` pixels of row ``y`` that ``fxaa_edge_pixels`` listed in
    ``edges[y, x0:]``: each one's anti-aliased 8-bit colour of ``img`` (its luma in
    ``luma``) into ``out`` (``_EDGE_SPAN_CPP``)."""
    ...
