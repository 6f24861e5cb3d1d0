"""The dome light's lat-long convention, in one place, for host code and kernels.

Convention (UsdLux DomeLight, which adopts the OpenEXR latitude-longitude map; see the
DomeLight doc in pxr's ``usdLux/schema.usda``), in the dome's local frame:

* +Y is up: the top row of the image is latitude +pi/2 (+Y), the bottom row -pi/2.
* Longitude ``lon = atan2(x, z)``: the image centre (u = 0.5) faces **+Z**, u = 0.25
  faces +X, u = 0.75 faces -X, and the left/right edges (u = 0, 1) face -Z.  (The
  OpenEXR text: the first pixel column has longitude +pi, the last -pi; latitude 0,
  longitude 0 is +Z; longitude +pi/2 is +X.)
* UVs follow the USD texture convention, (0, 0) = bottom-left of the image:
  ``u = 0.5 - lon / (2 pi)``, ``v = 0.5 + lat / pi`` with ``lat = asin(y)``.

A world direction is first rotated into the dome's frame by
``EnvironmentGPU.world_to_light`` (the loader folds the dome's transform, and any
up-axis change, into it).  The radiance is ``color * (texel * scale + bias)`` of the
bound texture (UsdUVTexture semantics), or ``color`` without a texture.  Texels are
fetched bilinearly, wrapping in u (across the -Z seam) and clamping in v (at the poles).

The module also projects a lat-long image onto 9 spherical-harmonic coefficients of
irradiance (Ramamoorthi & Hanrahan 2001) for the raster ambient term.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ...core.constants import PI, TWO_PI
from ...core.native_rows import LAMBDA_HEADER_CPP, float_literal
from ...core.scene_gpu import EnvironmentGPU, SceneGPU, TextureGPU

# Real SH basis constants, bands 0..2 (order: 00, 1-1, 10, 11, 2-2, 2-1, 20, 21, 22).
SH_C0 = 0.282095
SH_C1 = 0.488603
SH_C2 = 1.092548
SH_C20 = 0.315392
SH_C22 = 0.546274
# Cosine-lobe convolution factors A_l (Ramamoorthi & Hanrahan): pi, 2pi/3, pi/4.
SH_BAND_FACTOR = np.array([math.pi] + [2.0 * math.pi / 3.0] * 3 + [math.pi / 4.0] * 5)


def environment_uv(dirs: np.ndarray) -> np.ndarray:
    """Dome-local directions (..., 3) (any length > 0) -> lat-long UVs (..., 2) in [0, 1).

    USD texture convention: v = 1 is the top row (+Y); u = 0.5 faces +Z."""
    d = np.asarray(dirs, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    lon = np.arctan2(d[..., 0], d[..., 2])
    lat = np.arcsin(np.clip(d[..., 1], -1.0, 1.0))
    u = np.mod(0.5 - lon / (2.0 * np.pi), 1.0)
    v = 0.5 + lat / np.pi
    return np.stack([u, v], axis=-1)


def environment_direction(uv: np.ndarray) -> np.ndarray:
    """Inverse of ``environment_uv``: lat-long UVs (..., 2) -> unit dome-local directions (..., 3)."""
    uv = np.asarray(uv, dtype=np.float64)
    lon = np.pi * (1.0 - 2.0 * uv[..., 0])
    lat = np.pi * (uv[..., 1] - 0.5)
    c = np.cos(lat)
    return np.stack([c * np.sin(lon), np.sin(lat), c * np.cos(lon)], axis=-1)


def texel_directions(height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit dome-local directions (H, W, 3) of the texel centres of a lat-long image
    (row 0 = top) and each texel's exact solid angle (H, W) (they sum to 4 pi):
    ``(2 pi / W) (sin(lat_top) - sin(lat_bottom))``."""
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    dirs = environment_direction(np.stack([uu, vv], axis=-1))
    edges = np.sin(np.pi * (0.5 - np.arange(height + 1) / height))
    band = (edges[:-1] - edges[1:]) * (2.0 * np.pi / width)
    return dirs, np.repeat(band[:, None], width, axis=1)


