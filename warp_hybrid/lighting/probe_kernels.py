"""The reflection probe as kernels see it (``@wp.func``): the raster layer's glossy ambient
read from a cube map captured from the scene (``probes.py`` captures and filters it).

**Layout.** ``ProbeGPU.texels`` holds levels 0..``levels - 1`` one after the other, each
six faces (face k looks along ``+-axis k // 2``, + for even k: ``cube_face``'s order)
of ``size[l]`` x ``size[l]`` vec4 texels from the top row: ``rgb`` the radiance of the
scene's surfaces times ``a``, their coverage (1 where the capture saw a surface, 0 where
it saw the background).  A direction lands in a face through the face's own camera
(``faces``, the capture's cameras; ``primary.clipping.project``), so a lookup and the
capture agree on where a texel is.

**Roughness to level**, the dome's rule (``lighting/ambient.py``): the GGX lobe of
alpha reads level ``log2(alpha / theta0)``, the level whose texel angle matches alpha,
with ``theta0 = pi / (2 size[0])`` the angle of a level-0 texel at a face's centre;
trilinear (bilinear in a face, clamped at its edges, linear between levels); wider
lobes read the last level.

**Where it counts** (``probe_specular``): the probe stands in for the traced layer's
mirror ray, so it carries the same share of the glossy ambient as that ray does in the
tracer (``core.constants.mirror_share``: all of it up to ``GLOSSY_ROUGHNESS``, none
from ``SMOOTH_ROUGHNESS`` on); the dome's prefiltered term keeps the rest, as in the
traced layer.  Rough surfaces are shaded as without a probe, and both layers agree on
which surfaces reflect the room.

**Parallax** (``box_lo``/``box_hi``: the scene's bounds and the probe's position): the
reflected ray from the shaded point is followed to where it leaves the box, and the
probe is read in the direction from its ``origin`` to that point, so a reflection of a
wall lands where the wall is instead of where it would be seen from the probe.  Exact
for a scene that is its box (a room); elsewhere an approximation.

**Background.** Where the capture saw no surface the probe holds nothing (``a`` = 0):
the dome's own prefiltered radiance along the reflected direction (unshifted: it is at
infinity) fills ``1 - a`` of the lookup, so a scene under a dome reflects the sky as
before and the room where the room is; without a dome that part is black.
"""

from __future__ import annotations

import warp as wp

from ..core.camera import CameraGPU
from ..core.constants import mirror_share
from ..core.scene_gpu import AmbientGPU, SceneGPU
from ..primary.clipping import project
from .ambient import env_brdf, prefiltered_radiance
from .brdf import roughness_to_alpha
from .shadow_map_kernels import cube_face

wp.set_module_options({"enable_backward": False})


@wp.struct
class ProbeGPU:
    """One reflection probe (module docstring): ``faces`` its six face cameras,
    ``texels`` every level's faces, ``offset[l]``/``size[l]`` level l's first texel and
    face size, ``levels`` how many, ``inv_theta0`` 1 / the angle of a level-0 texel,
    ``origin`` where it was captured, ``box_lo``/``box_hi`` its parallax box."""

    faces: wp.array(dtype=CameraGPU)
    texels: wp.array(dtype=wp.vec4)
    offset: wp.array(dtype=wp.int32)
    size: wp.array(dtype=wp.int32)
    levels: int
    inv_theta0: float
    origin: wp.vec3
    box_lo: wp.vec3
    box_hi: wp.vec3


@wp.func(inline=True)
def _texel(probe: ProbeGPU, level: int, face: int, x: int, y: int) -> wp.vec4:
    """Texel (x, y) of ``face`` at ``level`` (indices already in range)."""
    s = probe.size[level]
    return probe.texels[probe.offset[level] + (face * s + y) * s + x]


