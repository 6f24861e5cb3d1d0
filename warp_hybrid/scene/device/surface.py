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

from ...core.scene_gpu import FLAG_CUTOUT, FLAG_SPECULAR_WORKFLOW, FLAG_VERTEX_COLOR, SceneGPU, TextureGPU
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


# Bilinear filtering of one mip level, in native code: Warp's array indexing
# (negative-index folding and a stride multiply per access) made the taps ~1.6x
# slower.  Repeat wrapping in both axes (nearly every texture) has its own short
# function.  Coordinates are folded first so taps stay near the image (repeat ->
# [0, 1), mirror -> [0, 2), clamp/black -> clamped just past the edges), so the tap
# indices need no integer division: repeat i in [-1, n], mirror i in [-1, 2n].  A
# non-finite uv (NaN, or an infinity folded to NaN) reads black, never out of bounds.
_BILINEAR_TAPS = """
const wp::vec4* row0 = texels.data + offset + r0 * width;
const wp::vec4* row1 = texels.data + offset + r1 * width;
return (row0[c0] * wx0 + row0[c1] * wx1) * wy0 + (row1[c0] * wx0 + row1[c1] * wx1) * wy1;
"""


@wp.func_native(
    """
const float vf = 1.0f - v;
const float x = (u - wp::floor(u)) * (float)width - 0.5f;
const float y = (vf - wp::floor(vf)) * (float)height - 0.5f;
if (!(x == x && y == y)) return wp::vec4(0.0f);
const float x0f = wp::floor(x);
const float y0f = wp::floor(y);
const float wx1 = x - x0f;
const float wy1 = y - y0f;
const float wx0 = 1.0f - wx1;
const float wy0 = 1.0f - wy1;
int c0 = (int)x0f;
int r0 = (int)y0f;
int c1 = c0 + 1;
int r1 = r0 + 1;
c0 = c0 < 0 ? c0 + width : c0;
r0 = r0 < 0 ? r0 + height : r0;
c1 = c1 >= width ? c1 - width : c1;
r1 = r1 >= height ? r1 - height : r1;
"""
    + _BILINEAR_TAPS
)
def _bilinear_repeat(
    texels: wp.array(dtype=wp.vec4), offset: int, width: int, height: int, u: float, v: float
) -> wp.vec4:
    """Bilinear lookup between texel centres of the ``width`` x ``height`` image at
    ``texels[offset:]`` (row 0 at the top) at USD (u, v), repeating in both axes."""
    ...


@wp.func_native(
    f"""
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
"""
    + _BILINEAR_TAPS
)
def _bilinear_wrapped(
    texels: wp.array(dtype=wp.vec4),
    offset: int,
    width: int,
    height: int,
    wrap_s: int,
    wrap_t: int,
    u: float,
    v: float,
) -> wp.vec4:
    """``_bilinear_repeat`` for any wrap modes ``wrap_s``, ``wrap_t`` (``model.Wrap``:
    repeat, clamp to the edge texels, mirrored repeat, black: taps outside weigh 0)."""
    ...


@wp.func(inline=True)
def _bilinear(scene: SceneGPU, t: TextureGPU, offset: int, width: int, height: int, uv: wp.vec2) -> wp.vec4:
    """Bilinear lookup in the ``width`` x ``height`` level at ``offset`` of binding
    ``t`` (no scale or bias)."""
    if t.wrap_s == WRAP_REPEAT and t.wrap_t == WRAP_REPEAT:
        return _bilinear_repeat(scene.texels, offset, width, height, uv[0], uv[1])
    return _bilinear_wrapped(scene.texels, offset, width, height, t.wrap_s, t.wrap_t, uv[0], uv[1])


@wp.func(inline=True)
def _texture_uv(t: TextureGPU, uv: wp.vec2) -> wp.vec2:
    """The mesh ``uv`` through binding ``t``'s uv transform (UsdTransform2d)."""
    p = wp.vec3(uv[0], uv[1], 1.0)
    return wp.vec2(wp.dot(t.uv_u, p), wp.dot(t.uv_v, p))


@wp.func(inline=True)
def sample_texture(scene: SceneGPU, tex: int, uv: wp.vec2) -> wp.vec4:
    """Bilinearly sample texture binding ``tex`` at USD ``uv`` (v up, before the
    binding's uv transform) in mip level 0, with its wrap modes, then apply its scale
    and bias."""
    t = scene.textures[tex]
    return wp.cw_mul(_bilinear(scene, t, t.offset, t.width, t.height, _texture_uv(t, uv)), t.scale) + t.bias


