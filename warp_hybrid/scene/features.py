"""Decide which effects a scene needs from its materials and lights."""

from __future__ import annotations

from .model import Scene, SceneFeatures


def analyse_features(scene: Scene) -> SceneFeatures:
    """Return the effects this scene's materials and lights call for.

    Only materials that some triangle uses count, so an unused glass material in a
    library never turns refraction on.
    """
    used = {int(m) for m in set(scene.triangle_material.tolist())} if scene.triangle_count else set()
    mats = [scene.materials[i] for i in sorted(used) if 0 <= i < len(scene.materials)]
    return SceneFeatures(
        shadows=bool(scene.lights),
        reflections=any(m.is_reflective for m in mats),
        refractions=any(m.is_refractive for m in mats),
        transparency=any(m.is_transmissive for m in mats),
        environment=scene.environment is not None,
        emission=any(max(m.emissive) > 0.0 or m.emissive_texture >= 0 for m in mats),
        cutouts=any(m.is_cutout for m in mats),
        textures=any(
            t >= 0
            for m in mats
            for t in (m.diffuse_texture, m.emissive_texture, m.roughness_texture, m.metallic_texture, m.opacity_texture)
        ),
    )
