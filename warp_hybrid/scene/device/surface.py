"""Surface evaluation shared by every pass that looks at a triangle hit.

The raster resolve pass, the ray-cast primary pass and the secondary-ray tracer all
call these ``@wp.func`` device functions, so a surface looks the same whichever way
it was found.  This module holds no kernels (it is compiled into the modules that
call it).

Barycentric convention (the one ``wp.mesh_query_ray`` returns, see Warp's
``native/mesh.h`` ``mesh_eval_position``): for triangle ``tri`` with corners
``i0, i1, i2 = indices[3 tri + 0..2]`` and weights ``(bu, bv)``::

    P = bu * p[i0] + bv * p[i1] + (1 - bu - bv) * p[i2]

i.e. ``bu`` is the weight of the first corner, ``bv`` of the second.  Corner
attributes (``corner_normals``, ``corner_uvs`` at ``3 tri + k``) use the same weights.

Texture convention: USD uv (0, 0) is the bottom-left of the image while texel row 0
is its top row, so ``v`` flips against rows.  Sampling is bilinear between texel
centres; the result is ``filtered texel * scale + bias`` (UsdUVTexture).  Wrap modes
(``model.Wrap``): repeat, clamp (edge texels), mirror (mirrored repeat) and black
(texels outside the image read as 0 before scale and bias).  A binding's uv transform
(UsdTransform2d, ``TextureGPU.uv_u/uv_v``) maps the mesh uv (and its pixel footprint)
before any of this.  A vertex-coloured material (``FLAG_VERTEX_COLOR``) takes its
diffuse colour from the interpolated ``corner_colors``.

Normal maps (``MaterialGPU.normal_tex``, ``perturb_normal``): the sampled rgb (after
scale and bias) is a tangent-space normal (x, y, z): x along the texture's +u (its
right), y along its +v (up in the picture: texel row 0 is the top, so "green up",
OpenGL style), z along the interpolated normal N.  The frame is per triangle: T and B
solve dP = T du + B dv over the triangle's edges in the binding's uv (after its
UsdTransform2d, so a rotated or mirrored mapping turns the frame with it); T is
orthonormalised against N (Gram-Schmidt) and B = +-N x T, its sign that of the solved
B (mirrored uvs give a left-handed frame).  The perturbed normal is
normalize(T x + B y + N z) (filtered texels of a mip level are shorter than unit:
renormalised).  It is built in the surface's own frame, and the facing flip (the
normal turned towards the ray) is decided on N and applied to the result, so the
back of a bump reads as a dent.  Degenerate uv triangles and samples with no
tangential part (x = y = 0: a flat map) keep N bit for bit.  The geometric normal
stays the face normal.

Minification: material textures carry box-filtered mip chains (``mipmaps``).  The
G-buffer passes know each pixel's uv footprint (``uv_footprint``: ray differentials
of the camera rays, on the hit triangle's plane), the tracer's secondary hits their
pixel's ray cone (``trace/cone.py``), and both sample trilinearly at OpenGL's
isotropic level of detail, log2 of the longer pixel axis in level-0 texels
(``surface_at_grad``, ``sample_texture_grad``).  Where that is <= 0 (magnified) the
lookup is the plain bilinear level-0 one, which ``surface_at`` and ``sample_texture``
always use.  Alpha tests (``is_cut_away``) read level 0, so every pass cuts the same
holes.
"""

from __future__ import annotations

import warp as wp

from ...core.native_rows import LAMBDA_HEADER_CPP
from ...core.scene_gpu import FLAG_CUTOUT, FLAG_SPECULAR_WORKFLOW, FLAG_VERTEX_COLOR, MaterialGPU, SceneGPU, TextureGPU
from ..model import Wrap

WRAP_REPEAT = wp.constant(int(Wrap.REPEAT))


@wp.struct
class SurfaceHit:
    """A shaded surface point.

    position: world-space point.  normal: unit shading normal (interpolated corner
    normals, perturbed by the material's normal map) facing against the ray.
    geometric_normal: unit face normal facing against the ray.  front_face: 1 when
    the ray hit the side the winding (counter-clockwise) faces, 0 for the back side
    (glass: 1 = entering).
    albedo: diffuse colour * (1 - metallic), textures applied.  specular: F0.
    emission: emitted radiance.  material: index into the material table (-1 none).
    flags: the material's ``FLAG_*`` bits.
    """

    position: wp.vec3
    normal: wp.vec3
    geometric_normal: wp.vec3
    front_face: int
    uv: wp.vec2
    albedo: wp.vec3
    specular: wp.vec3
    emission: wp.vec3
    roughness: float
    metallic: float
    opacity: float
    ior: float
    material: int
    flags: int


