"""Tone-mapping operators (``@wp.func`` on exposed linear RGB -> display-linear [0, 1]).

* ``aces`` (default): Narkowicz's 2015 fit of the ACES filmic RRT+ODT curve,
  ``f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)``, per channel, clamped to [0, 1].
* ``reinhard``: ``x / (1 + x)`` per channel.
* ``none``: clamp to [0, 1].

The result is then encoded to 8-bit sRGB (``color.srgb_quantize``) for display.
"""

from __future__ import annotations

import warp as wp


@wp.func
def _aces_channel(x: float) -> float:
    c = wp.max(x, 0.0)
    return wp.clamp((c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14), 0.0, 1.0)


@wp.func
def tonemap_aces(c: wp.vec3) -> wp.vec3:
    """Narkowicz ACES filmic fit per channel."""
    return wp.vec3(_aces_channel(c[0]), _aces_channel(c[1]), _aces_channel(c[2]))


@wp.func
def tonemap_reinhard(c: wp.vec3) -> wp.vec3:
    """Reinhard ``x / (1 + x)`` per channel."""
    x = wp.max(c[0], 0.0)
    y = wp.max(c[1], 0.0)
    z = wp.max(c[2], 0.0)
    return wp.vec3(x / (1.0 + x), y / (1.0 + y), z / (1.0 + z))


@wp.func
def tonemap_clamp(c: wp.vec3) -> wp.vec3:
    """No curve: clamp to [0, 1]."""
    return wp.vec3(wp.clamp(c[0], 0.0, 1.0), wp.clamp(c[1], 0.0, 1.0), wp.clamp(c[2], 0.0, 1.0))


OPERATORS = {"aces": tonemap_aces, "reinhard": tonemap_reinhard, "none": tonemap_clamp}