def sh_basis(dirs: np.ndarray) -> np.ndarray:
    """The 9 real SH basis functions (bands 0-2) at unit directions (..., 3) -> (..., 9)."""
    x, y, z = dirs[..., 0], dirs[..., 1], dirs[..., 2]
    return np.stack(
        [
            np.full_like(x, SH_C0),
            SH_C1 * y,
            SH_C1 * z,
            SH_C1 * x,
            SH_C2 * x * y,
            SH_C2 * y * z,
            SH_C20 * (3.0 * z * z - 1.0),
            SH_C2 * x * z,
            SH_C22 * (x * x - y * y),
        ],
        axis=-1,
    )


def sh_irradiance_coefficients(radiance: np.ndarray) -> np.ndarray:
    """Irradiance SH coefficients (9, 3) of a lat-long radiance image (H, W, >=3), row 0
    = top, in the dome-local frame: ``E(n) = sum_k coef[k] * Y_k(n)`` (W/m^2).

    The radiance is projected with exact texel solid angles (a constant image gives
    exactly ``E = pi L`` in band 0; higher bands pick up a quadrature error of order
    (pi / H)^2 / 12), then each band is scaled by the cosine-lobe factor A_l, so a
    constant radiance L gives ``E = pi L`` everywhere."""
    img = np.asarray(radiance, dtype=np.float64)[..., :3]
    dirs, weight = texel_directions(img.shape[0], img.shape[1])
    basis = sh_basis(dirs) * weight[..., None]
    coeffs = np.einsum("hwk,hwc->kc", basis, img)
    return (coeffs * SH_BAND_FACTOR[:, None]).astype(np.float32)


def sh_constant_coefficients(color: tuple[float, float, float] | np.ndarray) -> np.ndarray:
    """Irradiance SH coefficients (9, 3) of a constant radiance ``color``: E = pi * color."""
    coeffs = np.zeros((9, 3), dtype=np.float64)
    coeffs[0] = np.asarray(color, dtype=np.float64) * (math.pi / SH_C0)
    return coeffs.astype(np.float32)