# The texture lookups, the surface's frame and its material as native lambdas, the one
# implementation of each: the scalar functions below wrap them (``@wp.func_native``) and
# the surface pass's row loop (``primary/kernels.py``) evaluates them over a chunk of
# pixels.  Bilinear taps in native code: Warp's array indexing (negative-index folding
# and a stride multiply per access) made them ~1.6x slower.  Repeat wrapping in both axes
# (nearly every texture) has its own short lambda.  Coordinates are folded first so taps
# stay near the image (repeat -> [0, 1), mirror -> [0, 2), clamp/black -> clamped just
# past the edges), so the tap indices need no integer division: repeat i in [-1, n],
# mirror i in [-1, 2n].  A non-finite uv (NaN, or an infinity folded to NaN) reads black,
# never out of bounds.  The operations are those of the Python they replaced, one at a
# time (``wp::`` calls where Warp would write them), so the bits are too.
#: C++ lambdas: texture sampling (see the module docstring), ``t`` a ``TextureGPU``.
TEXTURE_CPP = (
    LAMBDA_HEADER_CPP
    + """
// The bilinear footprint of (u, v) in the width x height level at texel offset ``offset``,
// repeating in both axes: the four texels' indices into the pool (i00, i01 in the upper row,
// i10, i11 in the lower) and the blend's weights wx1, wy1; false where the point is not
// finite (its indices then texel 0's row and column, its value black).  Branch-free.
auto wh_repeat_footprint = [&](int offset, int width, int height, float u, float v, int& i00, int& i01, int& i10,
                               int& i11, float& wx1, float& wy1) WH_INLINE -> bool {
    const float vf = 1.0f - v;
    const float xf = (u - wp::floor(u)) * (float)width - 0.5f;
    const float yf = (vf - wp::floor(vf)) * (float)height - 0.5f;
    const bool finite = xf == xf && yf == yf;
    const float x = finite ? xf : 0.0f;
    const float y = finite ? yf : 0.0f;
    const float x0f = wp::floor(x);
    const float y0f = wp::floor(y);
    wx1 = x - x0f;
    wy1 = y - y0f;
    int c0 = (int)x0f;
    int r0 = (int)y0f;
    int c1 = c0 + 1;
    int r1 = r0 + 1;
    c0 = c0 < 0 ? c0 + width : c0;
    r0 = r0 < 0 ? r0 + height : r0;
    c1 = c1 >= width ? c1 - width : c1;
    r1 = r1 >= height ? r1 - height : r1;
    const int row0 = offset + r0 * width, row1 = offset + r1 * width;
    i00 = row0 + c0;
    i01 = row0 + c1;
    i10 = row1 + c0;
    i11 = row1 + c1;
    return finite;
};
// Channel k of a footprint's (``wh_repeat_footprint``'s) bilinear value in the texel pool:
// black where it is not finite.
auto wh_footprint_channel = [&](const wp::vec4* texels, int i00, int i01, int i10, int i11, float wx1, float wy1,
                                bool finite, int k) WH_INLINE -> float {
    // (each texel's float by an int index into the texel pool, which a loop across pixels
    // gathers in 16 lanes; a pointer per lane took two gathers of 8: ``MAX_TEXEL_FLOATS``)
    const float* flat = (const float*)texels;
    const float top = wh_lerp(flat[4 * i00 + k], flat[4 * i01 + k], wx1);
    const float bottom = wh_lerp(flat[4 * i10 + k], flat[4 * i11 + k], wx1);
    return finite ? wh_lerp(top, bottom, wy1) : 0.0f;
};
// Channel k of the bilinear lookup in the width x height level at offset, repeating in both
// axes.  One channel at a time, so a loop over pixels vectorises it (a non-finite point
// taps texel 0 and reads black).
auto wh_bilinear_repeat_channel = [&](const wp::vec4* texels, int offset, int width, int height, float u, float v,
                                      int k) WH_INLINE -> float {
    int i00, i01, i10, i11;
    float wx1, wy1;
    const bool finite = wh_repeat_footprint(offset, width, height, u, v, i00, i01, i10, i11, wx1, wy1);
    return wh_footprint_channel(texels, i00, i01, i10, i11, wx1, wy1, finite, k);
};
// All four channels.
auto wh_bilinear_repeat = [&](const wp::vec4* texels, int offset, int width, int height, float u,
                              float v) WH_INLINE -> wp::vec4 {
    return wp::vec4(wh_bilinear_repeat_channel(texels, offset, width, height, u, v, 0),
                    wh_bilinear_repeat_channel(texels, offset, width, height, u, v, 1),
                    wh_bilinear_repeat_channel(texels, offset, width, height, u, v, 2),
                    wh_bilinear_repeat_channel(texels, offset, width, height, u, v, 3));
};
"""
    + f"""auto wh_bilinear_wrapped = [&](const wp::vec4* texels, int offset, int width, int height, int wrap_s, int wrap_t,
                               float u, float v) WH_INLINE -> wp::vec4 {{
    auto fold = [](float a, int mode) -> float {{
        if (mode == {int(Wrap.REPEAT)}) return a - wp::floor(a);
        if (mode == {int(Wrap.MIRROR)}) return a - 2.0f * wp::floor(0.5f * a);
        return wp::clamp(a, -1.0f, 2.0f);
    }};
    auto wrap = [](int i, int n, int mode) -> int {{
        if (mode == {int(Wrap.REPEAT)}) return i < 0 ? i + n : (i >= n ? i - n : i);
        if (mode == {int(Wrap.MIRROR)}) {{
            int m = i < 0 ? -1 - i : i;
            if (m >= 2 * n) m -= 2 * n;
            return m >= n ? 2 * n - 1 - m : m;
        }}
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
    }};
    auto weight = [](float w, int i, int n, int mode) -> float {{
        return (mode == {int(Wrap.BLACK)} && (i < 0 || i >= n)) ? 0.0f : w;
    }};
    const float x = fold(u, wrap_s) * (float)width - 0.5f;
    const float y = fold(1.0f - v, wrap_t) * (float)height - 0.5f;
    if (!(u == u && v == v && x == x && y == y)) return wp::vec4(0.0f);
    const float x0f = wp::floor(x);
    const float y0f = wp::floor(y);
    const float fx = x - x0f;
    const float fy = y - y0f;
    const int x0 = (int)x0f;
    const int y0 = (int)y0f;
    const int c0 = wrap(x0, width, wrap_s);
    const int c1 = wrap(x0 + 1, width, wrap_s);
    const int r0 = wrap(y0, height, wrap_t);
    const int r1 = wrap(y0 + 1, height, wrap_t);
    const float wx0 = weight(1.0f - fx, x0, width, wrap_s);
    const float wx1 = weight(fx, x0 + 1, width, wrap_s);
    const float wy0 = weight(1.0f - fy, y0, height, wrap_t);
    const float wy1 = weight(fy, y0 + 1, height, wrap_t);
    const wp::vec4* row0 = texels + offset + r0 * width;
    const wp::vec4* row1 = texels + offset + r1 * width;
    return (row0[c0] * wx0 + row0[c1] * wx1) * wy0 + (row1[c0] * wx0 + row1[c1] * wx1) * wy1;
}};
// Bilinear in the width x height level at offset of binding t, its wrap modes (no scale or bias).
auto wh_bilinear = [&](const wp::vec4* texels, const auto& t, int offset, int width, int height,
                       const wp::vec2& uv) WH_INLINE -> wp::vec4 {{
    if (t.wrap_s == {int(Wrap.REPEAT)} && t.wrap_t == {int(Wrap.REPEAT)})
        return wh_bilinear_repeat(texels, offset, width, height, uv[0], uv[1]);
    return wh_bilinear_wrapped(texels, offset, width, height, t.wrap_s, t.wrap_t, uv[0], uv[1]);
}};
// The mesh uv through binding t's uv transform (UsdTransform2d).
auto wh_texture_uv = [&](const auto& t, const wp::vec2& uv) WH_INLINE -> wp::vec2 {{
    const wp::vec3 p(uv[0], uv[1], 1.0f);
    return wp::vec2(wp::dot(t.uv_u, p), wp::dot(t.uv_v, p));
}};
// log2 of a positive normal float to within 0.005 (exponent plus a quadratic in the
// mantissa): plenty for picking a mip level, and no libm call.
auto wh_log2_approx = [&](float x) WH_INLINE -> float {{
    union {{ float f; unsigned int u; }} c;
    c.f = x;
    float e = (float)((int)((c.u >> 23) & 255u) - 127);
    c.u = (c.u & 0x007FFFFFu) | 0x3F800000u;
    return e + (-0.34484843f * c.f + 2.02466578f) * c.f - 1.67487759f;
}};
// OpenGL's isotropic level of detail of binding t for the mesh-uv footprint fp:
// -1 (level 0) where magnified.
auto wh_lod = [&](const auto& t, const wp::vec4& fp) WH_INLINE -> float {{
    const float ax = wp::mul(wp::add(wp::mul(t.uv_u[0], fp[0]), wp::mul(t.uv_u[1], fp[1])), (float)t.width);
    const float ay = wp::mul(wp::add(wp::mul(t.uv_v[0], fp[0]), wp::mul(t.uv_v[1], fp[1])), (float)t.height);
    const float bx = wp::mul(wp::add(wp::mul(t.uv_u[0], fp[2]), wp::mul(t.uv_u[1], fp[3])), (float)t.width);
    const float by = wp::mul(wp::add(wp::mul(t.uv_v[0], fp[2]), wp::mul(t.uv_v[1], fp[3])), (float)t.height);
    const float rho2 = wp::max(wp::add(wp::mul(ax, ax), wp::mul(ay, ay)), wp::add(wp::mul(bx, bx), wp::mul(by, by)));
    if (!(rho2 > 1.0f)) return -1.0f;
    return wp::mul(0.5f, wh_log2_approx(wp::min(rho2, 1.0e30f)));
}};
// The mip level a level of detail picks, clamped to binding t's chain: floor(lod) and the
// fraction toward the next level; level 0 and no fraction where lod <= 0 (magnified).
auto wh_mip_level = [&](const auto& t, float lod, int& level, float& frac) WH_INLINE {{
    const float lod_c = wp::min(lod, (float)wp::sub(t.levels, 1));
    const bool minified = lod_c > 0.0f;
    level = minified ? (int)lod_c : 0;
    frac = minified ? wp::sub(lod_c, (float)level) : 0.0f;
}};
// One channel of a level's texel blended toward the next level's by frac (where frac > 0).
auto wh_mip_blend = [&](float fine, float coarse, float frac) WH_INLINE -> float {{
    return frac > 0.0f ? wh_lerp(fine, coarse, frac) : fine;
}};
// The filtered texel (before scale and bias) of binding t: bilinear in the level, blended
// toward the next one by frac where frac > 0.
auto wh_trilinear_at = [&](const wp::vec4* texels, const auto& t, const wp::vec2& uv, int level,
                           float frac) WH_INLINE -> wp::vec4 {{
    auto at = [&](int l) WH_INLINE -> wp::vec4 {{
        return wh_bilinear(texels, t, l == 0 ? t.offset : t.level_offsets[l], wp::max(t.width >> l, 1),
                           wp::max(t.height >> l, 1), uv);
    }};
    const wp::vec4 v = at(level);
    if (!(frac > 0.0f)) return v;
    const wp::vec4 c = at(level + 1);
    return wp::vec4(wh_mip_blend(v[0], c[0], frac), wh_mip_blend(v[1], c[1], frac), wh_mip_blend(v[2], c[2], frac),
                    wh_mip_blend(v[3], c[3], frac));
}};
// The filtered texel (before scale and bias) of binding t at level of detail lod.
auto wh_trilinear = [&](const wp::vec4* texels, const auto& t, const wp::vec2& uv, float lod) WH_INLINE -> wp::vec4 {{
    int level;
    float frac;
    wh_mip_level(t, lod, level, frac);
    return wh_trilinear_at(texels, t, uv, level, frac);
}};
// Binding tex of the scene at uv (before its transform) and level of detail lod, scale and bias applied.
auto wh_sample_lod = [&](const auto& scene, int tex, const wp::vec2& uv, float lod) WH_INLINE -> wp::vec4 {{
    const auto& t = scene.textures.data[tex];
    return wp::add(wp::cw_mul(wh_trilinear(scene.texels.data, t, wh_texture_uv(t, uv), lod), t.scale), t.bias);
}};
// The same at the level of detail of the footprint fp.
auto wh_sample_grad = [&](const auto& scene, int tex, const wp::vec2& uv, const wp::vec4& fp) WH_INLINE -> wp::vec4 {{
    const auto& t = scene.textures.data[tex];
    return wp::add(wp::cw_mul(wh_trilinear(scene.texels.data, t, wh_texture_uv(t, uv), wh_lod(t, fp)), t.scale),
                   t.bias);
}};
"""
)


