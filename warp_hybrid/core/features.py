"""Which effects a scene needs: the one table that decides what is compiled and launched.

``SceneFeatures`` lists every effect once.  A field marked ``traced`` selects tracer
kernel code (``trace/variant.py`` derives its compile-time flags from these fields and
nothing else); the others only inform (``warp-hybrid info``).  ``analyse_features``
reads them off a host scene, counting only the materials some triangle uses, so an
unused glass material in a library never turns refraction on.  ``indirect`` (the
lights' interreflection estimate, ``lighting/indirect.py``) is a rendering choice, not
a property of the scene: a ``DeviceScene`` built with the estimate on sets it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..scene.model import Scene


def _effect(traced: bool) -> bool:
    return field(default=False, metadata={"traced": traced})


@dataclass(frozen=True)
class SceneFeatures:
    """The effects a scene needs (see the module docstring)."""

    shadows: bool = _effect(traced=True)
    reflections: bool = _effect(traced=True)
    refractions: bool = _effect(traced=True)
    transparency: bool = _effect(traced=True)
    blending: bool = _effect(traced=True)
    environment: bool = _effect(traced=True)
    emission: bool = _effect(traced=False)
    cutouts: bool = _effect(traced=True)
    indirect: bool = _effect(traced=True)
    textures: bool = _effect(traced=False)

    @classmethod
    def all(cls) -> SceneFeatures:
        """Every effect on (the tracer variant that can render any scene)."""
        return cls(**{f.name: True for f in fields(cls)})

    def names(self) -> list[str]:
        """The effects that are on, in table order."""
        return [f.name for f in fields(self) if getattr(self, f.name)]

    def traced(self) -> SceneFeatures:
        """Only the effects that select tracer code (the others switched off)."""
        return SceneFeatures(**{f.name: getattr(self, f.name) for f in fields(self) if f.metadata["traced"]})

    def missing_from(self, other: SceneFeatures) -> list[str]:
        """Traced effects this scene needs that ``other`` (a compiled variant) lacks."""
        return [name for name in self.traced().names() if not getattr(other, name)]


def analyse_features(scene: Scene) -> SceneFeatures:
    """The effects ``scene``'s used materials and its lights call for."""
    used = {int(m) for m in np.unique(scene.triangle_material)} if scene.triangle_count else set()
    mats = [scene.materials[i] for i in sorted(used) if 0 <= i < len(scene.materials)]
    return SceneFeatures(
        shadows=bool(scene.lights),
        reflections=any(m.is_reflective for m in mats),
        refractions=any(m.is_refractive for m in mats),
        transparency=any(m.is_glass for m in mats),
        blending=any(m.is_blended for m in mats),
        environment=scene.environment is not None,
        emission=any(m.is_emissive for m in mats),
        cutouts=any(m.is_cutout for m in mats),
        textures=any(t >= 0 for m in mats for t in m.texture_slots()),
    )
