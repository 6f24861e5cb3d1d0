"""Where shadow rays go: sample geometry of each light kind (``@wp.func``).

``light_sample`` (``lights.py``) gives the direction and distance to a light's centre;
these give the rest a shadow ray needs: where a hard shadow ray toward the centre stops
(``center_ray_length``), whether a light has extent worth several samples
(``light_has_extent``), and a uniformly sampled point on a sphere, rect or disk light
or in a distant light's cone (``sample_light_ray``).  Rays stop at a sphere light's
surface and just short (``LIGHT_END``) of a rect/disk light's point, so the emitter
geometry itself never shadows its own light.
"""

from __future__ import annotations

import warp as wp

from ..core.constants import TWO_PI
from ..core.scene_gpu import LightGPU
from .lights import KIND_DISTANT, KIND_RECT, KIND_SPHERE

LIGHT_END = wp.constant(1.0e-4)


@wp.func
def orthonormal_u(n: wp.vec3) -> wp.vec3:
    """A unit vector perpendicular to unit ``n``."""
    a = wp.vec3(1.0, 0.0, 0.0)
    if wp.abs(n[0]) > 0.9:
        a = wp.vec3(0.0, 1.0, 0.0)
    return wp.normalize(wp.cross(n, a))


@wp.func
def sphere_entry(o: wp.vec3, d: wp.vec3, c: wp.vec3, r: float) -> float:
    """Distance along unit ``d`` from ``o`` to where it enters the sphere (c, r);
    the distance to its centre plane when it misses, 0 from inside."""
    oc = c - o
    b = wp.dot(oc, d)
    c2 = wp.dot(oc, oc) - r * r
    if c2 <= 0.0:
        return 0.0
    disc = b * b - c2
    if disc < 0.0:
        return b
    return b - wp.sqrt(disc)


@wp.func
def light_has_extent(light: LightGPU) -> bool:
    """Soft shadows need more than one sample from this light."""
    if light.kind == KIND_DISTANT:
        return light.cos_half_angle < 1.0
    if light.kind == KIND_SPHERE:
        return light.radius > 0.0
    return True


@wp.func
def sample_light_ray(light: LightGPU, p: wp.vec3, wi: wp.vec3, distance: float, r1: float, r2: float) -> wp.vec4:
    """A shadow ray toward a uniformly sampled point of the light: (direction, length).
    ``wi``/``distance``: the direction and distance to the light's centre."""
    phi = TWO_PI * r2
    if light.kind == KIND_DISTANT:
        cos_t = 1.0 - r1 * (1.0 - light.cos_half_angle)
        sin_t = wp.sqrt(wp.max(1.0 - cos_t * cos_t, 0.0))
        e1 = orthonormal_u(wi)
        e2 = wp.cross(wi, e1)
        dd = wi * cos_t + (e1 * wp.cos(phi) + e2 * wp.sin(phi)) * sin_t
        return wp.vec4(dd[0], dd[1], dd[2], distance)
    q = light.position
    if light.kind == KIND_RECT:
        q = light.position + light.axis_u * (2.0 * r1 - 1.0) + light.axis_v * (2.0 * r2 - 1.0)
    else:
        rad = wp.sqrt(r1)
        e1 = orthonormal_u(wi)
        e2 = wp.cross(wi, e1)
        if light.kind == KIND_SPHERE:
            e1 = e1 * light.radius
            e2 = e2 * light.radius
        elif wp.length(wp.cross(light.axis_u, light.axis_v)) > 0.0:
            e1 = light.axis_u
            e2 = light.axis_v
        else:
            e1 = orthonormal_u(light.direction) * light.radius
            e2 = wp.cross(light.direction, e1)
        q = light.position + (e1 * wp.cos(phi) + e2 * wp.sin(phi)) * rad
    to_q = q - p
    length = wp.length(to_q)
    if length <= 0.0:
        return wp.vec4(wi[0], wi[1], wi[2], 0.0)
    dd = to_q / length
    if light.kind == KIND_SPHERE:
        length = sphere_entry(p, dd, light.position, light.radius)
    else:
        length = length * (1.0 - LIGHT_END)
    return wp.vec4(dd[0], dd[1], dd[2], length)


@wp.func
def center_ray_length(light: LightGPU, distance: float) -> float:
    """Where a hard shadow ray toward the light's centre stops."""
    if light.kind == KIND_DISTANT:
        return distance
    if light.kind == KIND_SPHERE:
        return wp.max(distance - light.radius, 0.0)
    return distance * (1.0 - LIGHT_END)