@wp.func_native(TEXTURE_CPP + "return wh_sample_lod(scene, tex, uv, -1.0f);")
def sample_texture(scene: SceneGPU, tex: int, uv: wp.vec2) -> wp.vec4:
    """Bilinearly sample texture binding ``tex`` at USD ``uv`` (v up, before the
    binding's uv transform) in mip level 0, with its wrap modes, then apply its scale
    and bias."""
    ...


@wp.func_native(TEXTURE_CPP + "return wh_sample_lod(scene, tex, uv, lod);")
def sample_texture_lod(scene: SceneGPU, tex: int, uv: wp.vec2, lod: float) -> wp.vec4:
    """Trilinearly sample texture binding ``tex`` at USD ``uv`` and level of detail
    ``lod`` (log2 of the footprint in level-0 texels, clamped to the chain): bilinear
    in levels floor(lod) and floor(lod) + 1, blended by the fraction; lod <= 0 is the
    plain bilinear level-0 lookup of ``sample_texture``.  Scale and bias applied."""
    ...


@wp.func_native(TEXTURE_CPP + "return wh_lod(scene.textures.data[tex], footprint);")
def texture_lod(scene: SceneGPU, tex: int, footprint: wp.vec4) -> float:
    """Isotropic level of detail (OpenGL's) of binding ``tex`` for the uv footprint
    (du/dx, dv/dx, du/dy, dv/dy) of one pixel: log2 of the longer of the two pixel
    axes measured in level-0 texels (to within 0.005); -1 when the texture is
    magnified (and for a zero footprint), which selects level 0.  The footprint is in
    mesh uv, before the binding's uv transform."""
    ...


