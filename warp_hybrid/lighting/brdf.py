"""The surface reflection model: UsdPreviewSurface-style Lambert + GGX.

The functions are ``@wp.func_native`` over the C++ of ``native_math`` (the model's one
implementation), so the deferred pass's row loop, its lighting kernel and the tracer's
secondary hits evaluate exactly the same arithmetic.  Vectors are world space and unit
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

from .native_math import cpp


@wp.func_native(cpp("roughness_to_alpha") + "return wh_roughness_to_alpha(roughness);")
def roughness_to_alpha(roughness: float) -> float:
    """GGX alpha from UsdPreviewSurface roughness: ``max(roughness^2, ALPHA_MIN)``."""
    ...


@wp.func_native(cpp("fresnel_f90") + "return wh_fresnel_f90(f0);")
def fresnel_f90(f0: wp.vec3) -> float:
    """Grazing reflectance: 1 for any real specular colour, fading to 0 below f0 = 2%."""
    ...


@wp.func_native(cpp("fresnel_schlick") + "return wh_fresnel_schlick(f0, cos_theta);")
def fresnel_schlick(f0: wp.vec3, cos_theta: float) -> wp.vec3:
    """Schlick's Fresnel ``f0 + (f90 - f0) (1 - cos)^5`` (``f90`` from ``fresnel_f90``)."""
    ...


@wp.func_native(cpp("fresnel_dielectric") + "return wh_fresnel_dielectric(cos_i, eta);")
def fresnel_dielectric(cos_i: float, eta: float) -> float:
    """Exact unpolarised Fresnel reflectance of a smooth dielectric interface.

    ``cos_i``: cosine between the incident direction and the normal on the incident
    side (its sign is ignored).  ``eta = n_transmitted / n_incident`` (1.5 entering
    glass from air, 1/1.5 leaving it).  Returns 1 beyond the critical angle (total
    internal reflection).
    """
    ...


@wp.func_native(cpp("ggx_d") + "return wh_ggx_d(n_dot_h, alpha);")
def ggx_d(n_dot_h: float, alpha: float) -> float:
    """GGX normal distribution D(h) (1/sr)."""
    ...


@wp.func_native(cpp("diffuse_view_weight") + "return wh_diffuse_view_weight(f0, n_dot_v);")
def diffuse_view_weight(f0: wp.vec3, n_dot_v: float) -> wp.vec3:
    """``1 - F(n.v)``: the diffuse lobe's directional albedo per unit albedo (what a
    uniform environment gives a Lambertian of this specular colour)."""
    ...


@wp.func_native(cpp("brdf_diffuse") + "return wh_brdf_diffuse(n, v, l, albedo, f0);")
def brdf_diffuse(n: wp.vec3, v: wp.vec3, l: wp.vec3, albedo: wp.vec3, f0: wp.vec3) -> wp.vec3:
    """Diffuse lobe ``albedo / pi (1 - F(n.l)) (1 - F(n.v)) / (1 - F_avg)`` (1/sr); no
    cosine, no horizon test (``n.l`` is clamped to [0, 1])."""
    ...


@wp.func_native(cpp("brdf_specular") + "return wh_brdf_specular(n, v, l, f0, roughness);")
def brdf_specular(n: wp.vec3, v: wp.vec3, l: wp.vec3, f0: wp.vec3, roughness: float) -> wp.vec3:
    """Specular lobe ``D Vis F`` (1/sr); zero when ``l`` is below the horizon."""
    ...