@wp.func_native(
    """union { float f; unsigned int u; } c; c.f = x;
float e = (float)((int)((c.u >> 23) & 255u) - 127);
c.u = (c.u & 0x007FFFFFu) | 0x3F800000u;
return e + (-0.34484843f * c.f + 2.02466578f) * c.f - 1.67487759f;"""
)
def _log2_approx(x: float) -> float:
    """log2 of a positive normal float to within 0.005 (exponent plus a quadratic in
    the mantissa): plenty for picking a mip level, and no libm call."""
    ...


@wp.func(inline=True)
def _trilinear(scene: SceneGPU, t: TextureGPU, uv: wp.vec2, lod: float) -> wp.vec4:
    """Filtered texel (before scale and bias) of binding ``t`` at ``lod``: see
    ``sample_texture_lod``."""
    lod_c = wp.min(lod, float(t.levels - 1))
    if not (lod_c > 0.0):
        return _bilinear(scene, t, t.offset, t.width, t.height, uv)
    level = int(lod_c)
    frac = lod_c - float(level)
    v = _bilinear(scene, t, t.level_offsets[level], wp.max(t.width >> level, 1), wp.max(t.height >> level, 1), uv)
    if frac > 0.0:
        up = level + 1
        coarse = _bilinear(scene, t, t.level_offsets[up], wp.max(t.width >> up, 1), wp.max(t.height >> up, 1), uv)
        v = v * (1.0 - frac) + coarse * frac
    return v


@wp.func(inline=True)
def sample_texture_lod(scene: SceneGPU, tex: int, uv: wp.vec2, lod: float) -> wp.vec4:
    """Trilinearly sample texture binding ``tex`` at USD ``uv`` and level of detail
    ``lod`` (log2 of the footprint in level-0 texels, clamped to the chain): bilinear
    in levels floor(lod) and floor(lod) + 1, blended by the fraction; lod <= 0 is the
    plain bilinear level-0 lookup of ``sample_texture``.  Scale and bias applied."""
    t = scene.textures[tex]
    return wp.cw_mul(_trilinear(scene, t, _texture_uv(t, uv), lod), t.scale) + t.bias


@wp.func(inline=True)
def _lod(t: TextureGPU, footprint: wp.vec4) -> float:
    # The footprint through the uv transform's linear part, then in level-0 texels.
    ax = (t.uv_u[0] * footprint[0] + t.uv_u[1] * footprint[1]) * float(t.width)
    ay = (t.uv_v[0] * footprint[0] + t.uv_v[1] * footprint[1]) * float(t.height)
    bx = (t.uv_u[0] * footprint[2] + t.uv_u[1] * footprint[3]) * float(t.width)
    by = (t.uv_v[0] * footprint[2] + t.uv_v[1] * footprint[3]) * float(t.height)
    rho2 = wp.max(ax * ax + ay * ay, bx * bx + by * by)
    if not (rho2 > 1.0):
        return -1.0
    return 0.5 * _log2_approx(wp.min(rho2, 1.0e30))


@wp.func(inline=True)
def texture_lod(scene: SceneGPU, tex: int, footprint: wp.vec4) -> float:
    """Isotropic level of detail (OpenGL's) of binding ``tex`` for the uv footprint
    (du/dx, dv/dx, du/dy, dv/dy) of one pixel: log2 of the longer of the two pixel
    axes measured in level-0 texels (to within 0.005); -1 when the texture is
    magnified (and for a zero footprint), which selects level 0.  The footprint is in
    mesh uv, before the binding's uv transform."""
    return _lod(scene.textures[tex], footprint)


@wp.func(inline=True)
def sample_texture_grad(scene: SceneGPU, tex: int, uv: wp.vec2, footprint: wp.vec4) -> wp.vec4:
    """``sample_texture_lod`` at the level of detail ``texture_lod`` picks for the
    pixel footprint (du/dx, dv/dx, du/dy, dv/dy)."""
    t = scene.textures[tex]
    return wp.cw_mul(_trilinear(scene, t, _texture_uv(t, uv), _lod(t, footprint)), t.scale) + t.bias


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


@wp.func(inline=True)
def samples_textures(scene: SceneGPU, tri: int) -> bool:
    """Whether the triangle's material samples any texture (only then does a caller need
    the footprint ``surface_at_grad`` filters over)."""
    m = scene.materials[scene.triangle_material[tri]]
    slots = wp.max(wp.max(m.diffuse_tex, m.emissive_tex), wp.max(m.roughness_tex, m.metallic_tex))
    return wp.max(wp.max(slots, m.opacity_tex), m.normal_tex) >= 0


