"""What a surface does to a ray that meets it: mirror reflection, Snell refraction,
Fresnel weights and the transmission tint (``@wp.func``).

* Reflection: the mirror direction about the shading normal, nudged above the
  geometric surface where interpolated normals would send it below.
* Transmission through a transmissive material: weighted ``(1 - opacity) (1 - F)``
  times the tint; refracted by Snell's law with relative IOR ``ior`` entering (front
  face) and ``1 / ior`` leaving, total internal reflection when F = 1; straight
  through for thin-walled surfaces (no ``FLAG_REFRACTIVE``).
* The tint (the diffuse colour) applies once per passage: on every crossing of a
  thin-walled or non-refracting surface, on entering (front-face) crossings of a solid
  dielectric; shadow rays use the same rule.
"""

from __future__ import annotations

import warp as wp

from ..core.scene_gpu import FLAG_REFRACTIVE
from ..lighting.brdf import fresnel_dielectric
from ..scene.device.surface import SurfaceHit


@wp.func
def transmission_tint(h: SurfaceHit) -> wp.vec3:
    """``(1 - opacity)`` times the diffuse tint where the tint applies (every crossing
    of a thin-walled or non-refracting surface, entering crossings of a solid one)."""
    t = 1.0 - h.opacity
    if (h.flags & FLAG_REFRACTIVE) == 0 or h.front_face != 0:
        return h.albedo * t
    return wp.vec3(t, t, t)


@wp.func
def mirror_direction(d: wp.vec3, n: wp.vec3, ng: wp.vec3) -> wp.vec3:
    """``d`` reflected about the shading normal ``n``, nudged above the geometric
    surface (``ng`` facing against ``d``) where interpolated normals would send it below."""
    r = d - n * (2.0 * wp.dot(d, n))
    c = wp.dot(r, ng)
    if c < 1.0e-4:
        r = wp.normalize(r + ng * (1.0e-4 - c))
    return r


@wp.func
def refract_direction(d: wp.vec3, n: wp.vec3, eta: float) -> wp.vec4:
    """Snell refraction of unit ``d`` at unit normal ``n`` (facing against ``d``) with
    relative IOR ``eta = n_t / n_i``: (direction, 1) or (0, 0) under total internal
    reflection."""
    cos_i = -wp.dot(d, n)
    sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin_t2 >= 1.0:
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    cos_t = wp.sqrt(1.0 - sin_t2)
    t = wp.normalize(d / eta + n * (cos_i / eta - cos_t))
    return wp.vec4(t[0], t[1], t[2], 1.0)


@wp.struct
class Transmission:
    """A surface's transmission event: Fresnel reflectance, outgoing direction, and
    whether a transmitted ray exists (not under total internal reflection)."""

    fresnel: float
    direction: wp.vec3
    valid: int


def make_transmission_func(refractions: bool):
    """``transmission(h, d)``: Fresnel and the transmitted direction at a transmissive
    hit; Snell refraction only when ``refractions`` (thin surfaces pass straight)."""

    @wp.func
    def transmission(h: SurfaceHit, d: wp.vec3) -> Transmission:
        out = Transmission()
        out.direction = d
        out.valid = 1
        cos_i = wp.max(-wp.dot(d, h.normal), 1.0e-6)
        if wp.static(refractions):
            if (h.flags & FLAG_REFRACTIVE) != 0:
                eta = h.ior
                if h.front_face == 0:
                    eta = 1.0 / h.ior
                out.fresnel = fresnel_dielectric(cos_i, eta)
                r = refract_direction(d, h.normal, eta)
                t = wp.vec3(r[0], r[1], r[2])
                if r[3] > 0.0 and wp.dot(t, h.geometric_normal) >= 0.0:
                    r = refract_direction(d, h.geometric_normal, eta)
                    t = wp.vec3(r[0], r[1], r[2])
                if r[3] == 0.0 or out.fresnel >= 1.0:
                    out.fresnel = 1.0
                    out.valid = 0
                out.direction = t
                return out
        out.fresnel = fresnel_dielectric(cos_i, h.ior)
        return out

    return transmission
