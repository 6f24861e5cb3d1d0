"""Ambient light from the dome for raster shading: SH irradiance + prefiltered mips.

Built once per scene on the host (numpy/OpenCV) and shared by the deferred lighting
and the tracer (``EnvironmentLighting.for_scene``):

* Diffuse: the dome's irradiance as 9 spherical-harmonic coefficients (Ramamoorthi &
  Hanrahan 2001), ``E(n)``; a Lambertian surface gets ``kd / pi * E(n)``.  A constant
  dome of radiance L gives ``E = pi L``, hence ``kd * L``.
* Specular (glossy reflection of the dome): a mip chain of the lat-long radiance
  (area-filtered halvings down to 8 texels wide).  The GGX lobe of roughness r
  (alpha = r^2) reads level ``log2(alpha * W0 / 2 pi)`` (the level whose texel angle
  matches alpha), trilinearly; level 0 is the sharp texture itself; past the last
  level it blends into ``E(R) / pi`` (a cosine-wide lobe).  The result is weighted by
  the split-sum environment BRDF ``f0 A + f90 B`` (Karis 2013): the directional albedo
  of exactly our GGX lobe, tabulated once over (roughness, n.v) by importance sampling
  (``specular_albedo_table``).  The diffuse ambient is weighted by ``1 - F(n.v)``,
  the diffuse lobe's own directional albedo.
* No occlusion: the dome reaches every point (shadowing it needs rays).
"""

from __future__ import annotations

import functools
import math
import weakref

import cv2
import numpy as np
import warp as wp

from ..scene.device import DeviceScene, SceneGPU
from ..scene.environment import (
    SH_C0,
    SH_C1,
    SH_C2,
    SH_C20,
    SH_C22,
    dome_texture_radiance,
    environment_radiance,
    environment_uv_wp,
    latlong_bilinear,
    sh_constant_coefficients,
    sh_irradiance_coefficients,
)
from .brdf import ALPHA_MIN, INV_PI, diffuse_view_weight, fresnel_f90, roughness_to_alpha

MIN_MIP_WIDTH = 8
LUT_SIZE = 32
LUT_SAMPLES = 512
TWO_PI = wp.constant(2.0 * math.pi)


@wp.struct
class AmbientGPU:
    """Device data for the ambient term (see the module docstring).

    ``sh``: 9 irradiance coefficients (dome-local frame).  ``mip_*``: levels 1..levels
    of the radiance mip chain (colour, scale and bias applied), flat vec3 texels from
    the top row; ``base_width`` is the width of level 0 (the dome texture).
    ``brdf_lut``: (roughness, n.v) -> (A, B) of ``specular_albedo_table``.
    ``sh_bands``: 1 when only the constant band is non-zero (a constant dome; the
    others are then skipped, which changes no bit of the sum), else 3."""

    enabled: int
    brdf_lut: wp.array2d(dtype=wp.vec2)
    sh: wp.array(dtype=wp.vec3)
    sh_bands: int
    mip_texels: wp.array(dtype=wp.vec3)
    mip_offset: wp.array(dtype=wp.int32)
    mip_width: wp.array(dtype=wp.int32)
    mip_height: wp.array(dtype=wp.int32)
    levels: int
    base_width: int


def _radical_inverse2(i: np.ndarray) -> np.ndarray:
    """Van der Corput sequence in base 2 (the second Hammersley coordinate)."""
    b = i.astype(np.uint64) & 0xFFFFFFFF
    b = ((b << 16) | (b >> 16)) & 0xFFFFFFFF
    b = ((b & 0x55555555) << 1) | ((b & 0xAAAAAAAA) >> 1)
    b = ((b & 0x33333333) << 2) | ((b & 0xCCCCCCCC) >> 2)
    b = ((b & 0x0F0F0F0F) << 4) | ((b & 0xF0F0F0F0) >> 4)
    b = ((b & 0x00FF00FF) << 8) | ((b & 0xFF00FF00) >> 8)
    return b.astype(np.float64) / 2.0**32


