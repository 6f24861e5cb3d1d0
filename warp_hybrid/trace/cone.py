"""Texture filtering at secondary hits: the pixel's ray cone (``@wp.func``, no kernels).

A reflected or refracted ray carries the cone of its pixel (Akenine-Moller et al.,
"Texture Level of Detail Strategies for Real-Time Ray Tracing", Ray Tracing Gems 2019,
ch. 20): the cone's apex is the camera, its spread the angle one pixel sample step
subtends at the image centre (``camera.sample_spread``), and every surface on the way
is taken as flat, so the cone only widens with the path length.  A ray that has
travelled ``cone_length`` from the camera to its origin is therefore the axis of a
pinhole camera at the virtual apex ``origin - cone_length * d``, and its hit's uv
footprint is the ray differential of that camera (``surface.uv_footprint``): the hit
reads its textures' mip chains at the level a direct view from that distance would
pick (``surface_at_grad``), where level-0 lookups alias a minified texture into
speckle and miss the cache at every hit.

Curvature is left out (no beta term), so a curved mirror's cone spreads no faster than
a flat one's: its textures stay as sharp as, never blurrier than, the full ray-
differential answer.  A magnified texture (level of detail <= 0) reads level 0
bilinearly, exactly as the unfiltered lookup does.  Shadow rays carry no cone: the
tint of a textured transmissive surface they cross is read at level 0 (``shadows.py``).
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU, sample_spread
from ..core.scene_gpu import SceneGPU
from ..scene.device.surface import uv_footprint


@wp.func
def cone_footprint(
    scene: SceneGPU, cam: CameraGPU, tri: int, origin: wp.vec3, d: wp.vec3, cone_length: float
) -> wp.vec4:
    """uv footprint (du/dx, dv/dx, du/dy, dv/dy) on triangle ``tri`` of the pixel cone
    around the unit ray ``origin + t d``, whose path from the camera to ``origin`` is
    ``cone_length`` long (module docstring)."""
    # An orthonormal pair perpendicular to d (Duff et al. 2017, branchless).
    sign = wp.where(d[2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + d[2])
    b = d[0] * d[1] * a
    e1 = wp.vec3(1.0 + sign * d[0] * d[0] * a, sign * b, -sign * d[0])
    e2 = wp.vec3(b, sign + d[1] * d[1] * a, -d[1])
    spread = sample_spread(cam)
    return uv_footprint(scene, tri, origin - d * cone_length, d, e1 * spread[0], e2 * spread[1])