#: C++ lambdas (no header: ``ENVIRONMENT_CPP`` adds it; ``lighting/native_math`` pastes
#: them among its own pieces): the dome's lookups, the only implementation of each
#: (the functions below wrap them).  One Warp operation a call (``wp::mul``, ``wp::add``,
#: ...), in the order of the arithmetic they stand for, so the compiler fuses nothing a
#: module's own flags do not ask for.  ``wh_latlong_bilinear`` takes any texel type
#: (vec4 dome texels, vec3 mip levels); the others take the scene's ``environment``
#: record, its ``textures`` and its ``texels``.
ENVIRONMENT_LAMBDAS_CPP = f"""
// atan2(y, x) in float32 to about 2 ulp with one division and no libm call (libm's atan2f
// costs ~20 ns): Cephes' atanf on the octant ratio t = lo / hi, reduced to |t| <= tan(pi/8)
// by (lo - hi) / (lo + hi) + pi/4, then a degree-9 odd polynomial; IEEE signs for zeros
// (atan2(+-0, -0) = +-pi).  Branch-free.
auto wh_fast_atan2 = [&](const float y, const float x) WH_INLINE -> float {{
    const float ax = wp::abs(x);
    const float ay = wp::abs(y);
    const bool steep = ay > ax;
    const float hi = steep ? ay : ax;
    const float lo = steep ? ax : ay;
    const bool reduce = lo > wp::mul({float_literal(0.41421356237)}, hi);
    const float t = wp::div(reduce ? wp::sub(lo, hi) : lo, reduce ? wp::add(lo, hi) : hi);
    const float z = wp::mul(t, t);
    float r = wp::sub(wp::mul({float_literal(8.05374449538e-2)}, z), {float_literal(1.38776856032e-1)});
    r = wp::sub(wp::mul(wp::add(wp::mul(r, z), {float_literal(1.99777106478e-1)}), z), {float_literal(3.33329491539e-1)});
    r = wp::add(wp::mul(wp::mul(r, z), t), t);
    r = reduce ? wp::add(r, {float_literal(0.785398163397)}) : r;
    r = hi > 0.0f ? r : 0.0f;
    r = steep ? wp::sub({float_literal(1.57079632679)}, r) : r;
    r = wp::copysign(1.0f, x) < 0.0f ? wp::sub({float_literal(3.14159265359)}, r) : r;
    return wp::copysign(r, y);
}};
// A dome-local direction (any non-zero length) -> lat-long uv (the module docstring):
// lon = atan2(x, z), lat = atan2(y, sqrt(x^2 + z^2)) (= asin of the unit vector's y).
auto wh_environment_uv = [&](const wp::vec3& d) WH_INLINE -> wp::vec2 {{
    const float lon = wh_fast_atan2(d[0], d[2]);
    const float lat = wh_fast_atan2(d[1], wp::sqrt(wp::add(wp::mul(d[0], d[0]), wp::mul(d[2], d[2]))));
    const float u = wp::sub(0.5f, wp::div(lon, {float_literal(TWO_PI)}));
    return wp::vec2(u >= 1.0f ? wp::sub(u, 1.0f) : u, wp::add(0.5f, wp::div(lat, {float_literal(PI)})));
}};
// The bilinear footprint of lat-long uv in a width x height image stored row-major from its
// top row at element offset (wrapping in u, clamping in v; USD uv, v = 1 at the top): the
// four texels' element indices (i00, i01 in the upper row, i10, i11 in the lower) and the
// blend's weights fx, fy (``wh_bilinear_blend``).
auto wh_latlong_footprint = [&](const int offset, const int width, const int height, const wp::vec2& uv, int& i00,
                                int& i01, int& i10, int& i11, float& fx, float& fy) WH_INLINE {{
    const float x = wp::sub(wp::mul(uv[0], (float)width), 0.5f);
    const float y = wp::sub(wp::mul(wp::sub(1.0f, uv[1]), (float)height), 0.5f);
    const float x0f = wp::floor(x);
    const float y0f = wp::floor(y);
    fx = wp::sub(x, x0f);
    fy = wp::sub(y, y0f);
    int x0 = (int)x0f;
    x0 = x0 < 0 ? x0 + width : (x0 >= width ? x0 - width : x0);
    const int x1 = x0 + 1 >= width ? 0 : x0 + 1;
    const int y0 = wp::clamp((int)y0f, 0, height - 1);
    const int y1 = wp::min((int)y0f + 1, height - 1);
    const int r0 = offset + y0 * width;
    const int r1 = offset + wp::max(y1, 0) * width;
    i00 = r0 + x0;
    i01 = r0 + x1;
    i10 = r1 + x0;
    i11 = r1 + x1;
}};
// The bilinear blend of a footprint's four texels (any type) by its weights.
auto wh_bilinear_blend = [&](const auto& t00, const auto& t01, const auto& t10, const auto& t11, const float fx,
                       const float fy) WH_INLINE {{
    return wh_lerp(wh_lerp(t00, t01, fx), wh_lerp(t10, t11, fx), fy);
}};
// Bilinear fetch from a lat-long image stored row-major from its top row at texels[offset:].
auto wh_latlong_bilinear = [&](const auto* texels, const int offset, const int width, const int height,
                               const wp::vec2& uv) WH_INLINE {{
    int i00, i01, i10, i11;
    float fx, fy;
    wh_latlong_footprint(offset, width, height, uv, i00, i01, i10, i11, fx, fy);
    return wh_bilinear_blend(texels[i00], texels[i01], texels[i10], texels[i11], fx, fy);
}};
// The dome's radiance given its texture ``tex``'s bilinear value (its first three channels):
// color * (texel * scale + bias).
auto wh_dome_scaled = [&](const auto& env, const auto& tex, const wp::vec3& texel) WH_INLINE -> wp::vec3 {{
    const wp::vec3 scale(tex.scale[0], tex.scale[1], tex.scale[2]);
    const wp::vec3 bias(tex.bias[0], tex.bias[1], tex.bias[2]);
    return wp::cw_mul(env.color, wp::add(wp::cw_mul(texel, scale), bias));
}};
// The dome's radiance off its texture at lat-long uv (the dome must have one).
auto wh_dome_texture_radiance = [&](const auto& env, const auto& textures, const auto& texels, const wp::vec2& uv)
    WH_INLINE -> wp::vec3 {{
    const auto& tex = textures.data[env.texture];
    const wp::vec4 t = wh_latlong_bilinear(texels.data, tex.offset, tex.width, tex.height, uv);
    return wh_dome_scaled(env, tex, wp::vec3(t[0], t[1], t[2]));
}};
// The dome's radiance at lat-long uv (black without a dome, its colour without a texture).
auto wh_environment_radiance_at = [&](const auto& env, const auto& textures, const auto& texels, const wp::vec2& uv)
    WH_INLINE -> wp::vec3 {{
    if (env.enabled == 0) return wp::vec3(0.0f);
    if (env.texture < 0) return env.color;
    return wh_dome_texture_radiance(env, textures, texels, uv);
}};
// The radiance arriving from world direction dir (any non-zero length) off the dome.
auto wh_environment_radiance = [&](const auto& env, const auto& textures, const auto& texels, const wp::vec3& dir)
    WH_INLINE -> wp::vec3 {{
    if (env.enabled == 0) return wp::vec3(0.0f);
    if (env.texture < 0) return env.color;
    return wh_dome_texture_radiance(env, textures, texels, wh_environment_uv(wp::mul(env.world_to_light, dir)));
}};
"""

