"""Shadow-map lookups (``@wp.func``) and the per-light visibility kernel (one Warp module).

A light's map is one or six *faces*, each a depth image rendered by the project's
rasterizer from a pinhole ``CameraGPU`` (``shadow_maps.py``): texel (i, j) holds the
view depth, along the face camera's forward axis, of the nearest caster through the
texel's centre (inf where none).  ``ShadowMapsGPU.first_face[i]`` is light i's first
face; a distant light has one, every other kind six (a cube map: face k looks along
``+-axis k // 2``, + for even k), and a point picks its cube face by the major axis of
its offset from the light (``cube_face``).  The face's projection is the rasterizer's
own (``primary.clipping.to_camera`` / ``project``), so lookups and the map agree to the
bit on where a point lands.

**Depth test** (``map_visibility``): a point ``p`` with unit geometric normal ``n`` at
view depth ``z`` in the face is compared against each texel ``t`` of a 4x4 PCF
footprint through the *receiver plane*: the depth ``d_t`` at which the ray through
t's centre meets the plane through ``p`` with normal ``n`` (``d_t = (n.q) / (n.r_t)``,
``q = p - origin``, ``r_t`` the texel's camera ray with unit forward component).  That
is the slope-scaled bias made exact per texel: it grows with the surface's angle to
the light and with the texel's distance from ``p``, and a flat receiver never shadows
itself however steep the angle.  ``d_t`` is capped at ``z`` + ``SLOPE_MAX`` texel
footprints per texel of distance (a plane nearly edge-on to the light, or one the ray
misses in front, continues at most that far behind ``p``), so grazing receivers stay
finite; a nearer ``d_t`` is kept (the receiver's own surface is that near there).  As
for traced shadows, an opaque point whose geometric surface faces away from the light's
centre gets 0 (``shadow_visibility``).  The texel is lit when ``depth_t + bias >= d_t`` with the constant bias
``BIAS_TEXELS * footprint + PRECISION * (z + |p|_max)``: the footprint
``z tan / (N / 2)`` is the world size of a texel at depth ``z`` (it covers the
curvature of a receiver across the footprint and the texel grid), and the second term
the float32 rounding of the depths compared, after ``trace/offset.py`` (16 ulps, 2^-19
there, of the magnitudes they are computed from: the point's coordinates and its
distance from the face's camera; 2^-18 here, as both the map and the point round; the
camera origin's own rounding is the same on both sides).

**Filter**: three bilinear taps a texel apart in each axis (the point's texel and
either neighbour), i.e. the 4x4 texels around the point weighted
``(1 - f, 1, 1, f) / 3`` per axis (f the fractional texel position): a smooth edge
about two texels wide for 16 comparisons.  Taps beyond a face's edge are clamped to it.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBufferArrays
from ..core.scene_gpu import FLAG_TRANSMISSIVE, SceneGPU
from ..primary.clipping import project, to_camera
from .lights import KIND_DISTANT, light_reaches, reach_sample

wp.set_module_options({"enable_backward": False})

#: Constant depth bias in texel footprints at the point's depth.
BIAS_TEXELS = wp.constant(1.0)
#: Steepest receiver-plane slope followed, in footprints per texel of distance (86 deg).
SLOPE_MAX = wp.constant(16.0)
#: Relative float32 rounding of the depths compared (2 x trace/offset.py's 2^-19).
PRECISION = wp.constant(2.0**-18)


@wp.struct
class ShadowMapsGPU:
    """Every light's shadow map as kernels see them (module docstring): ``faces`` the
    face cameras, ``depth`` (faces, N, N) their view depths (row 0 at the top),
    ``first_face[i]`` the first face of light i."""

    faces: wp.array(dtype=CameraGPU)
    depth: wp.array3d(dtype=wp.float32)
    first_face: wp.array(dtype=wp.int32)


@wp.func
def _max_abs(v: wp.vec3) -> float:
    return wp.max(wp.abs(v[0]), wp.max(wp.abs(v[1]), wp.abs(v[2])))


@wp.func(inline=True)
def cube_face(q: wp.vec3) -> int:
    """The cube face (0..5: +x, -x, +y, -y, +z, -z) direction ``q`` leaves through."""
    ax = wp.abs(q[0])
    ay = wp.abs(q[1])
    az = wp.abs(q[2])
    if ax >= ay and ax >= az:
        return wp.where(q[0] >= 0.0, 0, 1)
    if ay >= az:
        return wp.where(q[1] >= 0.0, 2, 3)
    return wp.where(q[2] >= 0.0, 4, 5)


@wp.func(inline=True)
def _pcf_weight(k: int, f: float) -> float:
    """Weight of texel k (0..3) of the 4-texel PCF row at fractional position ``f``."""
    if k == 0:
        return 1.0 - f
    if k == 3:
        return f
    return 1.0


@wp.func
def map_visibility(sm: ShadowMapsGPU, face: int, p: wp.vec3, n: wp.vec3) -> float:
    """Share of the PCF footprint of face ``face`` that sees point ``p`` (unit geometric
    normal ``n``) lit, in [0, 1]; 1 where ``p`` lies outside the face (module docstring)."""
    cam = sm.faces[face]
    c = to_camera(cam, p)
    z = c[2]
    if not (z > 0.0):
        return 1.0
    s = project(cam, c)
    size = cam.width
    fsize = float(size)
    px = s[0]
    py = s[1]
    if not (px >= 0.0 and px <= fsize and py >= 0.0 and py <= fsize):
        return 1.0
    tan_per_texel = cam.tan_x / (0.5 * fsize)
    footprint = z * tan_per_texel
    bias = BIAS_TEXELS * footprint + PRECISION * (z + _max_abs(p))
    # The receiver plane: n.r along the ray through image point (px + du, py + dv) is
    # n_dot_r + kx du + ky dv (r with unit forward component; y runs down the image).
    nq = wp.dot(n, p - cam.origin)
    n_dot_r = nq / z
    kx = wp.dot(n, cam.right) * tan_per_texel
    ky = -wp.dot(n, cam.up) * tan_per_texel
    u = px - 0.5
    v = py - 0.5
    i0 = int(wp.floor(u))
    j0 = int(wp.floor(v))
    fu = u - float(i0)
    fv = v - float(j0)
    lit = float(0.0)
    for b in range(4):
        ty = wp.clamp(j0 - 1 + b, 0, size - 1)
        dv = float(ty) + 0.5 - py
        row = float(0.0)
        for a in range(4):
            tx = wp.clamp(i0 - 1 + a, 0, size - 1)
            du = float(tx) + 0.5 - px
            limit = SLOPE_MAX * footprint * (wp.abs(du) + wp.abs(dv))
            d = z
            if nq != 0.0:
                nr = n_dot_r + kx * du + ky * dv
                d = z + limit
                if nr * nq > 0.0:
                    d = wp.min(nq / nr, d)
            if sm.depth[face, ty, tx] + bias >= d:
                row += _pcf_weight(a, fu)
        lit += row * _pcf_weight(b, fv)
    return lit / 9.0


@wp.func
def shadow_visibility(
    scene: SceneGPU, sm: ShadowMapsGPU, light_index: int, p: wp.vec3, n: wp.vec3, transmissive: bool
) -> float:
    """Shadow-map visibility of light ``light_index`` at ``p`` (unit geometric normal
    ``n``, facing the camera): its one face for a distant light, the cube face ``p``
    lies in otherwise.  As for traced shadows, an opaque point whose geometric surface
    faces away from the light's centre gets 0 (a ``transmissive`` one is lit through
    its far side)."""
    light = scene.lights[light_index]
    face = sm.first_face[light_index]
    to_light = -light.direction
    if light.kind != KIND_DISTANT:
        to_light = light.position - p
        face += cube_face(p - sm.faces[face].origin)
    if not transmissive and wp.dot(n, to_light) <= 0.0:
        return 0.0
    return map_visibility(sm, face, p, n)


@wp.kernel
def visibility_kernel(
    scene: SceneGPU,
    sm: ShadowMapsGPU,
    gb: GBufferArrays,
    visibility: wp.array3d(dtype=wp.float32),
    row0: int,
    row_step: int,
    cols: int,
):
    """Per pixel: every light's shadow-map visibility at the G-buffer's point into
    ``visibility`` (H, W, L), 0 where the light does not reach the point at all (as the
    traced visibility AOV has it); background pixels are left as they are."""
    r, c = wp.tid()
    y = row0 + r * row_step
    for x in range(c * cols, wp.min(c * cols + cols, gb.depth.shape[1])):
        if gb.triangle_id[y, x] >= 0:
            p = gb.position[y, x]
            n = gb.normal[y, x]
            transmissive = (scene.materials[gb.material_id[y, x]].flags & FLAG_TRANSMISSIVE) != 0
            for i in range(scene.light_count):
                v = float(0.0)
                if light_reaches(reach_sample(scene.lights[i], p, n), n):
                    v = shadow_visibility(scene, sm, i, p, gb.geometric_normal[y, x], transmissive)
                visibility[y, x, i] = v