@wp.func_native(TEXTURE_CPP + "return wh_sample_grad(scene, tex, uv, footprint);")
def sample_texture_grad(scene: SceneGPU, tex: int, uv: wp.vec2, footprint: wp.vec4) -> wp.vec4:
    """``sample_texture_lod`` at the level of detail ``texture_lod`` picks for the
    pixel footprint (du/dx, dv/dx, du/dy, dv/dy)."""
    ...


@wp.func_native(TEXTURE_CPP + "return wh_texture_uv(t, uv);")
def _texture_uv(t: TextureGPU, uv: wp.vec2) -> wp.vec2:
    """The mesh ``uv`` through binding ``t``'s uv transform (UsdTransform2d)."""
    ...


#: C++ lambdas: texture sampling (``TEXTURE_CPP``), the surface's frame and its material
#: (see ``surface_at_grad``).
SURFACE_CPP = (
    TEXTURE_CPP
    + f"""
// The value at barycentrics (bu, bv, bw) of the corner values a, b, c (floats or vectors).
auto wh_corners = [&](const auto& a, const auto& b, const auto& c, float bu, float bv, float bw) WH_INLINE {{
    return wp::add(wp::add(wp::mul(a, bu), wp::mul(b, bv)), wp::mul(c, bw));
}};
// The frame at barycentrics (bu, bv) of the triangle p0, p1, p2 (corner normals n0..n2,
// corner uvs t0..t2) seen along d: the position, the face normal turned against d and
// whether d hits its front, the uv (u, v), the interpolated normal (unit; the face
// normal where it vanishes; before any normal map) and whether it faced along d.
// Branch-free, so a loop over pixels vectorises.
auto wh_surface_frame = [&](const wp::vec3& p0, const wp::vec3& p1, const wp::vec3& p2, const wp::vec3& n0,
                            const wp::vec3& n1, const wp::vec3& n2, const wp::vec2& t0, const wp::vec2& t1,
                            const wp::vec2& t2, float bu, float bv, const wp::vec3& d, wp::vec3& position,
                            wp::vec3& ng, bool& front, float& u, float& v, wp::vec3& n, bool& away) WH_INLINE {{
    const float bw = wp::sub(wp::sub(1.0f, bu), bv);
    position = wh_corners(p0, p1, p2, bu, bv, bw);
    const wp::vec3 c = wp::cross(wp::sub(p1, p0), wp::sub(p2, p0));
    const float c_len = wp::length(c);
    ng = wh_select(c_len > 0.0f, wp::div(c, c_len), wp::neg(wh_normalize(d)));
    front = !(wp::dot(ng, d) > 0.0f);
    ng = wh_select(front, ng, wp::neg(ng));
    u = wh_corners(t0[0], t1[0], t2[0], bu, bv, bw);
    v = wh_corners(t0[1], t1[1], t2[1], bu, bv, bw);
    const wp::vec3 s = wh_corners(n0, n1, n2, bu, bv, bw);
    const float s_len = wp::length(s);
    n = wh_select(s_len > 1.0e-12f, wp::div(s, s_len), ng);
    away = wp::dot(n, d) > 0.0f;
}};
// The diffuse colour times (1 - metallic), specular F0, roughness, metallic and opacity of
// material m given its inputs' values (constants, vertex colours or textures).
auto wh_material_finish = [&](const auto& m, const wp::vec3& diffuse, float r, float metal, float o,
                              wp::vec3& albedo, wp::vec3& specular, float& roughness, float& metallic,
                              float& opacity) WH_INLINE {{
    // branch-free, so a loop over a chunk of one material vectorises
    const bool given = (m.flags & {int(FLAG_SPECULAR_WORKFLOW)}) != 0;  // the specular workflow's own F0
    const float f = wp::div(wp::sub(m.ior, 1.0f), wp::add(m.ior, 1.0f));
    const float f0 = wp::mul(f, f);
    const float mc = wp::clamp(metal, 0.0f, 1.0f);
    specular = wh_select(given, m.specular,
                         wp::add(wp::mul(wp::vec3(f0, f0, f0), wp::sub(1.0f, mc)), wp::mul(diffuse, mc)));
    metal = given ? 0.0f : mc;
    albedo = wp::mul(diffuse, wp::sub(1.0f, metal));
    roughness = wp::clamp(r, 0.0f, 1.0f);
    metallic = metal;
    opacity = wp::clamp(o, 0.0f, 1.0f);
}};
// Material m at the point of barycentrics (bu, bv) of the triangle whose first corner is k,
// uv there, textures filtered over the footprint fp: the diffuse colour times
// (1 - metallic), the specular F0, the emission, roughness, metallic and opacity.
auto wh_material = [&](const auto& scene, const auto& m, int k, float bu, float bv, const wp::vec2& uv,
                       const wp::vec4& fp, wp::vec3& albedo, wp::vec3& specular, wp::vec3& emission,
                       float& roughness, float& metallic, float& opacity) WH_INLINE {{
    auto channel = [](const wp::vec4& s, int c) WH_INLINE -> float {{ return s[wp::clamp(c, 0, 3)]; }};
    wp::vec3 diffuse = m.diffuse;
    if ((m.flags & {int(FLAG_VERTEX_COLOR)}) != 0) {{
        const float bw = wp::sub(wp::sub(1.0f, bu), bv);
        const wp::vec3* cc = scene.corner_colors.data;
        diffuse = wh_corners(cc[k], cc[k + 1], cc[k + 2], bu, bv, bw);
    }}
    if (m.diffuse_tex >= 0) {{
        const wp::vec4 s = wh_sample_grad(scene, m.diffuse_tex, uv, fp);
        diffuse = wp::vec3(s[0], s[1], s[2]);
    }}
    emission = m.emissive;
    if (m.emissive_tex >= 0) {{
        const wp::vec4 s = wh_sample_grad(scene, m.emissive_tex, uv, fp);
        emission = wp::vec3(s[0], s[1], s[2]);
    }}
    float r = m.roughness;
    if (m.roughness_tex >= 0) r = channel(wh_sample_grad(scene, m.roughness_tex, uv, fp), m.roughness_channel);
    float metal = m.metallic;
    if (m.metallic_tex >= 0) metal = channel(wh_sample_grad(scene, m.metallic_tex, uv, fp), m.metallic_channel);
    float o = m.opacity;
    if (m.opacity_tex >= 0) o = channel(wh_sample_grad(scene, m.opacity_tex, uv, fp), m.opacity_channel);
    wh_material_finish(m, diffuse, r, metal, o, albedo, specular, roughness, metallic, opacity);
}};
"""
)


