"""Shadow rays: the RGB transmittance from a point toward a light (``@wp.func``
factories and the primary shadow kernel).

Hard shadows from the light's centre (``shadow_samples`` = 1) or N samples over the
light's sphere/rect/disk/cone (soft: the average over the samples that leave on the
lit side; ``lighting/light_sampling.py``).  Shadow rays pass through emissive surfaces
(the emitter geometry of area lights: in neither shadow BVH) and cut-out holes.  Each
is an any-hit query against the opaque triangles, then, if unblocked, an ordered walk
through the transmissive and cut-out ones (``occluders.py``).  At each crossing of a
transmissive surface the transmittance is multiplied by ``(1 - opacity) (1 - F)`` with
F the exact dielectric Fresnel reflectance for the material's IOR at the crossing
angle (air-to-glass at every crossing: by reciprocity this is the reflectance a
refracted ray would meet), and by the tint once per passage
(``optics.transmission_tint``); an alpha-blended surface (``FLAG_BLENDED``) lets
``1 - opacity`` through, untinted, with no Fresnel.  The first opaque surface stops the ray
(transmittance 0).  Straight lines, no caustics.  A light the point cannot see at all
(below its horizon, outside a spot cone, or behind the geometric surface of an opaque
point) gets 0 and no ray.

``shadow_kernel`` (stage "trace_shadow") runs over a compacted pixel list (item
``start + tid * step``; each item writes only its own pixel and its own row of the
scratch arrays): per light, the transmittance into ``transmittance[item, light]`` and
its luminance into the per-light ``visibility`` AOV; in the kept frames of a still view
a pixel whose transmittances an earlier frame of the view traced takes them from the
cache instead (``shadow_cache.py``).
"""

from __future__ import annotations

import functools

import warp as wp

from ..core.constants import luma709
from ..core.pixel_list import listed_pixel
from ..core.scene_gpu import FLAG_BLENDED, FLAG_CUTOUT, FLAG_TRANSMISSIVE, SceneGPU
from ..lighting.brdf import fresnel_dielectric
from ..lighting.light_sampling import center_ray_length, light_has_extent, sample_light_ray
from ..lighting.lights import LightSample, light_reaches, reach_sample
from ..scene.device.surface import is_cut_away, surface_at
from ..scene.device.wide_bvh import wide_any_hit, wide_closest
from .occluders import OccluderGPU
from .offset import hit_bound, offset_ray_origin
from .optics import transmission_tint
from .rays import MAX_LAYERS, TraceFrame, TraceParams, max3, step_past
from .shadow_cache import ShadowCacheGPU


@wp.struct
class ShadowResult:
    """Transmittance toward one light and the shadow rays it took."""

    transmittance: wp.vec3
    rays: int


@wp.func
def crossing_transmittance(scene: SceneGPU, face: int, u: float, v: float, d: wp.vec3) -> wp.vec3:
    """What a shadow ray keeps crossing a transmissive or alpha-blended surface (module docstring)."""
    h = surface_at(scene, face, u, v, d)
    if (h.flags & FLAG_BLENDED) != 0:
        a = 1.0 - h.opacity
        return wp.vec3(a, a, a)
    f = fresnel_dielectric(wp.dot(h.geometric_normal, d), h.ior)
    return transmission_tint(h) * (1.0 - f)


