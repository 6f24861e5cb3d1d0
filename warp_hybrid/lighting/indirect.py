"""One estimate of the indirect (interreflected) diffuse light of a scene, from the power
its lights emit: the ambient term of progressive radiosity (Cohen, Chen, Wallace and
Greenberg 1988), computed once per scene on the host.

Light of total power ``Phi`` falls on surfaces of total area ``A`` whose mean diffuse
albedo is ``rho``; each bounce keeps ``rho`` of it, so after the first (direct) hit the
surfaces receive on average

    E_indirect = rho / (1 - rho) * Phi / A

more irradiance (the sum ``rho + rho^2 + ...`` of the later bounces).  Both layers add
``kd / pi * E_indirect`` (with the diffuse lobe's view weight) wherever they add the
dome's diffuse ambient (``lighting/ambient.py``), so shadowed surfaces are not pure
black in a scene without a dome and the two layers stay one lighting model.  For an
integrating sphere (a closed sphere of one albedo around a light) the estimate is
exact: the indirect irradiance there is uniform and equals this formula.  Elsewhere it
is an average: it ignores where the light actually goes (open scenes lose light to the
sky, so it overestimates there) and occlusion.

Per channel (RGB):

* ``A``: the area of every triangle, counted once (one side of each surface).
* ``rho``: the area-weighted mean of each triangle's diffuse albedo: the material's
  diffuse colour (a texture's mean texel after its scale and bias; vertex colours'
  mean) times ``1 - metallic`` and times the opacity of transmissive materials;
  capped at ``MAX_ALBEDO`` so a white room does not diverge.
* ``Phi``: the lights' emitted power in the units of ``lighting/lights.py`` (distant
  light: its irradiance times the scene bounds' area across the light; sphere:
  ``4 pi^2 r^2 L``, point ``4 pi I``; rect and disk: ``pi L A``, one-sided; ``normalize``
  makes it ``pi color``, for a point ``4 pi color``; a ShapingAPI cone keeps the share
  of the emitted flux inside it) plus emissive surfaces (``pi L_e`` times their area).
  The dome is not counted: its diffuse light is already the SH ambient term.
"""

from __future__ import annotations

import math

import numpy as np

from ..scene.model import Light, LightKind, Material, Scene

#: The highest mean albedo the estimate uses (``rho / (1 - rho)`` grows without bound at 1).
MAX_ALBEDO = 0.95


def triangle_areas(scene: Scene) -> np.ndarray:
    """Area (T,) float64 of each triangle."""
    p = np.asarray(scene.points, np.float64)[np.asarray(scene.indices)]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def _texture_mean(scene: Scene, slot: int) -> np.ndarray:
    """Mean rgba (4,) of texture binding ``slot`` after its scale and bias."""
    binding = scene.textures[slot]
    texels = np.asarray(scene.images[binding.image].pixels, np.float64)
    return texels.reshape(-1, 4).mean(axis=0) * np.asarray(binding.scale) + np.asarray(binding.bias)


def _diffuse_albedo(scene: Scene, material: Material, colours: np.ndarray | None) -> np.ndarray:
    """The mean diffuse albedo (3,) of ``material`` (``colours``: the mean vertex colour
    of its triangles, for a vertex-coloured one)."""
    diffuse = np.asarray(material.diffuse, np.float64)
    if material.is_vertex_colored and colours is not None:
        diffuse = colours
    if material.diffuse_texture >= 0:
        diffuse = _texture_mean(scene, material.diffuse_texture)[:3]
    albedo = np.clip(diffuse, 0.0, 1.0) * (1.0 - min(max(material.metallic, 0.0), 1.0))
    if material.is_transmissive:
        albedo = albedo * min(max(material.opacity, 0.0), 1.0)
    return albedo