#: The lambdas with their header, for the functions below.
ENVIRONMENT_CPP = LAMBDA_HEADER_CPP + ENVIRONMENT_LAMBDAS_CPP


def texel_gather_cpp(
    footprint: str, lanes: str, wanted: str, dome: str, mips: str = "nullptr", on_dome: str = "true"
) -> str:
    """C++ (a block): for lanes ``0 <= j < lanes`` where ``wanted`` (a condition on ``j``),
    the bilinear value of footprint ``footprint`` (the lane arrays ``{footprint}00`` ..
    ``{footprint}11``, ``{footprint}x``, ``{footprint}y`` that ``wh_latlong_footprint``
    fills) into ``{footprint}c[k][j]``, its three channels (zero where not wanted): each of
    the four texels' first three channels blended as ``wh_bilinear_blend`` blends them
    (``wh_lerp_contracted``: the same bits under the module's contraction), from
    ``dome`` (a ``const float*`` over vec4 texels) where ``on_dome`` (a condition on ``j``),
    else from ``mips`` (over vec3 texels, one spare texel after the last).  On the CPU lane
    by lane, each texel one 16-byte load and its channels blended at once
    (``wh_bilinear4``: a gather across lanes, three a texel, took a cycle or more a float);
    on CUDA, where a chunk is one lane, each load a conditional read of a flat float array,
    a block whose wanted lanes all read one source reading that one alone."""
    f = footprint
    return f"""
    {{
        const float* dome_floats = {dome};
        const float* mip_floats = {mips};
#if defined(__CUDA_ARCH__)
        int dome_lanes = 0, mip_lanes = 0;
        for (int j = 0; j < {lanes}; ++j) {{
            const bool wanted = {wanted};
            const bool on_dome = {on_dome};
            dome_lanes += wanted && on_dome ? 1 : 0;
            mip_lanes += wanted && !on_dome ? 1 : 0;
        }}
        auto gather = [&](const bool dome_source, const bool mip_source) WH_INLINE {{
            for (int j = 0; j < {lanes}; ++j) {{
                const bool wanted = {wanted};
                const bool on_dome = {on_dome};
                const bool from_dome = dome_source && wanted && on_dome;
                const bool from_mips = mip_source && wanted && !on_dome;
                const int t00 = {f}00[j], t01 = {f}01[j], t10 = {f}10[j], t11 = {f}11[j];
                const float fx = {f}x[j], fy = {f}y[j];
                for (int k = 0; k < 3; ++k) {{
                    const float a00 = from_dome ? dome_floats[4 * t00 + k] : (from_mips ? mip_floats[3 * t00 + k] : 0.0f);
                    const float a01 = from_dome ? dome_floats[4 * t01 + k] : (from_mips ? mip_floats[3 * t01 + k] : 0.0f);
                    const float a10 = from_dome ? dome_floats[4 * t10 + k] : (from_mips ? mip_floats[3 * t10 + k] : 0.0f);
                    const float a11 = from_dome ? dome_floats[4 * t11 + k] : (from_mips ? mip_floats[3 * t11 + k] : 0.0f);
                    const float value = wh_lerp_contracted(wh_lerp_contracted(a00, a01, fx), wh_lerp_contracted(a10, a11, fx), fy);
                    {f}c[k][j] = wanted ? value : 0.0f;
                }}
            }}
        }};
        if (dome_lanes == 0 && mip_lanes == 0) {{
            for (int j = 0; j < {lanes}; ++j) {f}c[0][j] = {f}c[1][j] = {f}c[2][j] = 0.0f;
        }}
        else if (mip_lanes == 0) gather(true, false);
        else if (dome_lanes == 0) gather(false, true);
        else gather(true, true);
#else
        #pragma clang loop vectorize(disable)
        for (int j = 0; j < {lanes}; ++j) {{
            if (!({wanted})) {{
                {f}c[0][j] = {f}c[1][j] = {f}c[2][j] = 0.0f;
                continue;
            }}
            const bool on_dome = {on_dome};
            const wh_float4 value = wh_bilinear4(on_dome ? dome_floats : mip_floats, on_dome ? 4 : 3, {f}00[j],
                                                 {f}01[j], {f}10[j], {f}11[j], {f}x[j], {f}y[j]);
            {f}c[0][j] = value[0]; {f}c[1][j] = value[1]; {f}c[2][j] = value[2];
        }}
#endif
    }}"""