@wp.func_native(
    SURFACE_CPP
    + """
wp::vec3 position, ng, n;
bool front, away;
float u, v;
wh_surface_frame(p0, p1, p2, n0, n1, n2, t0, t1, t2, bu, bv, d, position, ng, front, u, v, n, away);
return wp::mat44(position[0], position[1], position[2], front ? 1.0f : 0.0f, ng[0], ng[1], ng[2],
                 away ? 1.0f : 0.0f, n[0], n[1], n[2], 0.0f, u, v, 0.0f, 0.0f);
"""
)
def _surface_frame(
    p0: wp.vec3,
    p1: wp.vec3,
    p2: wp.vec3,
    n0: wp.vec3,
    n1: wp.vec3,
    n2: wp.vec3,
    t0: wp.vec2,
    t1: wp.vec2,
    t2: wp.vec2,
    bu: float,
    bv: float,
    d: wp.vec3,
) -> wp.mat44:
    """``wh_surface_frame`` as rows (position, front face 1/0), (face normal, faced
    away 1/0), (interpolated normal, 0), (u, v, 0, 0)."""
    ...


@wp.func_native(
    SURFACE_CPP
    + """
wp::vec3 albedo, specular, emission;
float roughness, metallic, opacity;
wh_material(scene, m, k, bu, bv, uv, footprint, albedo, specular, emission, roughness, metallic, opacity);
return wp::mat44(albedo[0], albedo[1], albedo[2], roughness, specular[0], specular[1], specular[2], metallic,
                 emission[0], emission[1], emission[2], opacity, 0.0f, 0.0f, 0.0f, 0.0f);
"""
)
def _material_values(
    scene: SceneGPU, m: MaterialGPU, k: int, bu: float, bv: float, uv: wp.vec2, footprint: wp.vec4
) -> wp.mat44:
    """``wh_material`` as rows (albedo, roughness), (specular, metallic), (emission,
    opacity)."""
    ...


