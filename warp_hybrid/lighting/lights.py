"""Incident light from one UsdLux light at a shading point (``@wp.func``).

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

import math

import warp as wp

from ..core.constants import PI
from ..core.scene_gpu import LightGPU
from ..scene.model import LightKind

KIND_DISTANT = wp.constant(int(LightKind.DISTANT))
KIND_SPHERE = wp.constant(int(LightKind.SPHERE))
KIND_RECT = wp.constant(int(LightKind.RECT))
INFINITY = wp.constant(math.inf)


@wp.struct
class LightSample:
    """What one light delivers at a shading point (see the module docstring)."""

    wi: wp.vec3
    distance: float
    e_normal: wp.vec3
    irradiance: wp.vec3


@wp.func(inline=False)
def _cone_falloff(light: LightGPU, wi: wp.vec3) -> float:
    """The ShapingAPI smoothstep for a light with a cone (the rare path of ``cone_factor``)."""
    cos_theta = -wp.dot(light.direction, wi)
    outer = wp.acos(wp.clamp(light.cos_cone, -1.0, 1.0))
    cos_inner = wp.cos(outer * (1.0 - wp.clamp(light.cone_softness, 0.0, 1.0)))
    if cos_theta >= cos_inner:
        return 1.0
    if cos_theta <= light.cos_cone:
        return 0.0
    t = (cos_theta - light.cos_cone) / (cos_inner - light.cos_cone)
    return t * t * (3.0 - 2.0 * t)


@wp.func(inline=True)
def cone_factor(light: LightGPU, wi: wp.vec3) -> float:
    """ShapingAPI cone falloff for the ray leaving the light toward the point (-wi)."""
    if light.cos_cone <= -1.0 + 1.0e-6:
        return 1.0
    return _cone_falloff(light, wi)


@wp.func(inline=True)
def subtended_angle(s: float, c: float) -> float:
    """atan2(s, c) for s >= 0, in [0, pi]: a degree-11 odd minimax polynomial for atan
    on [0, 1] (the Cg reference coefficients; absolute error < 1e-5 rad, relative error
    < 5e-6 near 0), several times cheaper than libm's atan2 on the CPU.  Branch-free
    (selects only), so the compiler can evaluate several of them in SIMD lanes."""
    ac = wp.abs(c)
    steep = s > ac
    hi = wp.where(steep, s, ac)
    t = wp.where(steep, ac, s) / hi
    t2 = t * t
    p = -0.013480470
    p = p * t2 + 0.057477314
    p = p * t2 - 0.121239071
    p = p * t2 + 0.195635925
    p = p * t2 - 0.332994597
    p = p * t2 + 0.999995630
    r = p * t
    r = wp.where(steep, 1.570796327 - r, r)
    r = wp.where(c < 0.0, 3.141592654 - r, r)
    return wp.where(hi > 0.0, r, 0.0)


@wp.func(inline=True)
def _edge_term(a: wp.vec3, b: wp.vec3, n: wp.vec3) -> float:
    """theta * (n . gamma) for the edge a -> b seen from the origin (a, b any length).

    The subtended angle is atan2(|a x b|, a.b), accurate for tiny edges."""
    c = wp.cross(a, b)
    lc = wp.sqrt(wp.dot(c, c))
    return wp.where(lc > 0.0, subtended_angle(lc, wp.dot(a, b)) * wp.dot(c, n) / lc, 0.0)


@wp.func(inline=True)
def _horizon_point(a: wp.vec3, b: wp.vec3, ha: float, hb: float) -> wp.vec3:
    """The point of segment a-b on the horizon plane (heights ha > 0 >= hb or reverse)."""
    t = ha / (ha - hb)
    return a + (b - a) * t


@wp.func(inline=False)
def quad_edge_sum(q0: wp.vec3, q1: wp.vec3, q2: wp.vec3, q3: wp.vec3, n: wp.vec3) -> float:
    """sum_i theta_i (n . gamma_i) over the quad q0..q3 (relative to the shading point)
    clipped to the half space n.x >= 0 (Sutherland-Hodgman on a convex polygon: at
    most one exit and one entry, joined by an edge along the horizon).  The general
    (and, for a rect light, the rare horizon-crossing) path, kept out of line."""
    total = float(0.0)
    exit_pt = wp.vec3(0.0, 0.0, 0.0)
    entry_pt = wp.vec3(0.0, 0.0, 0.0)
    inside = int(0)
    for k in range(4):
        a = q0
        b = q1
        if k == 1:
            a = q1
            b = q2
        elif k == 2:
            a = q2
            b = q3
        elif k == 3:
            a = q3
            b = q0
        ha = wp.dot(n, a)
        hb = wp.dot(n, b)
        if ha > 0.0:
            inside += 1
            if hb > 0.0:
                total += _edge_term(a, b, n)
            else:
                exit_pt = _horizon_point(a, b, ha, hb)
                total += _edge_term(a, exit_pt, n)
        elif hb > 0.0:
            entry_pt = _horizon_point(a, b, ha, hb)
            total += _edge_term(entry_pt, b, n)
    if inside == 0:
        return 0.0
    if inside < 4:
        total += _edge_term(exit_pt, entry_pt, n)
    return total


@wp.func(inline=True)
def _rect_edge(c: wp.vec3, a_dot_b: float, n: wp.vec3) -> float:
    """``_edge_term`` of an edge given ``c`` = a x b and a.b (both at any common positive
    scale, which leaves the term unchanged)."""
    lc = wp.sqrt(wp.dot(c, c))
    return wp.where(lc > 0.0, subtended_angle(lc, a_dot_b) * wp.dot(c, n) / lc, 0.0)


@wp.func(inline=True)
def rect_edge_sum(d: wp.vec3, u: wp.vec3, v: wp.vec3, n: wp.vec3) -> float:
    """``quad_edge_sum`` over the rectangle with centre ``d`` (relative to the shading
    point) and half axes ``u``, ``v`` (corners d - u - v, d + u - v, d + u + v, d - u + v).

    Wholly above the horizon (the common case) the edges' cross and dot products factor
    through d x u and d x v: with z = u x v the edge a_i -> a_i+1 has
    a x b = 2 (z + d x u), 2 (z + d x v), 2 (z - d x u), 2 (z - d x v) and
    a.b = |d - v|^2 - |u|^2, |d + u|^2 - |v|^2, |d + v|^2 - |u|^2, |d - u|^2 - |v|^2
    (used at half scale); four straight-line, branch-free edge terms."""
    dn = wp.dot(d, n)
    un = wp.dot(u, n)
    vn = wp.dot(v, n)
    if dn - un - vn > 0.0 and dn + un - vn > 0.0 and dn + un + vn > 0.0 and dn - un + vn > 0.0:
        z = wp.cross(u, v)
        xu = wp.cross(d, u)
        xv = wp.cross(d, v)
        half_dd = 0.5 * wp.dot(d, d)
        half_k = 0.5 * (wp.dot(v, v) - wp.dot(u, u))
        du = wp.dot(d, u)
        dv = wp.dot(d, v)
        total = _rect_edge(z + xu, half_dd - dv + half_k, n)
        total += _rect_edge(z + xv, half_dd + du - half_k, n)
        total += _rect_edge(z - xu, half_dd + dv + half_k, n)
        total += _rect_edge(z - xv, half_dd - du - half_k, n)
        return total
    return quad_edge_sum(d - u - v, d + u - v, d + u + v, d - u + v, n)


@wp.func(inline=True)
def rect_irradiance_factor(p: wp.vec3, n: wp.vec3, light: LightGPU) -> float:
    """E / L for a one-sided rect light at ``p`` with normal ``n`` (pi times the form
    factor of the horizon-clipped rectangle; dimensionless, in [0, pi])."""
    d = light.position - p
    if wp.dot(d, light.direction) >= 0.0:
        return 0.0
    u = light.axis_u
    v = light.axis_v
    s = rect_edge_sum(d, u, v, n)
    if wp.dot(wp.cross(u, v), light.direction) > 0.0:
        s = -s
    return wp.clamp(0.5 * s, 0.0, PI)


@wp.func(inline=True)
def _light_sample(light: LightGPU, p: wp.vec3, n: wp.vec3, exact: bool) -> LightSample:
    """``light_sample``; without ``exact`` a rect light's irradiance is its exact value only
    where the centre terms leave ``light_reaches`` undecided (``reach_sample``)."""
    out = LightSample()
    zero = wp.vec3(0.0, 0.0, 0.0)
    if light.kind == KIND_DISTANT:
        out.wi = -light.direction
        out.distance = INFINITY
        out.e_normal = light.color
        out.irradiance = light.color * wp.max(wp.dot(n, out.wi), 0.0)
        return out
    to_light = light.position - p
    d2 = wp.dot(to_light, to_light)
    d = wp.sqrt(d2)
    wi = wp.vec3(0.0, 0.0, 1.0)
    if d > 0.0:
        wi = to_light / d
    out.wi = wi
    out.distance = d
    cos_n = wp.max(wp.dot(n, wi), 0.0)
    cone = cone_factor(light, wi)
    if light.kind == KIND_SPHERE:
        r2 = light.radius * light.radius
        e = zero
        if r2 > 0.0:
            scale = PI * r2
            if light.normalize != 0:
                scale = 0.25
            e = light.color * (scale / wp.max(d2, r2))
        else:
            e = light.color * (1.0 / wp.max(d2, 1.0e-20))
        out.e_normal = e * cone
        out.irradiance = out.e_normal * cos_n
        return out
    # rect and disk: one-sided planar emitters facing `direction`
    area = float(0.0)
    if light.kind == KIND_RECT:
        area = 4.0 * wp.length(wp.cross(light.axis_u, light.axis_v))
    else:
        area = PI * wp.length(wp.cross(light.axis_u, light.axis_v))
        if area <= 0.0:
            area = PI * light.radius * light.radius
    radiance = light.color
    if light.normalize != 0 and area > 0.0:
        radiance = light.color / area
    cos_e = wp.max(-wp.dot(light.direction, wi), 0.0)
    point_factor = wp.min(area * cos_e / wp.max(d2, 1.0e-20), PI)
    out.e_normal = radiance * (point_factor * cone)
    out.irradiance = out.e_normal * cos_n
    if light.kind == KIND_RECT:
        if exact or not _centre_reaches(out.e_normal, cos_n):
            out.irradiance = radiance * (rect_irradiance_factor(p, n, light) * cone)
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


@wp.func(inline=True)
def _centre_reaches(e_normal: wp.vec3, n_dot_l: float) -> bool:
    """The light's centre lies above the horizon of ``p`` and gives it light."""
    return n_dot_l > 0.0 and wp.max(e_normal[0], wp.max(e_normal[1], e_normal[2])) > 0.0


@wp.func(inline=True)
def light_reaches(ls: LightSample, n: wp.vec3) -> bool:
    """The light contributes at all at a point with normal ``n`` (its unshadowed
    response is non-zero): some irradiance on the surface, or its centre above the
    horizon (the specular lobe's term).  The one rule for whether a shadow ray or a
    shadow-map lookup is needed."""
    irradiance = ls.irradiance
    return wp.max(irradiance[0], wp.max(irradiance[1], irradiance[2])) > 0.0 or _centre_reaches(
        ls.e_normal, wp.dot(n, ls.wi)
    )