def mean_albedo(scene: Scene, areas: np.ndarray) -> np.ndarray:
    """The area-weighted mean diffuse albedo (3,) over the scene's triangles."""
    total = float(areas.sum())
    if total <= 0.0:
        return np.zeros(3)
    per_material = np.bincount(scene.triangle_material, weights=areas, minlength=len(scene.materials))
    mean = np.zeros(3)
    for index, (material, area) in enumerate(zip(scene.materials, per_material)):
        if area <= 0.0:
            continue
        colours = None
        if material.is_vertex_colored and len(scene.corner_colors):
            mine = scene.triangle_material == index
            colours = np.asarray(scene.corner_colors[mine], np.float64).mean(axis=(0, 1))
        mean += _diffuse_albedo(scene, material, colours) * area
    return mean / total


def _cone_share(light: Light, lambertian: bool) -> float:
    """The share of the light's flux inside its ShapingAPI cone (1 without one):
    ``sin^2`` of the half angle for a Lambertian emitter, ``(1 - cos) / 2`` for an
    isotropic one."""
    half = math.radians(min(max(light.cone_angle_deg, 0.0), 180.0))
    if lambertian:
        return 1.0 if half >= math.pi / 2 else math.sin(half) ** 2
    return (1.0 - math.cos(half)) / 2.0


def light_power(light: Light, bounds: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The flux (3,) ``light`` emits, in the units of ``lighting/lights.py`` (module
    docstring); ``bounds`` (lower, upper) of the scene, for a distant light."""
    color = np.asarray(light.color, np.float64)
    if light.kind == LightKind.DISTANT:
        extent = np.maximum(bounds[1] - bounds[0], 0.0)
        d = np.abs(np.asarray(light.direction, np.float64))
        d = d / max(float(np.linalg.norm(d)), 1e-30)
        across = d[0] * extent[1] * extent[2] + d[1] * extent[0] * extent[2] + d[2] * extent[0] * extent[1]
        return color * across
    if light.kind == LightKind.SPHERE:
        if light.radius <= 0.0:
            return color * 4.0 * math.pi * _cone_share(light, lambertian=False)
        power = color * math.pi if light.normalize else color * 4.0 * math.pi**2 * light.radius**2
        return power * _cone_share(light, lambertian=False)
    axes = float(np.linalg.norm(np.cross(light.axis_u, light.axis_v)))
    area = 4.0 * axes if light.kind == LightKind.RECT else math.pi * axes
    if light.kind == LightKind.DISK and area <= 0.0:
        area = math.pi * light.radius**2
    power = color * math.pi if light.normalize else color * math.pi * area
    return power * _cone_share(light, lambertian=True)


def emissive_power(scene: Scene, areas: np.ndarray) -> np.ndarray:
    """The flux (3,) of the emissive surfaces: ``pi L_e`` times their area (one side)."""
    per_material = np.bincount(scene.triangle_material, weights=areas, minlength=len(scene.materials))
    power = np.zeros(3)
    for material, area in zip(scene.materials, per_material):
        if area <= 0.0 or not material.is_emissive:
            continue
        emission = np.asarray(material.emissive, np.float64)
        if material.emissive_texture >= 0:
            emission = _texture_mean(scene, material.emissive_texture)[:3]
        power += math.pi * np.maximum(emission, 0.0) * area
    return power


def indirect_irradiance(scene: Scene) -> np.ndarray:
    """``E_indirect`` (3,) float64 of ``scene`` (module docstring); 0 for a scene
    without surfaces."""
    areas = triangle_areas(scene)
    total = float(areas.sum())
    if total <= 0.0:
        return np.zeros(3)
    points = np.asarray(scene.points, np.float64)
    bounds = (points.min(axis=0), points.max(axis=0))
    flux = emissive_power(scene, areas)
    for light in scene.lights:
        flux = flux + light_power(light, bounds)
    rho = np.minimum(mean_albedo(scene, areas), MAX_ALBEDO)
    return rho / (1.0 - rho) * flux / total
