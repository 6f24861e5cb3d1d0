"""Incident light from one UsdLux light at a shading point (``@wp.func``).

The arithmetic is ``native_math``'s C++ (``wh_light_sample``), the one implementation the
scalar functions here and the deferred pass's row loop (``direct_rows.py``) share.

``light_sample(light, p, n)`` returns a ``LightSample``: the unit direction ``wi``
from ``p`` toward the light's centre, the ``distance`` to it (inf for a distant
light; a shadow ray stops there), and two irradiance terms:

* ``e_normal``: irradiance at normal incidence from the light's centre direction,
  so a lobe evaluated along ``wi`` receives ``f(v, wi) * e_normal * max(n.wi, 0)``
  (the specular lobe always uses it);
* ``irradiance``: the irradiance on the surface itself (receiver cosine included,
  horizon respected), used with the diffuse lobe.  For point-like lights it equals
  ``e_normal * max(n.wi, 0)``; for a rect light it is the exact area-light value.

Units follow UsdLux: ``light.color`` (= color * intensity * 2^exposure, folded in by
the loader) is the emitted radiance L of area lights (nits, W/(m^2 sr) up to the
renderer's RGB scale) and the irradiance E (W/m^2) of a distant light; lengths are
scene units (irradiance scales as 1 / unit^2 like any inverse-square law).

Per kind:

* DISTANT: ``wi = -direction``, ``E = color`` on a surface facing the light (the
  Storm/Karma reading of intensity for a sun; ``angle`` only softens shadows).
* SPHERE: point approximation from the centre, exact for an unoccluded sphere fully
  above the horizon: ``E = L pi r^2 / d^2`` with ``d^2`` clamped to ``>= r^2`` (so
  ``E <= pi L`` even inside the sphere); ``normalize`` divides L by the area
  ``4 pi r^2`` (``E = color / (4 d^2)``); radius 0 means a true point light whose
  colour is its intensity (W/sr): ``E = color / d^2``.
* RECT: a one-sided rectangle with half extents ``axis_u``/``axis_v`` emitting along
  ``direction``.  Diffuse: exact irradiance from Lambert's polygon formula
  ``E = L/2 * sum_i theta_i (n . gamma_i)`` over the edges of the rectangle clipped
  to the horizon plane of ``p`` (theta_i the angle the edge subtends,
  gamma_i the unit normal of the plane through ``p`` and the edge), i.e. ``pi L``
  times the point-to-polygon form factor (edge angles from ``subtended_angle``,
  accurate to 1e-5 rad).  Specular: the centre as a point emitter,
  ``E = L A cos_e / d^2`` (A the area, cos_e the emitter cosine), capped at the
  physical bound ``pi L``.  ``normalize`` divides L by A.
* DISK: the point form factor with the emitter cosine, ``E = L pi r^2 cos_e / d^2``
  capped at ``pi L``; the area is ``pi |axis_u x axis_v|`` when the axes are set,
  else ``pi radius^2``.  ``normalize`` divides L by it.
* ShapingAPI cone (sphere, rect and disk): a factor on both terms from the angle
  between ``direction`` and the ray leaving the light: 1 inside
  ``coneAngle * (1 - coneSoftness)``, 0 beyond ``coneAngle``, smoothstep between.
"""

from __future__ import annotations

import warp as wp

from ..core.scene_gpu import LightGPU
from ..scene.model import LightKind
from .native_math import cpp

KIND_DISTANT = wp.constant(int(LightKind.DISTANT))
KIND_SPHERE = wp.constant(int(LightKind.SPHERE))
KIND_RECT = wp.constant(int(LightKind.RECT))


@wp.struct
class LightSample:
    """What one light delivers at a shading point (see the module docstring)."""

    wi: wp.vec3
    distance: float
    e_normal: wp.vec3
    irradiance: wp.vec3


