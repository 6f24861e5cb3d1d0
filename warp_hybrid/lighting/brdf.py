"""The surface reflection model: UsdPreviewSurface-style Lambert + GGX.

All functions are ``@wp.func`` so the deferred lighting kernel and the tracer's
secondary hits evaluate exactly the same model.  Vectors are world space and unit
length: ``n`` the shading normal, ``v`` toward the viewer, ``l`` toward the light.

BRDF (per colour channel)::

    f(v, l) = albedo / pi * (1 - F(n.l)) (1 - F(n.v)) / (1 - F_avg)  +  D(n.h) Vis(n.v, n.l) F(v.h)

* ``albedo`` is the diffuse colour already scaled by (1 - metallic) (the G-buffer
  stores it that way); ``f0`` the specular colour at normal incidence.
* D: GGX / Trowbridge-Reitz, ``D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2)`` with
  ``a = max(roughness^2, ALPHA_MIN)`` (the clamp avoids a 0/0 at roughness 0).
* Vis = G2 / (4 n.l n.v) with Smith's height-correlated masking-shadowing
  (Heitz 2014): ``Vis = 0.5 / (n.l sqrt((n.v)^2 (1 - a^2) + a^2) + n.v sqrt((n.l)^2 (1 - a^2) + a^2))``.
* F: Schlick, ``F = f0 + (f90 - f0) (1 - v.h)^5`` with ``f90 = clamp(50 luma(f0), 0, 1)``
  (Schlick's F90 = 1 faded out for f0 below 2%, as in Unreal/Filament), so a
  surface with zero specular colour is an exact Lambertian.
* Energy split: the diffuse lobe is weighted by ``1 - F`` on both the light and the
  view side, normalised by ``1 - F_avg`` with ``F_avg = f0 + (f90 - f0) / 21`` (the
  cosine-weighted hemispherical mean of Schlick's F), so the diffuse directional
  albedo is exactly ``albedo (1 - F(n.v))``.  The model stays reciprocal,
  ``f(v, l) = f(l, v)``, and its directional albedo never exceeds 1; the simpler
  ``1 - F(v.h)`` weighting (Storm's) reflects up to ~1.37x the incident energy at
  grazing view angles for roughness 0.2-0.4, so it is not used.

``fresnel_dielectric`` is the exact unpolarised Fresnel reflectance used later for
refraction.
"""

from __future__ import annotations

import warp as wp

from ..core.constants import ALPHA_MIN, INV_PI, PI, luma709

COS_EPS = wp.constant(1.0e-4)


@wp.func(inline=True)
def roughness_to_alpha(roughness: float) -> float:
    """GGX alpha from UsdPreviewSurface roughness: ``max(roughness^2, ALPHA_MIN)``."""
    r = wp.clamp(roughness, 0.0, 1.0)
    return wp.max(r * r, ALPHA_MIN)


@wp.func(inline=True)
def fresnel_f90(f0: wp.vec3) -> float:
    """Grazing reflectance: 1 for any real specular colour, fading to 0 below f0 = 2%."""
    return wp.clamp(50.0 * luma709(f0), 0.0, 1.0)


@wp.func(inline=True)
def fresnel_schlick(f0: wp.vec3, cos_theta: float) -> wp.vec3:
    """Schlick's Fresnel ``f0 + (f90 - f0) (1 - cos)^5`` (``f90`` from ``fresnel_f90``)."""
    c = wp.clamp(1.0 - cos_theta, 0.0, 1.0)
    c2 = c * c
    w = c2 * c2 * c
    f90 = fresnel_f90(f0)
    return f0 + (wp.vec3(f90, f90, f90) - f0) * w


