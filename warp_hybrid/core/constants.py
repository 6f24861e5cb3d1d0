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

#: Triangles per raster cluster: a run of consecutive triangles that the coverage pass
#: culls by one box and sets up together (``primary.kernels``, ``primary.cover_batch``);
#: the loader stores a still mesh's triangles so that its runs are compact
#: (``scene.usd.triangle_order``).
CLUSTER_TRIANGLES = wp.constant(64)

#: Surfaces smoother than this roughness get a traced mirror reflection; rougher ones
#: keep the prefiltered dome term.  One rule for both the feature analysis (which
#: decides whether reflection code is compiled) and the tracer kernels (which decide
#: per hit), so the two can never disagree.
SMOOTH_ROUGHNESS = wp.constant(0.45)
#: From this roughness up to ``SMOOTH_ROUGHNESS`` the mirror ray fades out
#: (``mirror_share``) and the prefiltered dome term fades in, so a roughness texture
#: across the cut does not speckle between mirror and matte.
GLOSSY_ROUGHNESS = wp.constant(0.25)


@wp.func
def mirror_share(roughness: float) -> float:
    """The share of a surface's specular reflection its traced mirror ray carries:
    1 up to ``GLOSSY_ROUGHNESS``, 0 from ``SMOOTH_ROUGHNESS`` on, a smoothstep between
    (the prefiltered dome term carries the rest)."""
    t = wp.clamp((roughness - GLOSSY_ROUGHNESS) / (SMOOTH_ROUGHNESS - GLOSSY_ROUGHNESS), 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


#: Smallest GGX alpha (= roughness^2): a perfectly smooth surface still has a lobe.
ALPHA_MIN = wp.constant(1.0e-3)

#: C++ expression: ``luma709`` of the ``wp::vec3`` named ``c`` (the one formula: the func
#: below and ``lighting/native_math.py`` paste it).
LUMA_709_CPP = f"{LUMA_709[0]!r}f * c[0] + {LUMA_709[1]!r}f * c[1] + {LUMA_709[2]!r}f * c[2]"


@wp.func_native(f"return {LUMA_709_CPP};")
def luma709(c: wp.vec3) -> float:
    """Rec. 709 luminance of linear RGB (``LUMA_709``)."""
    ...