@functools.lru_cache(maxsize=1)
def specular_albedo_table(size: int = LUT_SIZE, samples: int = LUT_SAMPLES) -> np.ndarray:
    """(size, size, 2) float32 split-sum table: entry [i, j] = (A, B) with
    ``A + B`` the directional albedo of the GGX lobe (``brdf.brdf_specular`` with F = 1)
    at roughness ``i / (size - 1)`` and ``n.v = (j + 0.5) / size``, split so that the
    Schlick-weighted albedo is ``f0 A + f90 B``.  Hammersley importance sampling of
    D(h) (n.h), ``samples`` directions per entry (deterministic)."""
    k = np.arange(samples)
    u1 = (k + 0.5) / samples
    phi = 2.0 * np.pi * _radical_inverse2(k)
    table = np.zeros((size, size, 2), dtype=np.float64)
    for i in range(size):
        r = i / (size - 1)
        a2 = max(r * r, ALPHA_MIN) ** 2
        cos_h = np.sqrt((1.0 - u1) / (1.0 + (a2 - 1.0) * u1))
        sin_h = np.sqrt(1.0 - cos_h**2)
        h = np.stack([sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h], axis=-1)
        for j in range(size):
            nv = (j + 0.5) / size
            v = np.array([math.sqrt(1.0 - nv * nv), 0.0, nv])
            vh = h @ v
            nl = 2.0 * vh * cos_h - nv
            nl_pos = np.maximum(nl, 1.0e-12)
            vis = 0.5 / (nl_pos * math.sqrt(nv * nv * (1.0 - a2) + a2) + nv * np.sqrt(nl_pos**2 * (1.0 - a2) + a2))
            weight = np.where(nl > 0.0, 4.0 * vis * nl_pos * vh / cos_h, 0.0)
            w5 = (1.0 - np.clip(vh, 0.0, 1.0)) ** 5
            table[i, j] = (np.mean(weight * (1.0 - w5)), np.mean(weight * w5))
    return table.astype(np.float32)


def dome_radiance_image(dscene: DeviceScene) -> np.ndarray | None:
    """The dome's lat-long radiance (H, W, 3) float32 on the host (colour, scale and bias
    applied), or None when the scene has no textured dome."""
    env = dscene.scene.environment
    if env is None or env.texture < 0:
        return None
    binding = dscene.scene.textures[env.texture]
    pixels = np.asarray(dscene.scene.images[binding.image].pixels, dtype=np.float32)
    rgba = pixels * np.asarray(binding.scale, np.float32) + np.asarray(binding.bias, np.float32)
    return rgba[..., :3] * np.asarray(env.color, dtype=np.float32)


def radiance_mips(image: np.ndarray, min_width: int = MIN_MIP_WIDTH) -> list[np.ndarray]:
    """Levels 1.. of an area-filtered mip chain of a lat-long image (each half the
    previous, rounded down), while the level is at least ``min_width`` wide."""
    levels = []
    level = np.ascontiguousarray(image, dtype=np.float32)
    while level.shape[1] // 2 >= min_width and level.shape[0] >= 2:
        w, h = level.shape[1] // 2, max(1, level.shape[0] // 2)
        level = cv2.resize(level, (w, h), interpolation=cv2.INTER_AREA)
        levels.append(level)
    return levels


