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
(texels outside the image read as 0 before scale and bias).
"""

from __future__ import annotations

import warp as wp

from .device import FLAG_CUTOUT, FLAG_SPECULAR_WORKFLOW, SceneGPU, TextureGPU
from .model import Wrap

WRAP_REPEAT = wp.constant(int(Wrap.REPEAT))
WRAP_CLAMP = wp.constant(int(Wrap.CLAMP))
WRAP_MIRROR = wp.constant(int(Wrap.MIRROR))
WRAP_BLACK = wp.constant(int(Wrap.BLACK))


@wp.struct
class SurfaceHit:
    """A shaded surface point.

    position: world-space point.  normal: unit shading normal (interpolated corner
    normals) facing against the ray.  geometric_normal: unit face normal facing
    against the ray.  front_face: 1 when the ray hit the side the winding
    (counter-clockwise) faces, 0 for the back side (glass: 1 = entering).
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


@wp.func(inline=True)
def _wrap_coord(x: float, mode: int) -> float:
    """Fold a texture coordinate in [0, 1] units so bilinear taps stay near the image:
    repeat -> [0, 1), mirror -> [0, 2), clamp/black -> clamped just past the edges."""
    if mode == WRAP_REPEAT:
        return x - wp.floor(x)
    if mode == WRAP_MIRROR:
        return x - 2.0 * wp.floor(0.5 * x)
    return wp.clamp(x, -1.0, 2.0)


@wp.func(inline=True)
def _wrap_index(i: int, n: int, mode: int) -> int:
    """Texel index for tap ``i`` of an ``n``-texel axis; -1 means 'black'.  Taps come
    from a coordinate folded by ``_wrap_coord`` (repeat: i in [-1, n], mirror: i in
    [-1, 2n]), so no integer division is needed."""
    if mode == WRAP_REPEAT:
        if i < 0:
            return i + n
        if i >= n:
            return i - n
        return i
    if mode == WRAP_MIRROR:
        m = i
        if m < 0:
            m = -1 - m
        if m >= 2 * n:
            m = m - 2 * n
        if m >= n:
            m = 2 * n - 1 - m
        return m
    if mode == WRAP_CLAMP:
        return wp.clamp(i, 0, n - 1)
    if i < 0 or i >= n:
        return -1
    return i


@wp.func(inline=True)
def _texel(scene: SceneGPU, t: TextureGPU, col: int, row: int) -> wp.vec4:
    if col < 0 or row < 0:
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    return scene.texels[t.offset + row * t.width + col]


@wp.func(inline=True)
def sample_texture(scene: SceneGPU, tex: int, uv: wp.vec2) -> wp.vec4:
    """Bilinearly sample texture binding ``tex`` at USD ``uv`` (v up), with its wrap
    modes, then apply its scale and bias."""
    t = scene.textures[tex]
    fw = float(t.width)
    fh = float(t.height)
    s = _wrap_coord(uv[0], t.wrap_s)
    r = _wrap_coord(1.0 - uv[1], t.wrap_t)
    x = s * fw - 0.5
    y = r * fh - 0.5
    x0f = wp.floor(x)
    y0f = wp.floor(y)
    fx = x - x0f
    fy = y - y0f
    x0 = int(x0f)
    y0 = int(y0f)
    c0 = _wrap_index(x0, t.width, t.wrap_s)
    c1 = _wrap_index(x0 + 1, t.width, t.wrap_s)
    r0 = _wrap_index(y0, t.height, t.wrap_t)
    r1 = _wrap_index(y0 + 1, t.height, t.wrap_t)
    gx = 1.0 - fx
    gy = 1.0 - fy
    v = (
        _texel(scene, t, c0, r0) * (gx * gy)
        + _texel(scene, t, c1, r0) * (fx * gy)
        + _texel(scene, t, c0, r1) * (gx * fy)
        + _texel(scene, t, c1, r1) * (fx * fy)
    )
    return wp.cw_mul(v, t.scale) + t.bias


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
def surface_at(scene: SceneGPU, tri: int, bu: float, bv: float, ray_dir: wp.vec3) -> SurfaceHit:
    """Evaluate triangle ``tri`` at barycentrics (bu, bv) (Warp's convention, see the
    module docstring) seen along ``ray_dir``: position, normals facing the ray, uv and
    the material with its textures applied."""
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

    n = scene.corner_normals[k] * bu + scene.corner_normals[k + 1] * bv + scene.corner_normals[k + 2] * bw
    n_len = wp.length(n)
    if n_len > 1.0e-12:
        n = n / n_len
    else:
        n = ng
    if wp.dot(n, ray_dir) > 0.0:
        n = -n
    h.normal = n

    uv = interpolate_uv(scene, tri, bu, bv)
    h.uv = uv

    mid = scene.triangle_material[tri]
    m = scene.materials[mid]
    h.material = mid
    h.flags = m.flags

    diffuse = m.diffuse
    if m.diffuse_tex >= 0:
        d = sample_texture(scene, m.diffuse_tex, uv)
        diffuse = wp.vec3(d[0], d[1], d[2])
    emission = m.emissive
    if m.emissive_tex >= 0:
        e = sample_texture(scene, m.emissive_tex, uv)
        emission = wp.vec3(e[0], e[1], e[2])
    roughness = m.roughness
    if m.roughness_tex >= 0:
        roughness = _channel(sample_texture(scene, m.roughness_tex, uv), m.roughness_channel)
    metallic = m.metallic
    if m.metallic_tex >= 0:
        metallic = _channel(sample_texture(scene, m.metallic_tex, uv), m.metallic_channel)
    opacity = m.opacity
    if m.opacity_tex >= 0:
        opacity = _channel(sample_texture(scene, m.opacity_tex, uv), m.opacity_channel)

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
