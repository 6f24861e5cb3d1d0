"""Ray origins that cannot re-hit the surface they leave (``@wp.func``, no kernels).

The method of Wächter & Binder, "A Fast and Robust Method for Avoiding
Self-Intersection" (Ray Tracing Gems, chapter 6): move the hit point along the
geometric normal by a fixed number of units in the last place (``INT_SCALE`` = 256
ULPs times the normal component, applied to the float's bit pattern as an integer,
via Warp's bit-preserving ``wp.cast``), so the offset grows with the magnitude of each
coordinate exactly as the rounding error of the computed hit point does.  Coordinates
close to zero, where ULPs shrink towards denormals, take a fixed offset
``FLOAT_SCALE`` instead, below ``ORIGIN``.

The chapter's constants (origin 1/32, float_scale 1/65536, int_scale 256) assume a
scene of size about 1.  Here ``ORIGIN`` and ``FLOAT_SCALE`` are multiplied by the
scene's scale ``S`` (the largest absolute coordinate of its bounds, see
``scene_scale``), so a millimetre-sized scene near the origin is offset by 1/65536 of
its own size rather than by 1.5e-5 absolute units, and a scene 1e4 units wide by
1/65536 of 1e4; for S = 1 this is exactly the published method.
"""

from __future__ import annotations

import numpy as np
import warp as wp

ORIGIN = wp.constant(1.0 / 32.0)
FLOAT_SCALE = wp.constant(1.0 / 65536.0)
INT_SCALE = wp.constant(256.0)


def scene_scale(bounds: tuple[np.ndarray, np.ndarray]) -> float:
    """``S`` for ``offset_ray_origin``: the largest absolute coordinate of the scene's
    axis-aligned bounds (min, max), at least 1e-30."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
    return float(max(np.max(np.abs(lo)), np.max(np.abs(hi)), 1.0e-30))


@wp.func
def _offset_coord(p: float, n: float, scale: float) -> float:
    """One coordinate of ``offset_ray_origin``."""
    if wp.abs(p) < ORIGIN * scale:
        return p + FLOAT_SCALE * scale * n
    of_i = int(INT_SCALE * n)
    bits = wp.cast(p, wp.int32)
    if p < 0.0:
        bits = bits - of_i
    else:
        bits = bits + of_i
    return wp.cast(bits, wp.float32)


@wp.func
def offset_ray_origin(p: wp.vec3, n: wp.vec3, scale: float) -> wp.vec3:
    """``p`` moved off its surface to the side of the unit geometric normal ``n`` (pass
    ``-n`` to leave through the far side); ``scale`` is the scene's ``S``."""
    return wp.vec3(_offset_coord(p[0], n[0], scale), _offset_coord(p[1], n[1], scale), _offset_coord(p[2], n[2], scale))