@wp.func(inline=True)
def fresnel_dielectric(cos_i: float, eta: float) -> float:
    """Exact unpolarised Fresnel reflectance of a smooth dielectric interface.

    ``cos_i``: cosine between the incident direction and the normal on the incident
    side (its sign is ignored).  ``eta = n_transmitted / n_incident`` (1.5 entering
    glass from air, 1/1.5 leaving it).  Returns 1 beyond the critical angle (total
    internal reflection).
    """
    c = wp.min(wp.abs(cos_i), 1.0)
    sin_t2 = (1.0 - c * c) / (eta * eta)
    if sin_t2 >= 1.0:
        return 1.0
    cos_t = wp.sqrt(1.0 - sin_t2)
    rs = (c - eta * cos_t) / (c + eta * cos_t)
    rp = (eta * c - cos_t) / (eta * c + cos_t)
    return 0.5 * (rs * rs + rp * rp)


@wp.func(inline=True)
def ggx_d(n_dot_h: float, alpha: float) -> float:
    """GGX normal distribution D(h) (1/sr)."""
    a2 = alpha * alpha
    d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0
    return a2 / (PI * d * d)


@wp.func(inline=True)
def smith_visibility(n_dot_v: float, n_dot_l: float, alpha: float) -> float:
    """Height-correlated Smith G2 / (4 n.l n.v) for GGX."""
    a2 = alpha * alpha
    gv = n_dot_l * wp.sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2)
    gl = n_dot_v * wp.sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2)
    return 0.5 / wp.max(gv + gl, 1.0e-12)


@wp.func(inline=True)
def half_vector(v: wp.vec3, l: wp.vec3) -> wp.vec3:
    """Unit half vector between ``v`` and ``l`` (``v`` when they are opposite)."""
    h = v + l
    len_h = wp.length(h)
    if len_h < 1.0e-8:
        return v
    return h / len_h


@wp.func(inline=True)
def diffuse_view_weight(f0: wp.vec3, n_dot_v: float) -> wp.vec3:
    """``1 - F(n.v)``: the diffuse lobe's directional albedo per unit albedo (what a
    uniform environment gives a Lambertian of this specular colour)."""
    return wp.vec3(1.0, 1.0, 1.0) - fresnel_schlick(f0, n_dot_v)


@wp.func(inline=True)
def brdf_diffuse(n: wp.vec3, v: wp.vec3, l: wp.vec3, albedo: wp.vec3, f0: wp.vec3) -> wp.vec3:
    """Diffuse lobe ``albedo / pi (1 - F(n.l)) (1 - F(n.v)) / (1 - F_avg)`` (1/sr); no
    cosine, no horizon test (``n.l`` is clamped to [0, 1])."""
    one = wp.vec3(1.0, 1.0, 1.0)
    f90 = fresnel_f90(f0)
    f_avg = f0 + (wp.vec3(f90, f90, f90) - f0) * (1.0 / 21.0)
    w_l = one - fresnel_schlick(f0, wp.clamp(wp.dot(n, l), 0.0, 1.0))
    w_v = diffuse_view_weight(f0, wp.clamp(wp.dot(n, v), 0.0, 1.0))
    keep = one - f_avg
    keep = wp.vec3(wp.max(keep[0], 1.0e-6), wp.max(keep[1], 1.0e-6), wp.max(keep[2], 1.0e-6))
    w = wp.cw_div(wp.cw_mul(w_l, w_v), keep)
    return wp.cw_mul(albedo * INV_PI, w)


@wp.func(inline=True)
def brdf_specular(n: wp.vec3, v: wp.vec3, l: wp.vec3, f0: wp.vec3, roughness: float) -> wp.vec3:
    """Specular lobe ``D Vis F`` (1/sr); zero when ``l`` is below the horizon."""
    n_dot_l = wp.dot(n, l)
    if n_dot_l <= 0.0:
        return wp.vec3(0.0, 0.0, 0.0)
    n_dot_v = wp.max(wp.dot(n, v), COS_EPS)
    h = half_vector(v, l)
    alpha = roughness_to_alpha(roughness)
    d = ggx_d(wp.max(wp.dot(n, h), 0.0), alpha)
    vis = smith_visibility(n_dot_v, n_dot_l, alpha)
    return fresnel_schlick(f0, wp.dot(v, h)) * (d * vis)