#: C++ statements: ray differentials (Igehy 1999) on the triangle ``p0, p1, p2`` with corner
#: uvs ``uv0, uv1, uv2``: ``fp``, how the uv of the hit of the ray ``o + t d`` with the
#: triangle's plane changes when the direction moves by ``ddx`` and by ``ddy`` (the origin
#: fixed), as (du/dx, dv/dx, du/dy, dv/dy).  No branch: a ray parallel to the plane gives a
#: huge footprint (the coarsest level).  Hit weights of p1 and p2: b1 = d.A / d.C,
#: b2 = d.Q / d.C (Moller-Trumbore).  Written once for ``uv_footprint`` and the surface
#: pass's row loop (``primary/kernels.py``), the same bits in each.
UV_FOOTPRINT_CPP = """
const wp::vec3 fp_e1 = wp::sub(p1, p0);
const wp::vec3 fp_e2 = wp::sub(p2, p0);
const wp::vec3 fp_tv = wp::sub(o, p0);
const wp::vec3 fp_a = wp::cross(fp_e2, fp_tv);
const wp::vec3 fp_q = wp::cross(fp_tv, fp_e1);
const wp::vec3 fp_c = wp::cross(fp_e2, fp_e1);
const float fp_den = wp::dot(d, fp_c);
const float fp_inv = wp::div(1.0f, fp_den);
const float fp_b1 = wp::mul(wp::dot(d, fp_a), fp_inv);
const float fp_b2 = wp::mul(wp::dot(d, fp_q), fp_inv);
const float fp_dcx = wp::dot(ddx, fp_c);
const float fp_dcy = wp::dot(ddy, fp_c);
const float fp_db1x = wp::mul(wp::sub(wp::dot(ddx, fp_a), wp::mul(fp_b1, fp_dcx)), fp_inv);
const float fp_db2x = wp::mul(wp::sub(wp::dot(ddx, fp_q), wp::mul(fp_b2, fp_dcx)), fp_inv);
const float fp_db1y = wp::mul(wp::sub(wp::dot(ddy, fp_a), wp::mul(fp_b1, fp_dcy)), fp_inv);
const float fp_db2y = wp::mul(wp::sub(wp::dot(ddy, fp_q), wp::mul(fp_b2, fp_dcy)), fp_inv);
const wp::vec2 fp_du1 = wp::sub(uv1, uv0);
const wp::vec2 fp_du2 = wp::sub(uv2, uv0);
const wp::vec2 fp_gx = wp::add(wp::mul(fp_du1, fp_db1x), wp::mul(fp_du2, fp_db2x));
const wp::vec2 fp_gy = wp::add(wp::mul(fp_du1, fp_db1y), wp::mul(fp_du2, fp_db2y));
const bool fp_flat = fp_den == 0.0f;
const wp::vec4 fp(fp_flat ? 1.0e6f : fp_gx[0], fp_flat ? 1.0e6f : fp_gx[1], fp_flat ? 1.0e6f : fp_gy[0],
                  fp_flat ? 1.0e6f : fp_gy[1]);
"""


