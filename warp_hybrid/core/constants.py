"""Constants and shared rules, each stated once.

``wp.constant`` returns the plain Python value, so host code and kernels read the same
names from here.
"""

from __future__ import annotations

import math

import warp as wp

PI = wp.constant(math.pi)
INV_PI = wp.constant(1.0 / math.pi)
TWO_PI = wp.constant(2.0 * math.pi)

#: Rec. 709 luminance weights of linear RGB.
LUMA_709 = (0.2126, 0.7152, 0.0722)

#: Surfaces smoother than this roughness get a traced mirror reflection; rougher ones
#: keep the prefiltered dome term.  One rule for both the feature analysis (which
#: decides whether reflection code is compiled) and the tracer kernels (which decide
#: per hit), so the two can never disagree.
SMOOTH_ROUGHNESS = wp.constant(0.35)

#: Smallest GGX alpha (= roughness^2): a perfectly smooth surface still has a lobe.
ALPHA_MIN = wp.constant(1.0e-3)

_Y_R = wp.constant(LUMA_709[0])
_Y_G = wp.constant(LUMA_709[1])
_Y_B = wp.constant(LUMA_709[2])


@wp.func(inline=True)
def luma709(c: wp.vec3) -> float:
    """Rec. 709 luminance of linear RGB (``LUMA_709``)."""
    return _Y_R * c[0] + _Y_G * c[1] + _Y_B * c[2]