class EnvironmentLighting:
    """Host-built ambient data for one ``DeviceScene``'s dome; ``.gpu`` goes to kernels."""

    _cache: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    def __init__(self, dscene: DeviceScene) -> None:
        """Project the dome onto SH and build its mip chain on ``dscene.device``."""
        env = dscene.scene.environment
        self.source = self._source(dscene)
        image = dome_radiance_image(dscene)
        mips: list[np.ndarray] = []
        if env is None:
            sh = np.zeros((9, 3), dtype=np.float32)
        elif image is None:
            sh = sh_constant_coefficients(env.color)
        else:
            sh = sh_irradiance_coefficients(image)
            mips = radiance_mips(image)
        dev = dscene.device
        g = AmbientGPU()
        g.enabled = 1 if env is not None else 0
        g.brdf_lut = wp.array(specular_albedo_table(), dtype=wp.vec2, device=dev)
        g.sh = wp.array(sh, dtype=wp.vec3, device=dev)
        g.sh_bands = 1 if not np.any(sh[1:]) else 3
        offsets = np.cumsum([0] + [m.shape[0] * m.shape[1] for m in mips])
        flat = np.concatenate([m.reshape(-1, 3) for m in mips]) if mips else np.zeros((1, 3), np.float32)
        g.mip_texels = wp.array(np.ascontiguousarray(flat, dtype=np.float32), dtype=wp.vec3, device=dev)
        g.mip_offset = wp.array(np.asarray(offsets[:-1] if mips else [0], np.int32), dtype=wp.int32, device=dev)
        g.mip_width = wp.array(np.asarray([m.shape[1] for m in mips] or [1], np.int32), dtype=wp.int32, device=dev)
        g.mip_height = wp.array(np.asarray([m.shape[0] for m in mips] or [1], np.int32), dtype=wp.int32, device=dev)
        g.levels = len(mips)
        g.base_width = int(image.shape[1]) if image is not None else 1
        self.gpu = g

    @staticmethod
    def _source(dscene: DeviceScene) -> tuple:
        """What the ambient data is derived from: the dome's colour, texture binding and
        the image object itself (held, so compared by identity)."""
        env = dscene.scene.environment
        if env is None:
            return (None,)
        if env.texture < 0:
            return (tuple(env.color), -1)
        binding = dscene.scene.textures[env.texture]
        pixels = dscene.scene.images[binding.image].pixels
        return (tuple(env.color), env.texture, tuple(binding.scale), tuple(binding.bias), pixels)

    def matches(self, dscene: DeviceScene) -> bool:
        """True when ``dscene``'s dome is still the one this data was built from."""
        now = self._source(dscene)
        return len(now) == len(self.source) and all(
            a is b if isinstance(a, np.ndarray) or isinstance(b, np.ndarray) else a == b
            for a, b in zip(now, self.source)
        )

    @classmethod
    def for_scene(cls, dscene: DeviceScene) -> EnvironmentLighting:
        """The ambient data of ``dscene``, cached per ``DeviceScene`` (weakly) so the
        deferred lighting and the tracer share it; rebuilt only when the dome changes."""
        cached = cls._cache.get(dscene)
        if cached is None or not cached.matches(dscene):
            cached = cls(dscene)
            cls._cache[dscene] = cached
        return cached


@wp.func(inline=True)
def sh_irradiance(amb: AmbientGPU, d: wp.vec3) -> wp.vec3:
    """Irradiance E(d) from the SH coefficients at a unit dome-local direction."""
    if amb.sh_bands == 1:
        c = amb.sh[0] * SH_C0
        return wp.vec3(wp.max(c[0], 0.0), wp.max(c[1], 0.0), wp.max(c[2], 0.0))
    x = d[0]
    y = d[1]
    z = d[2]
    e = amb.sh[0] * SH_C0
    e += amb.sh[1] * (SH_C1 * y) + amb.sh[2] * (SH_C1 * z) + amb.sh[3] * (SH_C1 * x)
    e += amb.sh[4] * (SH_C2 * x * y) + amb.sh[5] * (SH_C2 * y * z)
    e += amb.sh[6] * (SH_C20 * (3.0 * z * z - 1.0)) + amb.sh[7] * (SH_C2 * x * z)
    e += amb.sh[8] * (SH_C22 * (x * x - y * y))
    return wp.vec3(wp.max(e[0], 0.0), wp.max(e[1], 0.0), wp.max(e[2], 0.0))