def dome_along_lanes_cpp(size: str, lanes: str, direction: str, wanted: str, store: str) -> str:
    """C++ (a block, after ``ENVIRONMENT_LAMBDAS_CPP``, given ``scene`` and its dome ``env``,
    which must have a texture): the dome's radiance along each lane's direction, lanes
    ``0 <= j < lanes`` (at most ``size``, a C++ constant): ``direction`` (a C++ expression of
    lane ``j``'s world direction, any length) to its lat-long uv and bilinear footprint
    across the lanes, a loop of plain arithmetic the compiler vectorises; then, where
    ``wanted`` (a condition on ``j``), the texel loads and their blend (``texel_gather_cpp``),
    and lane by lane the dome's scale into ``c`` and ``store`` (a statement
    given ``c`` and ``j``).  The arithmetic of ``wh_dome_texture_radiance``, so the same
    bits."""
    return f"""
    {{
        const auto& tex = scene.textures.data[env.texture];
        const wp::mat33 to_dome = env.world_to_light;
        float gx[{size}], gy[{size}], gc[3][{size}];
        int g00[{size}], g01[{size}], g10[{size}], g11[{size}];
        for (int j = 0; j < {lanes}; ++j) {{
            const wp::vec3 d = wp::mul(to_dome, {direction});
            wh_latlong_footprint(tex.offset, tex.width, tex.height, wh_environment_uv(d), g00[j], g01[j], g10[j],
                                 g11[j], gx[j], gy[j]);
        }}{texel_gather_cpp("g", lanes, wanted, "(const float*)scene.texels.data")}
        for (int j = 0; j < {lanes}; ++j) {{
            if (!({wanted})) continue;
            const wp::vec3 c = wh_dome_scaled(env, tex, wp::vec3(gc[0][j], gc[1][j], gc[2][j]));
            {store}
        }}
    }}"""


@wp.func_native(ENVIRONMENT_CPP + "return wh_fast_atan2(y, x);")
def fast_atan2(y: float, x: float) -> float:
    """atan2(y, x) in float32 to about 2 ulp, with one division and no libm call
    (``wh_fast_atan2``)."""
    ...


@wp.func_native(ENVIRONMENT_CPP + "return wh_environment_uv(d);")
def environment_uv_wp(d: wp.vec3) -> wp.vec2:
    """Dome-local direction (any non-zero length) -> lat-long UV (USD convention; see
    the module doc): ``lon = atan2(x, z)``, ``lat = atan2(y, sqrt(x^2 + z^2))`` (= asin
    of the unit vector's y, without normalising)."""
    ...


@wp.func_native(ENVIRONMENT_CPP + "return wh_environment_radiance(env, textures, texels, dir_world);")
def _environment_radiance(
    env: EnvironmentGPU, textures: wp.array(dtype=TextureGPU), texels: wp.array(dtype=wp.vec4), dir_world: wp.vec3
) -> wp.vec3:
    """``environment_radiance`` given the scene's dome, textures and texels."""
    ...


@wp.func(inline=True)
def environment_radiance(scene: SceneGPU, dir_world: wp.vec3) -> wp.vec3:
    """Radiance arriving from world direction ``dir_world`` (any non-zero length) off
    the dome (black without a dome light): ``color * (texel * scale + bias)`` of its
    texture, bilinear in the lat-long image, or ``color`` without one."""
    return _environment_radiance(scene.environment, scene.textures, scene.texels, dir_world)