@wp.func(inline=True)
def _level_sample(probe: ProbeGPU, level: int, face: int, px: float, py: float) -> wp.vec4:
    """Bilinear sample of ``face`` at ``level`` at level-0 image point (px, py),
    clamped at the face's edges."""
    s = probe.size[level]
    scale = float(s) / float(probe.size[0])
    u = px * scale - 0.5
    v = py * scale - 0.5
    x0 = int(wp.floor(u))
    y0 = int(wp.floor(v))
    fu = u - float(x0)
    fv = v - float(y0)
    xa = wp.clamp(x0, 0, s - 1)
    xb = wp.clamp(x0 + 1, 0, s - 1)
    ya = wp.clamp(y0, 0, s - 1)
    yb = wp.clamp(y0 + 1, 0, s - 1)
    top = _texel(probe, level, face, xa, ya) * (1.0 - fu) + _texel(probe, level, face, xb, ya) * fu
    bottom = _texel(probe, level, face, xa, yb) * (1.0 - fu) + _texel(probe, level, face, xb, yb) * fu
    return top * (1.0 - fv) + bottom * fv


@wp.func(inline=True)
def probe_sample(probe: ProbeGPU, d: wp.vec3, roughness: float) -> wp.vec4:
    """The probe around direction ``d`` (any length > 0) blurred to the GGX lobe of
    ``roughness``: premultiplied radiance and coverage (module docstring)."""
    face = cube_face(d)
    cam = probe.faces[face]
    s = project(cam, wp.vec3(wp.dot(d, cam.right), wp.dot(d, cam.up), wp.dot(d, cam.forward)))
    width = roughness_to_alpha(roughness) * probe.inv_theta0
    lod = float(0.0)
    if width > 1.0:
        lod = wp.min(wp.log2(width), float(probe.levels - 1))
    l0 = int(wp.floor(lod))
    t = lod - float(l0)
    lower = _level_sample(probe, l0, face, s[0], s[1])
    if t <= 0.0:
        return lower
    return lower * (1.0 - t) + _level_sample(probe, l0 + 1, face, s[0], s[1]) * t


@wp.func(inline=True)
def parallax_direction(probe: ProbeGPU, p: wp.vec3, r: wp.vec3) -> wp.vec3:
    """The direction from the probe to where the ray ``p + t r`` (t > 0) leaves the
    parallax box; ``r`` itself when ``p`` is not inside the box or the exit is the
    probe's own position."""
    t = float(3.0e38)
    for k in range(3):
        if r[k] > 0.0:
            t = wp.min(t, (probe.box_hi[k] - p[k]) / r[k])
        elif r[k] < 0.0:
            t = wp.min(t, (probe.box_lo[k] - p[k]) / r[k])
    if not (t >= 0.0 and t < 3.0e38):
        return r
    d = p + r * t - probe.origin
    if wp.dot(d, d) <= 0.0:
        return r
    return d


@wp.func(inline=True)
def probe_specular(
    scene: SceneGPU, amb: AmbientGPU, probe: ProbeGPU, p: wp.vec3, n: wp.vec3, v: wp.vec3, f0: wp.vec3, roughness: float
) -> wp.vec3:
    """Glossy ambient at ``p`` (unit shading normal ``n``, toward the viewer ``v``): the
    ``mirror_share`` of the probe along the parallax-corrected mirror direction, the
    dome's prefiltered radiance for the rest and where the probe saw background, times
    the split-sum specular reflectance (as ``ambient.ambient_specular``)."""
    n_dot_v = wp.dot(n, v)
    r = n * (2.0 * n_dot_v) - v
    share = mirror_share(roughness)
    radiance = wp.vec3(0.0, 0.0, 0.0)
    dome = float(1.0)
    if share > 0.0:
        c = probe_sample(probe, parallax_direction(probe, p, r), roughness)
        radiance = wp.vec3(c[0], c[1], c[2]) * share
        dome = 1.0 - share * c[3]
    if amb.enabled != 0 and dome > 0.0:
        radiance += prefiltered_radiance(scene, amb, r, roughness) * dome
    return wp.cw_mul(env_brdf(amb, f0, roughness, n_dot_v), radiance)


@wp.kernel
def first_hit_kernel(mesh: wp.uint64, origin: wp.vec3, direction: wp.vec3, max_t: float, t_out: wp.array(dtype=float)):
    """The distance along the unit ``direction`` from ``origin`` to the first surface,
    -1 when there is none before ``max_t`` (one thread; where the probe may stand)."""
    q = wp.mesh_query_ray(mesh, origin, direction, max_t)
    t_out[0] = -1.0
    if q.result:
        t_out[0] = q.t
