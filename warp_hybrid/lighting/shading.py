"""Shading of one surface point (``@wp.func``), shared by deferred lighting and the tracer.

The radiance leaving a surface toward the viewer is assembled by the caller as::

    kd     = diffuse_albedo(scene, n, v, albedo, opacity, ior, flags)
    direct = sum_i T_i * direct_light(scene, i, p, n, v, kd, f0, roughness)
    Lo     = shade_surface(scene, amb, n, v, albedo, kd, f0, roughness, emission,
                           opacity, ior, flags, direct)

where ``T_i`` is the caller's RGB transmittance toward light i (1 unshadowed; the
deferred pass reads it from the shadow tracer's buffer, the tracer computes it with
shadow rays at secondary hits).  ``shade_surface_with`` takes the glossy ambient
term from the caller instead (the deferred pass's reflection probe).  Callers that
trace light paths themselves use the pieces: ``light_response`` for a light sample
they already have, ``ambient_diffuse`` and ``ambient_specular`` (``lighting/ambient.py``)
separately.

Conventions: ``n`` unit shading normal facing the viewer, ``v`` unit direction toward
the viewer, ``albedo`` the diffuse colour (already times 1 - metallic; the
transmission tint for glass), ``f0`` the specular colour, ``emission`` the emitted
radiance.  Metallic is folded into ``albedo``/``f0`` before shading.

Transmissive materials (FLAG_TRANSMISSIVE: glass, tinted panes) in raster-only
shading (no rays; the tracer replaces this inside the focus window):

* the diffuse lobe is weighted by ``opacity`` (clear glass has no diffuse response,
  its specular highlights and Fresnel-weighted glossy dome reflection stay);
* the light passing through, ``(1 - opacity) (1 - F(n.v)) tint * B``, with ``F`` the
  exact dielectric Fresnel for ``ior`` and B the radiance behind the surface:
  with a dome, B = the dome straight through (along -v, no bending);
  without one, B is estimated as the light falling on the surface itself (it is
  shaded like a tinted Lambertian), so interiors without a dome do not turn glass
  black.
"""

from __future__ import annotations

import warp as wp

from ..core.scene_gpu import FLAG_TRANSMISSIVE, AmbientGPU, SceneGPU
from ..scene.device.environment import environment_radiance
from .ambient import ambient_irradiance, ambient_specular
from .lights import LightSample, light_sample
from .native_math import cpp


@wp.func_native(
    cpp("light_response")
    + "return wh_light_response(true, ls.wi, ls.e_normal, ls.irradiance, n, v, kd, f0, roughness);"
)
def light_response(ls: LightSample, n: wp.vec3, v: wp.vec3, kd: wp.vec3, f0: wp.vec3, roughness: float) -> wp.vec3:
    """Unshadowed radiance toward ``v`` due to one light sample: the diffuse lobe times
    the surface irradiance plus the specular lobe times ``e_normal * max(n.wi, 0)``."""
    ...


@wp.func(inline=True)
def direct_light(
    scene: SceneGPU, light_index: int, p: wp.vec3, n: wp.vec3, v: wp.vec3, kd: wp.vec3, f0: wp.vec3, roughness: float
) -> wp.vec3:
    """Unshadowed contribution of light ``light_index`` at ``p`` toward ``v``."""
    return light_response(light_sample(scene.lights[light_index], p, n), n, v, kd, f0, roughness)


@wp.func_native(cpp("diffuse_albedo") + "return wh_diffuse_albedo(true, dome, n, v, albedo, opacity, ior, flags);")
def _diffuse_albedo(
    dome: bool, n: wp.vec3, v: wp.vec3, albedo: wp.vec3, opacity: float, ior: float, flags: int
) -> wp.vec3:
    """``diffuse_albedo`` given whether the scene has a dome."""
    ...


@wp.func(inline=True)
def diffuse_albedo(
    scene: SceneGPU, n: wp.vec3, v: wp.vec3, albedo: wp.vec3, opacity: float, ior: float, flags: int
) -> wp.vec3:
    """The diffuse colour that lights and the dome see (``albedo`` for opaque materials;
    see the module docstring for transmissive ones)."""
    return _diffuse_albedo(scene.environment.enabled != 0, n, v, albedo, opacity, ior, flags)


@wp.func_native(
    cpp("surface_radiance")
    + "return wh_surface_radiance(true, dome, n, v, albedo, kd, f0, emission, opacity, ior, flags, direct, e, "
    "specular, behind);"
)
def surface_radiance(
    dome: bool,
    n: wp.vec3,
    v: wp.vec3,
    albedo: wp.vec3,
    kd: wp.vec3,
    f0: wp.vec3,
    emission: wp.vec3,
    opacity: float,
    ior: float,
    flags: int,
    direct: wp.vec3,
    e: wp.vec3,
    specular: wp.vec3,
    behind: wp.vec3,
) -> wp.vec3:
    """``shade_surface_with`` given the ambient irradiance ``e`` (``ambient_irradiance``),
    whether the scene has a dome and its radiance ``behind`` the surface (along -v; read
    only for a transmissive material under a dome)."""
    ...


@wp.func(inline=True)
def shade_surface_with(
    scene: SceneGPU,
    amb: AmbientGPU,
    n: wp.vec3,
    v: wp.vec3,
    albedo: wp.vec3,
    kd: wp.vec3,
    f0: wp.vec3,
    emission: wp.vec3,
    opacity: float,
    ior: float,
    flags: int,
    direct: wp.vec3,
    specular: wp.vec3,
) -> wp.vec3:
    """``shade_surface`` with the caller's glossy ambient ``specular`` in place of the
    dome's (the deferred pass gives a reflection probe's, ``probe_kernels``)."""
    dome = scene.environment.enabled != 0
    behind = wp.vec3(0.0, 0.0, 0.0)
    if (flags & FLAG_TRANSMISSIVE) != 0 and dome:
        behind = environment_radiance(scene, -v)
    e = ambient_irradiance(scene, amb, n)
    return surface_radiance(dome, n, v, albedo, kd, f0, emission, opacity, ior, flags, direct, e, specular, behind)


@wp.func(inline=True)
def shade_surface(
    scene: SceneGPU,
    amb: AmbientGPU,
    n: wp.vec3,
    v: wp.vec3,
    albedo: wp.vec3,
    kd: wp.vec3,
    f0: wp.vec3,
    roughness: float,
    emission: wp.vec3,
    opacity: float,
    ior: float,
    flags: int,
    direct: wp.vec3,
) -> wp.vec3:
    """Raster shading of one point: emission + the caller's (shadowed) ``direct`` sum +
    the dome's diffuse and glossy light + the transmissive approximation."""
    specular = ambient_specular(scene, amb, n, v, f0, roughness)
    return shade_surface_with(scene, amb, n, v, albedo, kd, f0, emission, opacity, ior, flags, direct, specular)
