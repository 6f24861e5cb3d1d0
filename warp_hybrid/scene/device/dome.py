"""The dome's ambient data, built once per dome on the host and owned by the ``DeviceScene``.

* Diffuse: the dome's irradiance as 9 spherical-harmonic coefficients (Ramamoorthi &
  Hanrahan 2001), ``E(n)``; a Lambertian surface gets ``kd / pi * E(n)``.  A constant
  dome of radiance L gives ``E = pi L``, hence ``kd * L``.
* Specular (glossy reflection of the dome): a mip chain of the lat-long radiance
  (area-filtered halvings down to 8 texels wide), read by ``lighting/ambient.py``.
* The split-sum environment BRDF table (Karis 2013) of the GGX lobe of
  ``lighting/brdf.py``, tabulated once over (roughness, n.v) by importance sampling
  (``specular_albedo_table``).

``build_ambient`` fills the ``AmbientGPU`` struct kernels take; ``dome_source`` says
what it was built from, so a scene update rebuilds it only when the dome changed.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np
import warp as wp

from ...core.constants import ALPHA_MIN
from ...core.scene_gpu import AmbientGPU
from ..model import Scene
from .environment import sh_constant_coefficients, sh_irradiance_coefficients

MIN_MIP_WIDTH = 8
LUT_SIZE = 32
LUT_SAMPLES = 512


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


def dome_radiance_image(scene: Scene) -> np.ndarray | None:
    """The dome's lat-long radiance (H, W, 3) float32 on the host (colour, scale and bias
    applied), or None when the scene has no textured dome."""
    env = scene.environment
    if env is None or env.texture < 0:
        return None
    binding = scene.textures[env.texture]
    pixels = np.asarray(scene.images[binding.image].pixels, dtype=np.float32)
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


def dome_source(scene: Scene) -> tuple:
    """What the ambient data is derived from: the dome's colour, texture binding and
    the image object itself (compared by identity)."""
    env = scene.environment
    if env is None:
        return (None,)
    if env.texture < 0:
        return (tuple(env.color), -1)
    binding = scene.textures[env.texture]
    return (
        tuple(env.color),
        env.texture,
        tuple(binding.scale),
        tuple(binding.bias),
        scene.images[binding.image].pixels,
    )


def same_dome(a: tuple, b: tuple) -> bool:
    """Whether two ``dome_source`` results describe the same dome."""
    return len(a) == len(b) and all(
        x is y if isinstance(x, np.ndarray) or isinstance(y, np.ndarray) else x == y for x, y in zip(a, b)
    )


def build_ambient(scene: Scene, device: wp.context.Device) -> AmbientGPU:
    """Project ``scene``'s dome onto SH and build its mip chain on ``device``."""
    env = scene.environment
    image = dome_radiance_image(scene)
    mips: list[np.ndarray] = []
    if env is None:
        sh = np.zeros((9, 3), dtype=np.float32)
    elif image is None:
        sh = sh_constant_coefficients(env.color)
    else:
        sh = sh_irradiance_coefficients(image)
        mips = radiance_mips(image)
    g = AmbientGPU()
    g.enabled = 1 if env is not None else 0
    g.brdf_lut = wp.array(specular_albedo_table(), dtype=wp.vec2, device=device)
    g.sh = wp.array(sh, dtype=wp.vec3, device=device)
    g.sh_bands = 1 if not np.any(sh[1:]) else 3
    offsets = np.cumsum([0] + [m.shape[0] * m.shape[1] for m in mips])
    # (and one spare texel after the last level, no level's: the CPU's lookups load a
    # texel's three floats as four, ``wh_load4``)
    flat = np.concatenate([m.reshape(-1, 3) for m in mips] + [np.zeros((1, 3), np.float32)])
    g.mip_texels = wp.array(np.ascontiguousarray(flat, dtype=np.float32), dtype=wp.vec3, device=device)
    g.mip_offset = wp.array(np.asarray(offsets[:-1] if mips else [0], np.int32), dtype=wp.int32, device=device)
    g.mip_width = wp.array(np.asarray([m.shape[1] for m in mips] or [1], np.int32), dtype=wp.int32, device=device)
    g.mip_height = wp.array(np.asarray([m.shape[0] for m in mips] or [1], np.int32), dtype=wp.int32, device=device)
    g.levels = len(mips)
    g.base_width = int(image.shape[1]) if image is not None else 1
    g.indirect = wp.vec3(0.0, 0.0, 0.0)  # DeviceScene sets it where the estimate is on
    return g