@wp.func(inline=True)
def dome_irradiance(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """Irradiance from the dome on a surface with world normal ``n`` (no occlusion)."""
    if amb.enabled == 0:
        return wp.vec3(0.0, 0.0, 0.0)
    if amb.sh_bands == 1:
        return sh_irradiance(amb, n)  # direction-free
    return sh_irradiance(amb, wp.normalize(scene.environment.world_to_light * n))


@wp.func(inline=True)
def _mip_fetch(amb: AmbientGPU, level: int, uv: wp.vec2) -> wp.vec3:
    """Bilinear fetch from mip ``level`` (1-based) at lat-long ``uv`` (wrap u, clamp v)."""
    k = level - 1
    return latlong_bilinear(amb.mip_texels, amb.mip_offset[k], amb.mip_width[k], amb.mip_height[k], uv)


@wp.func(inline=True)
def _level_radiance(scene: SceneGPU, amb: AmbientGPU, level: int, uv: wp.vec2) -> wp.vec3:
    """Radiance at integer mip ``level`` (0 = the sharp dome texture)."""
    if level == 0:
        return dome_texture_radiance(scene, uv)
    return _mip_fetch(amb, level, uv)


@wp.func(inline=True)
def prefiltered_radiance(scene: SceneGPU, amb: AmbientGPU, dir_world: wp.vec3, roughness: float) -> wp.vec3:
    """Dome radiance around ``dir_world`` blurred to the width of a GGX lobe of this
    roughness (see the module docstring)."""
    if amb.enabled == 0:
        return wp.vec3(0.0, 0.0, 0.0)
    if amb.levels == 0:
        return environment_radiance(scene, dir_world)
    alpha = roughness_to_alpha(roughness)
    width = alpha * float(amb.base_width) / TWO_PI
    lod = float(0.0)
    if width > 1.0:
        lod = wp.log2(width)
    d = scene.environment.world_to_light * dir_world
    uv = environment_uv_wp(d)
    top = float(amb.levels)
    if lod >= top:
        t = wp.min(lod - top, 1.0)
        return _mip_fetch(amb, amb.levels, uv) * (1.0 - t) + sh_irradiance(amb, wp.normalize(d)) * (INV_PI * t)
    l0 = int(wp.floor(lod))
    t = lod - float(l0)
    lower = _level_radiance(scene, amb, l0, uv)
    if t <= 0.0:
        return lower
    return lower * (1.0 - t) + _level_radiance(scene, amb, l0 + 1, uv) * t


@wp.func(inline=True)
def env_brdf(amb: AmbientGPU, f0: wp.vec3, roughness: float, n_dot_v: float) -> wp.vec3:
    """Split-sum specular reflectance ``f0 A + f90 B`` under uniform light, bilinear in
    the (roughness, n.v) table."""
    size = amb.brdf_lut.shape[0]
    fr = wp.clamp(roughness, 0.0, 1.0) * float(size - 1)
    fv = wp.clamp(wp.clamp(n_dot_v, 0.0, 1.0) * float(size) - 0.5, 0.0, float(size - 1))
    r0 = wp.min(int(fr), size - 2)
    v0 = wp.min(int(fv), size - 2)
    tr = fr - float(r0)
    tv = fv - float(v0)
    ab = (amb.brdf_lut[r0, v0] * (1.0 - tv) + amb.brdf_lut[r0, v0 + 1] * tv) * (1.0 - tr) + (
        amb.brdf_lut[r0 + 1, v0] * (1.0 - tv) + amb.brdf_lut[r0 + 1, v0 + 1] * tv
    ) * tr
    f90 = fresnel_f90(f0)
    return f0 * ab[0] + wp.vec3(f90, f90, f90) * ab[1]


@wp.func(inline=True)
def ambient_diffuse(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3, v: wp.vec3, kd: wp.vec3, f0: wp.vec3) -> wp.vec3:
    """Diffuse light from the dome: ``kd / pi * E(n) * (1 - F(n.v))`` (the diffuse
    lobe of ``brdf.brdf_diffuse`` integrated against the dome's irradiance)."""
    if amb.enabled == 0:
        return wp.vec3(0.0, 0.0, 0.0)
    keep = diffuse_view_weight(f0, wp.clamp(wp.dot(n, v), 0.0, 1.0))
    return wp.cw_mul(wp.cw_mul(kd * INV_PI, dome_irradiance(scene, amb, n)), keep)


@wp.func(inline=True)
def ambient_specular(
    scene: SceneGPU, amb: AmbientGPU, n: wp.vec3, v: wp.vec3, f0: wp.vec3, roughness: float
) -> wp.vec3:
    """Glossy reflection of the dome: prefiltered radiance along the mirror direction
    times the split-sum specular reflectance."""
    if amb.enabled == 0:
        return wp.vec3(0.0, 0.0, 0.0)
    r = n * (2.0 * wp.dot(n, v)) - v
    return wp.cw_mul(env_brdf(amb, f0, roughness, wp.dot(n, v)), prefiltered_radiance(scene, amb, r, roughness))