def _make_transmittance_func(layered: bool, cutouts: bool, wide: bool):
    """``ray_transmittance(scene, occ, o, d, max_t)``: any-hit against the opaque
    BVH, then (``layered``) the ordered walk through the transmissive, cut-out and
    emissive surfaces of the special BVH; ``wide``: through their 4-wide copies."""

    @wp.func
    def ray_transmittance(scene: SceneGPU, occ: OccluderGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> wp.vec3:
        zero = wp.vec3(0.0, 0.0, 0.0)
        t = wp.vec3(1.0, 1.0, 1.0)
        if max_t <= 0.0:
            return t
        if occ.opaque != wp.uint64(0):
            if wp.static(wide):
                if wide_any_hit(occ.opaque_wide, o, d, max_t):
                    return zero
            elif wp.mesh_query_ray_anyhit(occ.opaque, o, d, max_t):
                return zero
        if wp.static(not layered):
            return t
        if occ.special == wp.uint64(0):
            return t
        origin = o
        remaining = max_t
        for _layer in range(MAX_LAYERS):
            if wp.static(wide):
                q = wide_closest(occ.special_wide, origin, d, remaining)
            else:
                q = wp.mesh_query_ray(occ.special, origin, d, remaining)
            if not q.result:
                return t
            face = occ.special_faces[q.face]
            m = scene.materials[scene.triangle_material[face]]
            passes = False
            if wp.static(cutouts):
                if (m.flags & FLAG_CUTOUT) != 0:
                    if not is_cut_away(scene, face, q.u, q.v):
                        return zero
                    passes = True
            if not passes:
                if (m.flags & (FLAG_TRANSMISSIVE | FLAG_BLENDED)) == 0:
                    return zero
                t = wp.cw_mul(t, crossing_transmittance(scene, face, q.u, q.v, d))
                if max3(t) <= 0.0:
                    return zero
            origin = step_past(scene, face, q.u, q.v, q.normal, d)
            remaining = max_t - wp.dot(origin - o, d)
            if remaining <= 0.0:
                return t
        return t

    return ray_transmittance


def make_light_func(layered: bool, soft: bool, cutouts: bool, wide: bool):
    """``light_transmittance(scene, params, occ, i, ls, p, n, ng, bound, transmissive, pixel, segment)``:
    the RGB transmittance toward light ``i`` (its sample ``ls`` at ``p``), averaged
    over the shadow samples that leave the surface on the lit side (transmissive
    points may send them through their far side); ``bound`` is ``offset.hit_bound``
    of the triangle ``p`` lies on."""
    ray_transmittance = _make_transmittance_func(layered, cutouts, wide)

    @wp.func
    def light_transmittance(
        scene: SceneGPU,
        params: TraceParams,
        occ: OccluderGPU,
        light_index: int,
        ls: LightSample,
        p: wp.vec3,
        n: wp.vec3,
        ng: wp.vec3,
        bound: float,
        transmissive: bool,
        pixel: int,
        segment: int,
    ) -> ShadowResult:
        out = ShadowResult()
        out.transmittance = wp.vec3(0.0, 0.0, 0.0)
        out.rays = 0
        if not light_reaches(ls, n):
            return out
        light = scene.lights[light_index]
        samples = int(1)
        if wp.static(soft):
            if light_has_extent(light):
                samples = params.shadow_samples
        rng = wp.rand_init(params.seed + light_index * 7919 + segment * 104729, pixel)
        total = wp.vec3(0.0, 0.0, 0.0)
        for _s in range(samples):
            d = ls.wi
            length = center_ray_length(light, ls.distance)
            if wp.static(soft):
                if samples > 1:
                    r1 = wp.randf(rng)
                    r2 = wp.randf(rng)
                    ray = sample_light_ray(light, p, ls.wi, ls.distance, r1, r2)
                    d = wp.vec3(ray[0], ray[1], ray[2])
                    length = ray[3]
            side = ng
            if wp.dot(d, ng) <= 0.0:
                if not transmissive:
                    continue
                side = -ng
            o = offset_ray_origin(p, side, bound)
            total += ray_transmittance(scene, occ, o, d, length - wp.dot(o - p, d))
            out.rays += 1
        if out.rays > 0:
            out.transmittance = total / float(out.rays)
        return out

    return light_transmittance


@functools.lru_cache(maxsize=None)
def shadow_kernel(layered: bool, soft: bool, cutouts: bool, wide: bool) -> wp.Kernel:
    """The primary shadow kernel for one flag tuple (its own Warp module, cached).

    Inputs: scene, the call's ``TraceFrame`` (its transmittance rows and count column 0
    are written), visibility (H, W, L) out, the still view's cache (``shadow_cache``:
    a pixel's entry of the current generation is reused, a traced pixel's stored),
    start, step."""
    light_transmittance = make_light_func(layered, soft, cutouts, wide)

    @wp.kernel(enable_backward=False, module="unique")
    def trace_shadow(
        scene: SceneGPU,
        tf: TraceFrame,
        visibility: wp.array3d(dtype=wp.float32),
        cache: ShadowCacheGPU,
        start: int,
        step: int,
    ):
        item = start + wp.tid() * step
        xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
        x = xy[0]
        y = xy[1]
        if x < 0 or tf.gb.triangle_id[y, x] < 0:
            return
        if cache.reuse != 0 and cache.stamp[y, x] == cache.generation:
            for i in range(scene.light_count):
                kept = cache.transmittance[y, x, i]
                tf.transmittance[item, i] = kept
                visibility[y, x, i] = wp.clamp(luma709(kept), 0.0, 1.0)
            tf.counts[item, 0] = 0
            return
        pixel = y * tf.cam.width + x
        mid = tf.gb.material_id[y, x]
        transmissive = (scene.materials[mid].flags & FLAG_TRANSMISSIVE) != 0
        p = tf.gb.position[y, x]
        n = tf.gb.normal[y, x]
        ng = tf.gb.geometric_normal[y, x]
        bound = hit_bound(scene, tf.gb.triangle_id[y, x])
        rays = int(0)
        for i in range(scene.light_count):
            ls = reach_sample(scene.lights[i], p, n)
            r = light_transmittance(scene, tf.params, tf.occ, i, ls, p, n, ng, bound, transmissive, pixel, 0)
            tf.transmittance[item, i] = r.transmittance
            cache.transmittance[y, x, i] = r.transmittance
            visibility[y, x, i] = wp.clamp(luma709(r.transmittance), 0.0, 1.0)
            rays += r.rays
        cache.stamp[y, x] = cache.generation
        tf.counts[item, 0] = rays

    return trace_shadow
