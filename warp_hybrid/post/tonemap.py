"""Tone-mapping operators (exposed linear RGB -> display-linear [0, 1], per channel).

* ``aces`` (default): Narkowicz's 2015 fit of the ACES filmic RRT+ODT curve,
  ``f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)``, clamped to [0, 1].
* ``reinhard``: ``x / (1 + x)``.
* ``none``: clamp to [0, 1].

Negative values (and NaN) map to 0.  The result is then encoded to 8-bit sRGB
(``color.srgb_quantize``) for display.

Each curve is written once, as C++ statements (``CHANNEL_CPP``: float ``x`` in, float
``t`` out, one operation a statement so the compiler contracts nothing into a fused
multiply-add), from which both the per-channel ``@wp.func`` (``OPERATORS``) and the tone
map's row loop (``kernels.py``, which the compiler vectorises across pixels) are made:
the two give the same bits.

No ``from __future__ import annotations`` here: Warp reads the generated stubs' types
from evaluated annotations.
"""

import warp as wp

#: Per operator, C++ statements mapping float ``x`` to float ``t`` in [0, 1].
CHANNEL_CPP = {
    "aces": """
const float c = wp::max(x, 0.0f);
const float n1 = 2.51f * c;
const float n2 = n1 + 0.03f;
const float num = c * n2;
const float d1 = 2.43f * c;
const float d2 = d1 + 0.59f;
const float d3 = c * d2;
const float den = d3 + 0.14f;
const float t = wp::clamp(num / den, 0.0f, 1.0f);
""",
    "reinhard": """
const float c = wp::max(x, 0.0f);
const float den = 1.0f + c;
const float t = c / den;
""",
    "none": """
const float t = wp::clamp(x, 0.0f, 1.0f);
""",
}


def _channel_func(name: str) -> wp.Function:
    """The ``@wp.func`` of operator ``name`` on one channel (``CHANNEL_CPP[name]``)."""

    @wp.func_native(CHANNEL_CPP[name] + "return t;")
    def channel(x: float) -> float:
        """One channel through the curve."""
        ...

    return channel


_aces_channel = _channel_func("aces")
_reinhard_channel = _channel_func("reinhard")
_clamp_channel = _channel_func("none")


@wp.func
def tonemap_aces(c: wp.vec3) -> wp.vec3:
    """Narkowicz ACES filmic fit per channel."""
    return wp.vec3(_aces_channel(c[0]), _aces_channel(c[1]), _aces_channel(c[2]))


@wp.func
def tonemap_reinhard(c: wp.vec3) -> wp.vec3:
    """Reinhard ``x / (1 + x)`` per channel."""
    return wp.vec3(_reinhard_channel(c[0]), _reinhard_channel(c[1]), _reinhard_channel(c[2]))


@wp.func
def tonemap_clamp(c: wp.vec3) -> wp.vec3:
    """No curve: clamp to [0, 1]."""
    return wp.vec3(_clamp_channel(c[0]), _clamp_channel(c[1]), _clamp_channel(c[2]))


OPERATORS = {"aces": tonemap_aces, "reinhard": tonemap_reinhard, "none": tonemap_clamp}
