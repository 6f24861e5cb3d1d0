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

from ..core.scene_gpu import AmbientGPU, EnvironmentGPU, SceneGPU, TextureGPU
from .native_math import cpp


@wp.func_native(cpp("ambient_irradiance") + "return wh_dome_irradiance(env, amb, n, true);")
def _dome_irradiance(env: EnvironmentGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """``dome_irradiance`` given the scene's dome record."""
    ...


@wp.func(inline=True)
def dome_irradiance(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """Irradiance from the dome on a surface with world normal ``n`` (no occlusion):
    the SH irradiance (band 0 alone for a constant dome) at ``n`` in the dome's frame."""
    return _dome_irradiance(scene.environment, amb, n)


@wp.func_native(
    cpp("prefiltered_radiance") + "return wh_prefiltered_radiance(env, textures, texels, amb, d, roughness);"
)
def _prefiltered_radiance(
    env: EnvironmentGPU,
    textures: wp.array(dtype=TextureGPU),
    texels: wp.array(dtype=wp.vec4),
    amb: AmbientGPU,
    d: wp.vec3,
    roughness: float,
) -> wp.vec3:
    """``prefiltered_radiance`` given the scene's dome, textures and texels."""
    ...


@wp.func(inline=True)
def prefiltered_radiance(scene: SceneGPU, amb: AmbientGPU, dir_world: wp.vec3, roughness: float) -> wp.vec3:
    """Dome radiance around ``dir_world`` blurred to the width of a GGX lobe of this
    roughness (see the module docstring)."""
    return _prefiltered_radiance(scene.environment, scene.textures, scene.texels, amb, dir_world, roughness)


@wp.func_native(cpp("env_brdf") + "return wh_env_brdf(amb.brdf_lut, f0, roughness, n_dot_v);")
def env_brdf(amb: AmbientGPU, f0: wp.vec3, roughness: float, n_dot_v: float) -> wp.vec3:
    """Split-sum specular reflectance ``f0 A + f90 B`` under uniform light, bilinear in
    the (roughness, n.v) table."""
    ...


@wp.func_native(cpp("ambient_irradiance") + "return wh_ambient_irradiance(env, amb, n, true);")
def _ambient_irradiance(env: EnvironmentGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """``ambient_irradiance`` given the scene's dome record."""
    ...


@wp.func(inline=True)
def ambient_irradiance(scene: SceneGPU, amb: AmbientGPU, n: wp.vec3) -> wp.vec3:
    """The irradiance the diffuse ambient term sees at world normal ``n``: the dome's
    plus the lights' indirect estimate ``amb.indirect`` (zero when off)."""
    return _ambient_irradiance(scene.environment, amb, n)


@wp.func_native(cpp("ambient_irradiance") + "return wh_direction_free(env, amb);")
def _direction_free(env: EnvironmentGPU, amb: AmbientGPU) -> bool:
    """``direction_free`` given the scene's dome record."""
    ...


@wp.func(inline=True)
def direction_free(scene: SceneGPU, amb: AmbientGPU) -> bool:
    """Whether the dome's light is the same from every direction (no dome, or an
    untextured one): then ``ambient_irradiance`` and ``prefiltered_radiance`` do not
    depend on the normal or the direction, and ``environment_radiance`` is one colour."""
    return _direction_free(scene.environment, amb)


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


@wp.func_native(
    cpp("ambient_specular") + "return wh_ambient_specular(env, textures, texels, amb, n, v, f0, roughness);"
)
def _ambient_specular(
    env: EnvironmentGPU,
    textures: wp.array(dtype=TextureGPU),
    texels: wp.array(dtype=wp.vec4),
    amb: AmbientGPU,
    n: wp.vec3,
    v: wp.vec3,
    f0: wp.vec3,
    roughness: float,
) -> wp.vec3:
    """``ambient_specular`` given the scene's dome, textures and texels."""
    ...


@wp.func(inline=True)
def ambient_specular(
    scene: SceneGPU, amb: AmbientGPU, n: wp.vec3, v: wp.vec3, f0: wp.vec3, roughness: float
) -> wp.vec3:
    """Glossy reflection of the dome: prefiltered radiance along the mirror direction
    times the split-sum specular reflectance."""
    return _ambient_specular(scene.environment, scene.textures, scene.texels, amb, n, v, f0, roughness)