@wp.func_native(cpp("subtended_angle") + "return wh_subtended_angle(s, c);")
def subtended_angle(s: float, c: float) -> float:
    """atan2(s, c) for s >= 0, in [0, pi]: a degree-11 odd minimax polynomial for atan
    on [0, 1] (the Cg reference coefficients; absolute error < 1e-5 rad, relative error
    < 5e-6 near 0), several times cheaper than libm's atan2 on the CPU.  Branch-free
    (selects only), so the compiler can evaluate several of them in SIMD lanes."""
    ...


#: ``_light_terms``' result: rows ``wi``, ``(distance, 0, 0)``, ``e_normal``, ``irradiance``
#: (a native function returns no struct).
_LightTerms = wp.types.matrix(shape=(4, 3), dtype=wp.float32)


@wp.func_native(
    cpp("light_sample")
    + """
wp::vec3 wi, e_normal, irradiance;
float distance;
const bool has_cone = wh_has_cone(light);
const float cos_inner = has_cone ? wh_cone_inner(light) : 0.0f;
wh_light_sample(light, light.kind, has_cone, cos_inner, p, n, exact, WH_RECT_ONE, wi, distance, e_normal, irradiance);
wp::mat_t<4, 3, float> rows;
for (int i = 0; i < 3; ++i) {
    rows.data[0][i] = wi[i];
    rows.data[1][i] = i == 0 ? distance : 0.0f;
    rows.data[2][i] = e_normal[i];
    rows.data[3][i] = irradiance[i];
}
return rows;
"""
)
def _light_terms(light: LightGPU, p: wp.vec3, n: wp.vec3, exact: bool) -> _LightTerms:
    """``_light_sample``'s values as the rows of a matrix."""
    ...


@wp.func(inline=True)
def _light_sample(light: LightGPU, p: wp.vec3, n: wp.vec3, exact: bool) -> LightSample:
    """``light_sample``; without ``exact`` a rect light's irradiance is its exact value only
    where the centre terms leave ``light_reaches`` undecided (``reach_sample``)."""
    rows = _light_terms(light, p, n, exact)
    out = LightSample()
    out.wi = wp.vec3(rows[0, 0], rows[0, 1], rows[0, 2])
    out.distance = rows[1, 0]
    out.e_normal = wp.vec3(rows[2, 0], rows[2, 1], rows[2, 2])
    out.irradiance = wp.vec3(rows[3, 0], rows[3, 1], rows[3, 2])
    return out


@wp.func(inline=True)
def light_sample(light: LightGPU, p: wp.vec3, n: wp.vec3) -> LightSample:
    """Direction, distance and irradiance terms of ``light`` at point ``p`` (normal ``n``)."""
    return _light_sample(light, p, n, True)


@wp.func(inline=True)
def reach_sample(light: LightGPU, p: wp.vec3, n: wp.vec3) -> LightSample:
    """``light_sample`` for a caller that reads the irradiance only through
    ``light_reaches`` (shadow rays, shadow-map visibility): the same ``wi``, ``distance``
    and ``e_normal``, and the same answer from ``light_reaches``, but a rect light's exact
    irradiance (the horizon-clipped polygon, the costly part) is computed only where the
    centre terms do not already show the light reaching ``p``; elsewhere ``irradiance``
    is the centre's point value."""
    return _light_sample(light, p, n, False)


@wp.func_native(cpp("light_reaches") + "return wh_light_reaches(irradiance, e_normal, n, wi);")
def _light_reaches(irradiance: wp.vec3, e_normal: wp.vec3, n: wp.vec3, wi: wp.vec3) -> bool:
    """``light_reaches`` given the sample's parts."""
    ...


@wp.func(inline=True)
def light_reaches(ls: LightSample, n: wp.vec3) -> bool:
    """The light contributes at all at a point with normal ``n`` (its unshadowed
    response is non-zero): some irradiance on the surface, or its centre above the
    horizon (the specular lobe's term).  The one rule for whether a shadow ray or a
    shadow-map lookup is needed (``wh_light_reaches``, which the shadow packets' row
    loop calls too)."""
    return _light_reaches(ls.irradiance, ls.e_normal, n, ls.wi)