@wp.func(inline=True)
def _channel(v: wp.vec4, c: int) -> float:
    return v[wp.clamp(c, 0, 3)]


@wp.func(inline=True)
def interpolate_uv(scene: SceneGPU, tri: int, bu: float, bv: float) -> wp.vec2:
    """Texture coordinates at barycentrics (bu, bv) of triangle ``tri``."""
    bw = 1.0 - bu - bv
    k = 3 * tri
    return scene.corner_uvs[k] * bu + scene.corner_uvs[k + 1] * bv + scene.corner_uvs[k + 2] * bw


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
    i0 = scene.indices[k]
    i1 = scene.indices[k + 1]
    i2 = scene.indices[k + 2]
    p0 = scene.points[i0]
    p1 = scene.points[i1]
    p2 = scene.points[i2]
    bw = 1.0 - bu - bv

    h = SurfaceHit()
    h.position = p0 * bu + p1 * bv + p2 * bw

    ng = wp.cross(p1 - p0, p2 - p0)
    ng_len = wp.length(ng)
    if ng_len > 0.0:
        ng = ng / ng_len
    else:
        ng = -wp.normalize(ray_dir)
    h.front_face = 1
    if wp.dot(ng, ray_dir) > 0.0:
        ng = -ng
        h.front_face = 0
    h.geometric_normal = ng

    uv = interpolate_uv(scene, tri, bu, bv)
    h.uv = uv

    mid = scene.triangle_material[tri]
    m = scene.materials[mid]
    h.material = mid
    h.flags = m.flags

    n = scene.corner_normals[k] * bu + scene.corner_normals[k + 1] * bv + scene.corner_normals[k + 2] * bw
    n_len = wp.length(n)
    if n_len > 1.0e-12:
        n = n / n_len
    else:
        n = ng
    away = wp.dot(n, ray_dir) > 0.0
    if m.normal_tex >= 0:
        n = perturb_normal(scene, m.normal_tex, tri, n, uv, footprint)
    if away:
        n = -n
    h.normal = n

    diffuse = m.diffuse
    if (m.flags & FLAG_VERTEX_COLOR) != 0:
        diffuse = scene.corner_colors[k] * bu + scene.corner_colors[k + 1] * bv + scene.corner_colors[k + 2] * bw
    if m.diffuse_tex >= 0:
        d = sample_texture_grad(scene, m.diffuse_tex, uv, footprint)
        diffuse = wp.vec3(d[0], d[1], d[2])
    emission = m.emissive
    if m.emissive_tex >= 0:
        e = sample_texture_grad(scene, m.emissive_tex, uv, footprint)
        emission = wp.vec3(e[0], e[1], e[2])
    roughness = m.roughness
    if m.roughness_tex >= 0:
        roughness = _channel(sample_texture_grad(scene, m.roughness_tex, uv, footprint), m.roughness_channel)
    metallic = m.metallic
    if m.metallic_tex >= 0:
        metallic = _channel(sample_texture_grad(scene, m.metallic_tex, uv, footprint), m.metallic_channel)
    opacity = m.opacity
    if m.opacity_tex >= 0:
        opacity = _channel(sample_texture_grad(scene, m.opacity_tex, uv, footprint), m.opacity_channel)

    if (m.flags & FLAG_SPECULAR_WORKFLOW) != 0:
        metallic = 0.0
        h.specular = m.specular
    else:
        metallic = wp.clamp(metallic, 0.0, 1.0)
        f = (m.ior - 1.0) / (m.ior + 1.0)
        f0 = f * f
        h.specular = wp.vec3(f0, f0, f0) * (1.0 - metallic) + diffuse * metallic
    h.albedo = diffuse * (1.0 - metallic)
    h.emission = emission
    h.roughness = wp.clamp(roughness, 0.0, 1.0)
    h.metallic = metallic
    h.opacity = wp.clamp(opacity, 0.0, 1.0)
    h.ior = m.ior
    return h


@wp.func(inline=True)
def surface_at(scene: SceneGPU, tri: int, bu: float, bv: float, ray_dir: wp.vec3) -> SurfaceHit:
    """``surface_at_grad`` with textures sampled unfiltered (bilinear in mip level 0)."""
    return surface_at_grad(scene, tri, bu, bv, ray_dir, wp.vec4(0.0, 0.0, 0.0, 0.0))
