"""Ambient light from the dome for raster shading (``@wp.func``): SH irradiance and the
prefiltered mip chain of ``scene/device/dome.py``, weighted by its split-sum table.

* Diffuse: ``kd / pi * E(n)`` with ``E`` the dome's SH irradiance (plus the lights'
  indirect estimate of ``lighting/indirect.py`` where it is on), weighted by
  ``1 - F(n.v)``, the diffuse lobe's own directional albedo.
* Specular (glossy reflection of the dome): the GGX lobe of roughness r
  (alpha = r^2) reads level ``log2(alpha * W0 / 2 pi)`` of the radiance mips (the
  level whose texel angle matches alpha), trilinearly; level 0 is the sharp texture
  itself; past the last level it blends into ``E(R) / pi`` (a cosine-wide lobe).
  The result is weighted by the split-sum environment BRDF ``f0 A + f90 B``.
* No occlusion: the dome reaches every point (shadowing it needs rays).
"""

from __future__ import annotations

import warp as wp

from ..core.constants import INV_PI, TWO_PI
from ..core.scene_gpu import AmbientGPU, SceneGPU
from ..scene.device.environment import (
    SH_C0,
    SH_C1,
    SH_C2,
    SH_C20,
    SH_C22,
    dome_texture_radiance,
    environment_radiance,
    environment_uv_wp,
    latlong_bilinear,
)
from .brdf import roughness_to_alpha
from .native_math import cpp


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


@wp.func_native(cpp("env_brdf") + "return wh_env_brdf(amb.brdf_lut, f0, roughness, n_dot_v);")
def env_brdf(amb: AmbientGPU, f0: wp.vec3, roughness: float, n_dot_v: float) -> wp.vec3:
    """Split-sum specular reflectance ``f0 A + f90 B`` under uniform light, bilinear in
    the (roughness, n.v) table."""
    ...


@wp.func(inline=True)
def ambient_irradiance(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """The irradiance the diffuse ambient term sees at world normal ``n``: the dome's
    plus the lights' indirect estimate ``amb.indirect`` (zero when off)."""
    e = amb.indirect
    if amb.enabled != 0:
        e = dome_irradiance(scene, amb, n) + e
    return e


@wp.func(inline=True)
def direction_free(scene: SceneGPU, amb: AmbientGPU) -> bool:
    """Whether the dome's light is the same from every direction (no dome, or an
    untextured one): then ``ambient_irradiance`` and ``prefiltered_radiance`` do not
    depend on the normal or the direction, and ``environment_radiance`` is one colour."""
    return amb.enabled == 0 or (scene.environment.texture < 0 and amb.levels == 0 and amb.sh_bands == 1)


@wp.func_native(cpp("ambient_diffuse") + "return wh_ambient_diffuse(true, e, n, v, kd, f0);")
def ambient_diffuse_under(e: wp.vec3, n: wp.vec3, v: wp.vec3, kd: wp.vec3, f0: wp.vec3) -> wp.vec3:
    """``ambient_diffuse`` given the irradiance ``e`` (``ambient_irradiance``)."""
    ...


@wp.func(inline=True)
def ambient_diffuse(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3, v: wp.vec3, kd: wp.vec3, f0: wp.vec3) -> wp.vec3:
    """Diffuse ambient light: ``kd / pi * E(n) * (1 - F(n.v))`` (the diffuse lobe of
    ``brdf.brdf_diffuse`` integrated against uniform light) with ``E`` the dome's
    irradiance plus the indirect estimate ``amb.indirect`` (zero when off)."""
    return ambient_diffuse_under(ambient_irradiance(scene, amb, n), n, v, kd, f0)


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
