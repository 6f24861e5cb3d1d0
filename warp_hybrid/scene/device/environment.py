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
from typing import Any

import numpy as np
import warp as wp

from ...core.constants import PI, TWO_PI
from ...core.scene_gpu import SceneGPU

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


@wp.func(inline=True)
def fast_atan2(y: float, x: float) -> float:
    """atan2(y, x) in float32 to about 2 ulp, with one division and no libm call (libm's
    atan2f costs ~20 ns on the CPU).  Cephes' atanf on the octant ratio: t = lo / hi,
    reduced to |t| <= tan(pi/8) by (lo - hi) / (lo + hi) + pi/4, then a degree-9 odd
    polynomial; IEEE signs for zeros (atan2(+-0, -0) = +-pi)."""
    ax = wp.abs(x)
    ay = wp.abs(y)
    steep = ay > ax
    hi = wp.where(steep, ay, ax)
    lo = wp.where(steep, ax, ay)
    reduce = lo > 0.41421356237 * hi
    t = wp.where(reduce, lo - hi, lo) / wp.where(reduce, lo + hi, hi)
    z = t * t
    r = (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z - 3.33329491539e-1) * z * t + t
    r = wp.where(reduce, r + 0.785398163397, r)
    r = wp.where(hi > 0.0, r, 0.0)
    r = wp.where(steep, 1.57079632679 - r, r)
    r = wp.where(wp.copysign(1.0, x) < 0.0, 3.14159265359 - r, r)
    return wp.copysign(r, y)


@wp.func(inline=True)
def environment_uv_wp(d: wp.vec3) -> wp.vec2:
    """Dome-local direction (any non-zero length) -> lat-long UV (USD convention; see
    the module doc): ``lon = atan2(x, z)``, ``lat = atan2(y, sqrt(x^2 + z^2))`` (= asin
    of the unit vector's y, without normalising)."""
    lon = fast_atan2(d[0], d[2])
    lat = fast_atan2(d[1], wp.sqrt(d[0] * d[0] + d[2] * d[2]))
    u = 0.5 - lon / TWO_PI
    if u >= 1.0:
        u = u - 1.0
    return wp.vec2(u, 0.5 + lat / PI)


@wp.func(inline=True)
def latlong_bilinear(texels: wp.array(dtype=Any), offset: int, width: int, height: int, uv: wp.vec2):
    """Bilinear fetch from a lat-long image stored row-major from its top row at
    ``texels[offset:]`` (any texel type: vec4 dome texels, vec3 mip levels): wraps in
    u, clamps in v (USD uv in [0, 1], v = 1 at the top)."""
    x = uv[0] * float(width) - 0.5
    y = (1.0 - uv[1]) * float(height) - 0.5
    x0f = wp.floor(x)
    y0f = wp.floor(y)
    fx = x - x0f
    fy = y - y0f
    x0 = int(x0f)
    if x0 < 0:
        x0 += width
    elif x0 >= width:
        x0 -= width
    x1 = x0 + 1
    if x1 >= width:
        x1 = 0
    y0 = wp.clamp(int(y0f), 0, height - 1)
    y1 = wp.min(int(y0f) + 1, height - 1)
    r0 = offset + y0 * width
    r1 = offset + wp.max(y1, 0) * width
    top = texels[r0 + x0] * (1.0 - fx) + texels[r0 + x1] * fx
    bottom = texels[r1 + x0] * (1.0 - fx) + texels[r1 + x1] * fx
    return top * (1.0 - fy) + bottom * fy


@wp.func(inline=True)
def dome_texture_radiance(scene: SceneGPU, uv: wp.vec2) -> wp.vec3:
    """``color * (texel * scale + bias)`` of the dome's texture at lat-long ``uv`` (the
    dome must have a texture)."""
    tex = scene.textures[scene.environment.texture]
    t = wp.cw_mul(latlong_bilinear(scene.texels, tex.offset, tex.width, tex.height, uv), tex.scale) + tex.bias
    return wp.cw_mul(scene.environment.color, wp.vec3(t[0], t[1], t[2]))


@wp.func(inline=True)
def environment_radiance(scene: SceneGPU, dir_world: wp.vec3) -> wp.vec3:
    """Radiance arriving from world direction ``dir_world`` (any non-zero length) off
    the dome (black without a dome light)."""
    if scene.environment.enabled == 0:
        return wp.vec3(0.0, 0.0, 0.0)
    if scene.environment.texture < 0:
        return scene.environment.color
    return dome_texture_radiance(scene, environment_uv_wp(scene.environment.world_to_light * dir_world))
