"""Which tracer code a scene compiles: the variant, derived from the scene's features.

A ``TraceVariant`` is the traced subset of ``SceneFeatures`` (``core/features.py``, the
one table of effects) plus whether shadows are soft and which BVH queries run: the
4-wide copies of the CPU (``wide_bvh``, ``scene/device/wide_bvh.py``) or Warp's own (CUDA).  Every compile-time flag the
kernels test with ``wp.static`` is a property derived here, so no rule is stated twice.
``shadows.shadow_kernel`` and ``path.path_kernel`` build (and cache) one kernel per
variant, each in its own Warp module (``module="unique"``): no reflection rays without
reflective materials, no transmission or refraction code without transmissive or
refractive ones, no dome lookups without a dome, no ordered shadow walk (only the
any-hit query) when every surface is opaque (emitters cast no shadow: ``occluders.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.features import SceneFeatures


@dataclass(frozen=True)
class TraceVariant:
    """The compile-time switches of one tracer specialisation."""

    features: SceneFeatures = SceneFeatures()
    soft_shadows: bool = False
    wide_bvh: bool = False

    @classmethod
    def for_scene(cls, features: SceneFeatures, shadow_samples: int, wide_bvh: bool = False) -> TraceVariant:
        """The smallest variant that renders a scene with ``features`` (``wide_bvh``: query
        the 4-wide BVH copies, as the CPU does)."""
        return cls(features=features.traced(), soft_shadows=shadow_samples > 1, wide_bvh=wide_bvh)

    @property
    def shadows(self) -> bool:
        """Any light to trace shadow rays toward."""
        return self.features.shadows

    @property
    def transparency(self) -> bool:
        """Glass (refracting surfaces are glass too)."""
        return self.features.transparency or self.features.refractions

    @property
    def blending(self) -> bool:
        """Alpha-blended surfaces: rays pass them straight on, weighted by the uncovered share."""
        return self.features.blending

    @property
    def refractions(self) -> bool:
        """Snell refraction at solid dielectrics."""
        return self.features.refractions

    @property
    def reflections(self) -> bool:
        """Mirror reflection rays (every transmissive surface also reflects)."""
        return self.features.reflections or self.transparency

    @property
    def secondary(self) -> bool:
        """Any secondary (reflection, transmission or pass-through) ray at all."""
        return self.reflections or self.transparency or self.blending

    @property
    def environment(self) -> bool:
        """Dome lookups for escaping rays and the ambient terms."""
        return self.features.environment

    @property
    def ambient(self) -> bool:
        """Diffuse ambient light at hits: the dome's, or the lights' indirect estimate."""
        return self.features.environment or self.features.indirect

    @property
    def cutouts(self) -> bool:
        """Alpha-tested surfaces that rays step through."""
        return self.features.cutouts

    @property
    def layered_shadows(self) -> bool:
        """Shadow rays walk the surfaces that let light through, in order (emitters are
        not among them: they cast no shadow)."""
        return self.transparency or self.blending or self.features.cutouts

    def covers(self, features: SceneFeatures) -> bool:
        """Whether this variant can render a scene with ``features``."""
        return not features.missing_from(self.features)

    def shadow_key(self) -> tuple[bool, bool, bool, bool]:
        """The switches the primary shadow kernel depends on."""
        return (self.layered_shadows, self.soft_shadows, self.cutouts, self.wide_bvh)
