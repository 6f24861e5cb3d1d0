"""Ray origins that cannot re-hit the surface they leave (``@wp.func``, no kernels).

A hit point ``p`` interpolated from a triangle's float32 corners lies off the exact
plane by a few units in the last place of the corners' largest coordinate ``M``
(pbrt-v4's bound for barycentric interpolation is ``gamma(7) M``, about 7 ulps), and a
ray leaving ``p`` is intersected by ``wp.mesh_query_ray`` (watertight Woop et al. in
float32, corners taken relative to the ray origin) with an error in t of about ten
ulps of the corners' distance from the origin, i.e. of the triangle's extent ``E``.
So the origin moves along the unit geometric normal by

    delta = OFFSET_ULPS_M * 2^-23 * max(M, EXTENT_WEIGHT * E)

(``hit_bound``, which the device scene keeps for every triangle,
``scene/device/triangle_bound.py``: 16 ulps of M, or 128 ulps of E when the triangle is
large compared with its distance from the local origin), which exceeds both errors by more than an
order of magnitude and is a property of the hit alone, not of the scene: a tiny object
next to a huge one keeps contact shadows, a scene far from the world origin (stored in
its local frame, ``scene.local_frame``) or rescaled gets the same offsets relative to
its own size.  The rounding of ``p + delta n`` to float32 moves the point by at most
half an ulp of M per axis, far below delta.

``offset_ray_origin(p, n, bound)`` takes the bound directly (pass ``hit_bound`` of the
triangle, or any larger magnitude for a more conservative offset).
"""

from __future__ import annotations

import warp as wp

from ..core.scene_gpu import SceneGPU

#: delta in units of the bound: 16 float32 ulps (2^-23 relative) of it.
OFFSET_SCALE = wp.constant(2.0**-19)


@wp.func
def hit_bound(scene: SceneGPU, face: int) -> float:
    """The magnitude the error of a point on triangle ``face`` scales with:
    ``max(M, EXTENT_WEIGHT * E)`` (module docstring), kept for every triangle by the
    device scene (``scene/device/triangle_bound.py``)."""
    return scene.triangle_bound[face]


@wp.func
def offset_ray_origin(p: wp.vec3, n: wp.vec3, bound: float) -> wp.vec3:
    """``p`` moved off its surface to the side of the unit geometric normal ``n`` (pass
    ``-n`` to leave through the far side) by ``OFFSET_SCALE * bound``; ``bound`` is
    the hit's ``hit_bound`` (or a larger magnitude)."""
    return p + n * (OFFSET_SCALE * bound)