@wp.func_native(UV_FOOTPRINT_CPP + "return fp;")
def _footprint_of(
    p0: wp.vec3,
    p1: wp.vec3,
    p2: wp.vec3,
    uv0: wp.vec2,
    uv1: wp.vec2,
    uv2: wp.vec2,
    o: wp.vec3,
    d: wp.vec3,
    ddx: wp.vec3,
    ddy: wp.vec3,
) -> wp.vec4:
    """``uv_footprint`` of the triangle's corners and corner uvs (``UV_FOOTPRINT_CPP``)."""
    ...


@wp.func(inline=True)
def uv_footprint(scene: SceneGPU, tri: int, origin: wp.vec3, d: wp.vec3, ddx: wp.vec3, ddy: wp.vec3) -> wp.vec4:
    """Ray differentials (Igehy 1999) on triangle ``tri``: how the uv of the hit of the
    ray ``origin + t d`` with the triangle's plane changes when the direction moves
    by ``ddx`` and by ``ddy`` (the origin fixed).  Returns (du/dx, dv/dx, du/dy, dv/dy),
    the exact derivatives of the plane hit's uv; a ray parallel to the plane gives a
    huge footprint (the coarsest level)."""
    k = 3 * tri
    return _footprint_of(
        scene.points[scene.indices[k]],
        scene.points[scene.indices[k + 1]],
        scene.points[scene.indices[k + 2]],
        scene.corner_uvs[k],
        scene.corner_uvs[k + 1],
        scene.corner_uvs[k + 2],
        origin,
        d,
        ddx,
        ddy,
    )


#: C++ expression: whether material ``m`` (a ``MaterialGPU``) samples any texture (only then
#: does a caller need the footprint ``surface_at_grad`` filters over, or the uv at all).
SAMPLES_TEXTURES_CPP = (
    "(wp::max(wp::max(wp::max(m.diffuse_tex, m.emissive_tex), wp::max(m.roughness_tex, m.metallic_tex)),"
    " wp::max(m.opacity_tex, m.normal_tex)) >= 0)"
)


@wp.func_native(
    f"const auto& m = scene.materials.data[scene.triangle_material.data[tri]];\nreturn {SAMPLES_TEXTURES_CPP};"
)
def samples_textures(scene: SceneGPU, tri: int) -> bool:
    """Whether the triangle's material samples any texture (``SAMPLES_TEXTURES_CPP``)."""
    ...


@wp.func(inline=True)
def _channel(v: wp.vec4, c: int) -> float:
    return v[wp.clamp(c, 0, 3)]


@wp.func_native(
    SURFACE_CPP
    + """const wp::vec2* uvs = scene.corner_uvs.data + 3 * tri;
return wh_corners(uvs[0], uvs[1], uvs[2], bu, bv, wp::sub(wp::sub(1.0f, bu), bv));"""
)
def interpolate_uv(scene: SceneGPU, tri: int, bu: float, bv: float) -> wp.vec2:
    """Texture coordinates at barycentrics (bu, bv) of triangle ``tri``."""
    ...


@wp.func(inline=True)
def opacity_at(scene: SceneGPU, tri: int, bu: float, bv: float) -> float:
    """Material opacity (constant or textured channel) at barycentrics (bu, bv);
    used by alpha-tested cut-outs."""
    m = scene.materials[scene.triangle_material[tri]]
    if m.opacity_tex >= 0:
        return _channel(sample_texture(scene, m.opacity_tex, interpolate_uv(scene, tri, bu, bv)), m.opacity_channel)
    return m.opacity


@wp.func(inline=True)
def is_cut_away(scene: SceneGPU, tri: int, bu: float, bv: float) -> bool:
    """True when the hit lies in a cut-out hole: the material is alpha-tested and the
    opacity there is below its threshold (such hits are skipped by every pass)."""
    m = scene.materials[scene.triangle_material[tri]]
    if (m.flags & FLAG_CUTOUT) == 0:
        return False
    return opacity_at(scene, tri, bu, bv) < m.opacity_threshold


@wp.func(inline=True)
def _texture_corner_uv(scene: SceneGPU, t: TextureGPU, corner: int) -> wp.vec2:
    """The uv of flat corner ``corner`` through binding ``t``'s uv transform."""
    return _texture_uv(t, scene.corner_uvs[corner])


@wp.func(inline=True)
def perturb_normal(scene: SceneGPU, tex: int, tri: int, n: wp.vec3, uv: wp.vec2, footprint: wp.vec4) -> wp.vec3:
    """Unit normal ``n`` of triangle ``tri`` (interpolated, in the surface's own frame)
    perturbed by the tangent-space normal map ``tex`` sampled at USD ``uv`` over the
    pixel ``footprint`` (see the module docstring for the frame).  Returns ``n`` itself
    where the uv triangle is degenerate, where its tangent is parallel to ``n`` and
    where the sample has no tangential part."""
    s = sample_texture_grad(scene, tex, uv, footprint)
    if s[0] == 0.0 and s[1] == 0.0:
        return n
    t = scene.textures[tex]
    k = 3 * tri
    p0 = scene.points[scene.indices[k]]
    e1 = scene.points[scene.indices[k + 1]] - p0
    e2 = scene.points[scene.indices[k + 2]] - p0
    uv0 = _texture_corner_uv(scene, t, k)
    d1 = _texture_corner_uv(scene, t, k + 1) - uv0
    d2 = _texture_corner_uv(scene, t, k + 2) - uv0
    det = d1[0] * d2[1] - d2[0] * d1[1]
    if not (wp.abs(det) > 1.0e-6 * (wp.abs(d1[0] * d2[1]) + wp.abs(d2[0] * d1[1]))):
        return n
    dpdu = (e1 * d2[1] - e2 * d1[1]) / det
    dpdv = (e2 * d1[0] - e1 * d2[0]) / det
    tangent = dpdu - n * wp.dot(n, dpdu)
    t_len = wp.length(tangent)
    if not (t_len > 1.0e-6 * wp.length(dpdu)):
        return n
    tangent = tangent / t_len
    bitangent = wp.cross(n, tangent)
    if wp.dot(bitangent, dpdv) < 0.0:
        bitangent = -bitangent
    p = tangent * s[0] + bitangent * s[1] + n * s[2]
    p_len = wp.length(p)
    if not (p_len > 0.0):
        return n
    return p / p_len


@wp.func(inline=True)
def surface_at_grad(
    scene: SceneGPU, tri: int, bu: float, bv: float, ray_dir: wp.vec3, footprint: wp.vec4
) -> SurfaceHit:
    """Evaluate triangle ``tri`` at barycentrics (bu, bv) (Warp's convention, see the
    module docstring) seen along ``ray_dir``: position, normals facing the ray, uv and
    the material with its textures applied, each texture filtered over the pixel's uv
    ``footprint`` (du/dx, dv/dx, du/dy, dv/dy; see ``uv_footprint``)."""
    k = 3 * tri
    f = _surface_frame(
        scene.points[scene.indices[k]],
        scene.points[scene.indices[k + 1]],
        scene.points[scene.indices[k + 2]],
        scene.corner_normals[k],
        scene.corner_normals[k + 1],
        scene.corner_normals[k + 2],
        scene.corner_uvs[k],
        scene.corner_uvs[k + 1],
        scene.corner_uvs[k + 2],
        bu,
        bv,
        ray_dir,
    )
    h = SurfaceHit()
    h.position = wp.vec3(f[0, 0], f[0, 1], f[0, 2])
    h.front_face = int(f[0, 3])
    h.geometric_normal = wp.vec3(f[1, 0], f[1, 1], f[1, 2])
    uv = wp.vec2(f[3, 0], f[3, 1])
    h.uv = uv
    mid = scene.triangle_material[tri]
    m = scene.materials[mid]
    h.material = mid
    h.flags = m.flags
    n = wp.vec3(f[2, 0], f[2, 1], f[2, 2])
    if m.normal_tex >= 0:
        n = perturb_normal(scene, m.normal_tex, tri, n, uv, footprint)
    if f[1, 3] != 0.0:  # the interpolated normal faced away from the ray
        n = -n
    h.normal = n
    values = _material_values(scene, m, k, bu, bv, uv, footprint)
    h.albedo = wp.vec3(values[0, 0], values[0, 1], values[0, 2])
    h.roughness = values[0, 3]
    h.specular = wp.vec3(values[1, 0], values[1, 1], values[1, 2])
    h.metallic = values[1, 3]
    h.emission = wp.vec3(values[2, 0], values[2, 1], values[2, 2])
    h.opacity = values[2, 3]
    h.ior = m.ior
    return h


@wp.func(inline=True)
def surface_at(scene: SceneGPU, tri: int, bu: float, bv: float, ray_dir: wp.vec3) -> SurfaceHit:
    """``surface_at_grad`` with textures sampled unfiltered (bilinear in mip level 0)."""
    return surface_at_grad(scene, tri, bu, bv, ray_dir, wp.vec4(0.0, 0.0, 0.0, 0.0))
