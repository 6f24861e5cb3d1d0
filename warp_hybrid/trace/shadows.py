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
cache instead (``shadow_cache.py``).  On the CPU (the 4-wide BVH copies) a kernel thread
takes ``SHADOW_GROUP`` consecutive items and sends their rays toward each light (each
sample) through the opaque BVH as one packet (``wide_bvh.wide_any_hit_packet``: a row of
pixels' rays toward one light visit nearly the same nodes), then the unblocked ones
through the special BVH: an any-hit packet tells which meet it at all, and those walk
through its layers together, each layer's nearest hits one packet
(``wide_bvh.wide_closest_packet``); where the shadow cache's last transmittance toward
the light at either end of the group is partial (``crossed``: its rays crossed glass
when last traced, in any earlier frame) every unblocked ray walks at once, without the
any-hit packet.  The same rays, the same random streams, the same answers as one item a
thread (``shadow_launch`` gives either launch's shape).  Secondary hits'
shadow rays (``make_light_func``, in the path kernel) go one at a time.
"""

from __future__ import annotations

import functools

import warp as wp

from ..core.constants import luma709
from ..core.pixel_list import listed_pixel
from ..core.scene_gpu import FLAG_BLENDED, FLAG_CUTOUT, FLAG_TRANSMISSIVE, LightGPU, SceneGPU
from ..lighting.brdf import fresnel_dielectric
from ..lighting.light_sampling import center_ray_length, light_has_extent, sample_light_ray
from ..lighting.lights import LightSample, light_reaches, reach_sample
from ..lighting.native_math import cpp
from ..scene.device.surface import is_cut_away, surface_at
from ..scene.device.wide_bvh import (
    PACKET,
    hit_from_row,
    wide_any_hit,
    wide_any_hit_packet,
    wide_closest,
    wide_closest_packet,
)
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


@wp.struct
class LayerCrossing:
    """One layer of the ordered walk crossed: the transmittance after it, where the walk
    goes on from and how far it may still go; ``going`` False where the walk ends here
    (``transmittance`` then its answer: zero where the layer blocks)."""

    transmittance: wp.vec3
    origin: wp.vec3
    remaining: float
    going: bool


def _make_crossing_func(cutouts: bool):
    """``cross_layer(scene, occ, hit_face, u, v, normal, o, d, max_t, t)``: the ordered
    walk's step over the special BVH's hit ``hit_face`` (its face index there; barycentrics
    ``u, v``, face ``normal``) of the ray ``o + s d``, ``s < max_t``, that kept ``t`` so
    far: a cut-out hole passes, a cut-out's solid part or an opaque surface blocks, a
    transmissive or blended one multiplies in what it lets through; the walk goes on just
    past the hit."""

    @wp.func
    def cross_layer(
        scene: SceneGPU,
        occ: OccluderGPU,
        hit_face: int,
        u: float,
        v: float,
        normal: wp.vec3,
        o: wp.vec3,
        d: wp.vec3,
        max_t: float,
        t: wp.vec3,
    ) -> LayerCrossing:
        out = LayerCrossing()
        out.transmittance = wp.vec3(0.0, 0.0, 0.0)
        out.going = False
        face = occ.special_faces[hit_face]
        m = scene.materials[scene.triangle_material[face]]
        passes = False
        if wp.static(cutouts):
            if (m.flags & FLAG_CUTOUT) != 0:
                if not is_cut_away(scene, face, u, v):
                    return out
                passes = True
        kept = t
        if not passes:
            if (m.flags & (FLAG_TRANSMISSIVE | FLAG_BLENDED)) == 0:
                return out
            kept = wp.cw_mul(t, crossing_transmittance(scene, face, u, v, d))
            if max3(kept) <= 0.0:
                return out
        out.transmittance = kept
        out.origin = step_past(scene, face, u, v, normal, d)
        out.remaining = max_t - wp.dot(out.origin - o, d)
        out.going = not (out.remaining <= 0.0)
        return out

    return cross_layer


def _make_walk_func(cutouts: bool, wide: bool):
    """``layered_transmittance(scene, occ, o, d, max_t)``: the ordered walk through the
    transmissive, cut-out and emissive surfaces of the special BVH (``wide``: its 4-wide
    copy) of a ray the opaque triangles do not block."""

    cross_layer = _make_crossing_func(cutouts)

    @wp.func
    def layered_transmittance(scene: SceneGPU, occ: OccluderGPU, o: wp.vec3, d: wp.vec3, max_t: float) -> wp.vec3:
        t = wp.vec3(1.0, 1.0, 1.0)
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
            c = cross_layer(scene, occ, q.face, q.u, q.v, q.normal, o, d, max_t, t)
            t = c.transmittance
            if not c.going:
                return t
            origin = c.origin
            remaining = c.remaining
        return t

    return layered_transmittance


def _make_transmittance_func(layered: bool, cutouts: bool, wide: bool):
    """``ray_transmittance(scene, occ, o, d, max_t)``: any-hit against the opaque
    BVH, then (``layered``) the ordered walk (``_make_walk_func``); ``wide``: through
    their 4-wide copies."""
    layered_transmittance = _make_walk_func(cutouts, wide)

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
        return layered_transmittance(scene, occ, o, d, max_t)

    return ray_transmittance


@wp.struct
class ShadowRay:
    """One shadow ray toward a light sample: origin, unit direction and length; ``ok``
    False where the sample leaves on the unlit side (no ray)."""

    o: wp.vec3
    d: wp.vec3
    max_t: float
    ok: bool


@wp.func
def shadow_ray(
    light: LightGPU,
    wi: wp.vec3,
    distance: float,
    p: wp.vec3,
    ng: wp.vec3,
    bound: float,
    transmissive: bool,
    sampled: bool,
    r1: float,
    r2: float,
) -> ShadowRay:
    """The shadow ray from ``p`` (geometric normal ``ng``, ``bound`` its ``hit_bound``)
    toward the light's centre (direction ``wi``, ``distance`` away: its ``LightSample``'s),
    or with ``sampled`` toward the point ``r1, r2`` of it (``sample_light_ray``); a ray
    leaving below ``ng`` is none unless the point is ``transmissive`` (it then leaves
    through the far side)."""
    r = ShadowRay()
    r.d = wi
    length = center_ray_length(light, distance)
    if sampled:
        ray = sample_light_ray(light, p, wi, distance, r1, r2)
        r.d = wp.vec3(ray[0], ray[1], ray[2])
        length = ray[3]
    side = ng
    r.ok = True
    if wp.dot(r.d, ng) <= 0.0:
        if not transmissive:
            r.ok = False
            return r
        side = -ng
    r.o = offset_ray_origin(p, side, bound)
    r.max_t = length - wp.dot(r.o - p, r.d)
    return r


@wp.func
def shadow_rng(params: TraceParams, light_index: int, segment: int, pixel: int) -> wp.uint32:
    """The soft-shadow random stream of a pixel's rays toward one light (``segment``: 0
    for the primary hit, the path segment for a secondary one)."""
    return wp.rand_init(params.seed + light_index * 7919 + segment * 104729, pixel)


@wp.func
def shadow_sample_count(params: TraceParams, light: LightGPU, soft: bool) -> int:
    """Shadow rays toward ``light`` from one point: ``params.shadow_samples`` for a light
    with an extent in a soft-shadow variant, else one."""
    if soft:
        if light_has_extent(light):
            return params.shadow_samples
    return 1


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
        samples = shadow_sample_count(params, light, soft)
        rng = shadow_rng(params, light_index, segment, pixel)
        total = wp.vec3(0.0, 0.0, 0.0)
        for _s in range(samples):
            r1 = float(0.0)
            r2 = float(0.0)
            if wp.static(soft):
                if samples > 1:
                    r1 = wp.randf(rng)
                    r2 = wp.randf(rng)
            ray = shadow_ray(light, ls.wi, ls.distance, p, ng, bound, transmissive, samples > 1, r1, r2)
            if not ray.ok:
                continue
            total += ray_transmittance(scene, occ, ray.o, ray.d, ray.max_t)
            out.rays += 1
        if out.rays > 0:
            out.transmittance = total / float(out.rays)
        return out

    return light_transmittance


#: Pixels a launch item of the 4-wide variant's primary shadow kernel takes: one packet
#: of ``wide_any_hit_packet``.
SHADOW_GROUP = PACKET
_group_vec3s = wp.types.matrix(shape=(SHADOW_GROUP, 3), dtype=wp.float32)
_group_floats = wp.types.vector(length=SHADOW_GROUP, dtype=wp.float32)
_group_ints = wp.types.vector(length=SHADOW_GROUP, dtype=wp.int32)
_group_states = wp.types.vector(length=SHADOW_GROUP, dtype=wp.uint32)
#: Per pixel of a group, where a light is as it sees it: ``wi``, the distance, and 1 where
#: the light reaches it (``_reach_group``).
_group_reach = wp.types.matrix(shape=(SHADOW_GROUP, 5), dtype=wp.float32)


@wp.func_native(
    cpp("light_sample", "light_reaches")
    + f"""
const bool has_cone = wh_has_cone(light);
const float cos_inner = has_cone ? wh_cone_inner(light) : 0.0f;
wp::mat_t<{SHADOW_GROUP}, 5, float> out;
auto lane = [&](const int kind, const int j) WH_INLINE {{
    const wp::vec3 p(ps.data[j][0], ps.data[j][1], ps.data[j][2]);
    const wp::vec3 n(ns.data[j][0], ns.data[j][1], ns.data[j][2]);
    wp::vec3 wi, e_normal, irradiance;
    float distance;
    wh_light_sample(light, kind, has_cone, cos_inner, p, n, false, WH_RECT_ONE, wi, distance, e_normal, irradiance);
    const bool reaches = wh_light_reaches(irradiance, e_normal, n, wi);
    out.data[j][0] = wi[0]; out.data[j][1] = wi[1]; out.data[j][2] = wi[2];
    out.data[j][3] = distance;
    out.data[j][4] = reaches && live[j] >= 0 ? 1.0f : 0.0f;
}};
if (light.kind == WH_DISTANT) {{
    for (int j = 0; j < {SHADOW_GROUP}; ++j) lane(WH_DISTANT, j);
}} else if (light.kind == WH_SPHERE) {{
    for (int j = 0; j < {SHADOW_GROUP}; ++j) lane(WH_SPHERE, j);
}} else if (light.kind == WH_RECT) {{
    for (int j = 0; j < {SHADOW_GROUP}; ++j) lane(WH_RECT, j);
}} else {{
    for (int j = 0; j < {SHADOW_GROUP}; ++j) lane(light.kind, j);
}}
return out;
"""
)
def _reach_group(light: LightGPU, ps: _group_vec3s, ns: _group_vec3s, live: _group_ints) -> _group_reach:
    """Row ``j``: ``reach_sample(light, ps[j], ns[j])``'s ``wi`` and distance, and 1 where
    ``light_reaches`` says the light reaches pixel ``j`` and ``live[j] >= 0`` (0 elsewhere);
    every pixel of the group at once, the light's kind decided once, the same lambdas as
    the scalar functions (so the same values)."""
    ...


@wp.func
def crossed(transmittance: wp.vec3) -> bool:
    """Whether a transmittance is partial (some light let through, not all of it): what a
    ray that crossed a transmissive or blended surface keeps (or soft shadows' average)."""
    top = max3(transmittance)
    return top > 0.0 and top < 1.0


def _make_packet_walk_func(cutouts: bool):
    """``packet_transmittance(scene, occ, o, d, max_t, walking)``: ``_make_walk_func``'s
    ordered walk (its 4-wide copy) for the rays of a group at once: row j the
    transmittance of ray ``o[j] + t d[j]``, ``0 <= t < max_t[j]``, for each ray whose bit
    is set in ``walking`` (1 for the others).  Each layer's nearest hits of the rays still
    walking are one ``wide_closest_packet`` (each ray's hit ``wide_closest``'s, bit for
    bit), and each ray's crossing is the single walk's arithmetic, so every ray gets what
    the single walk gives it: rays toward one light from neighbouring pixels cross the
    same layers through the same nodes."""

    cross_layer = _make_crossing_func(cutouts)

    @wp.func
    def packet_transmittance(
        scene: SceneGPU, occ: OccluderGPU, o: _group_vec3s, d: _group_vec3s, max_t: _group_floats, walking: int
    ) -> _group_vec3s:
        out = _group_vec3s()
        origin = _group_vec3s()
        remaining = _group_floats()  # 0: the ray's walk is over (none in the packet)
        live = walking
        for j in range(SHADOW_GROUP):
            out[j] = wp.vec3(1.0, 1.0, 1.0)
            if ((live >> j) & 1) != 0:
                origin[j] = o[j]
                remaining[j] = max_t[j]
        for _layer in range(MAX_LAYERS):
            if live == 0:
                return out
            hits = wide_closest_packet(occ.special_wide, origin, d, remaining)
            for j in range(SHADOW_GROUP):
                if ((live >> j) & 1) != 0:
                    q = hit_from_row(hits[j])
                    stop = not q.result
                    if not stop:
                        c = cross_layer(scene, occ, q.face, q.u, q.v, q.normal, o[j], d[j], max_t[j], out[j])
                        out[j] = c.transmittance
                        stop = not c.going
                        if not stop:
                            origin[j] = c.origin
                            remaining[j] = c.remaining
                    if stop:
                        live = live & ~(1 << j)
                        remaining[j] = 0.0
        return out

    return packet_transmittance


def shadow_launch(wide: bool, first: int, items: int) -> tuple[int, tuple[int, int]]:
    """The launch dimension and trailing inputs of ``shadow_kernel(..., wide)`` for the list
    items ``first`` to ``first + items``: one thread an item, ``(start, step)``; for the
    4-wide variant one thread a group of ``SHADOW_GROUP`` items, ``(start, end)``."""
    if wide:
        return -(-items // SHADOW_GROUP), (first, first + items)
    return items, (first, 1)


@functools.lru_cache(maxsize=None)
def shadow_kernel(layered: bool, soft: bool, cutouts: bool, wide: bool) -> wp.Kernel:
    """The primary shadow kernel for one flag tuple (its own Warp module, cached).

    Inputs: scene, the call's ``TraceFrame`` (its transmittance rows and count column 0
    are written), visibility (H, W, L) out, the still view's cache (``shadow_cache``:
    a pixel's entry of the current generation is reused, a traced pixel's stored), then
    the two integers of ``shadow_launch``.  The 4-wide variant (``wide``) traces the
    opaque any-hits of ``SHADOW_GROUP`` consecutive pixels as one packet per light and
    sample (``wide_any_hit_packet``: neighbouring pixels' rays toward one light share the
    nodes they visit), the same answers as one at a time."""
    if wide:
        return _packet_shadow_kernel(layered, soft, cutouts)
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
        if _reuse_cached(scene, tf, visibility, cache, item, x, y):
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
            _store(tf, visibility, cache, item, x, y, i, r.transmittance)
            rays += r.rays
        cache.stamp[y, x] = cache.generation
        tf.counts[item, 0] = rays

    return trace_shadow


@wp.func
def _reuse_cached(
    scene: SceneGPU,
    tf: TraceFrame,
    visibility: wp.array3d(dtype=wp.float32),
    cache: ShadowCacheGPU,
    item: int,
    x: int,
    y: int,
) -> bool:
    """Where the still view's cache holds pixel (x, y)'s transmittances of this
    generation: copy them to list item ``item`` and the visibility AOV (no rays)."""
    if cache.reuse == 0 or cache.stamp[y, x] != cache.generation:
        return False
    for i in range(scene.light_count):
        kept = cache.transmittance[y, x, i]
        tf.transmittance[item, i] = kept
        visibility[y, x, i] = wp.clamp(luma709(kept), 0.0, 1.0)
    tf.counts[item, 0] = 0
    return True


@wp.func
def _store(
    tf: TraceFrame,
    visibility: wp.array3d(dtype=wp.float32),
    cache: ShadowCacheGPU,
    item: int,
    x: int,
    y: int,
    light_index: int,
    transmittance: wp.vec3,
):
    """Write list item ``item`` (pixel x, y)'s transmittance toward light ``light_index``
    to the call's rows, the cache and the visibility AOV."""
    tf.transmittance[item, light_index] = transmittance
    cache.transmittance[y, x, light_index] = transmittance
    visibility[y, x, light_index] = wp.clamp(luma709(transmittance), 0.0, 1.0)


def _packet_shadow_kernel(layered: bool, soft: bool, cutouts: bool) -> wp.Kernel:
    """``shadow_kernel``'s 4-wide variant: per launch item the list items ``start +
    tid * SHADOW_GROUP`` on (before ``end``); per light and sample their rays
    (``shadow_ray``, as ``light_transmittance`` builds them, in the same order, from the
    same random streams) go through the opaque BVH as one packet, the unblocked ones
    (``layered``) through the BVH of the transmissive, cut-out and blended surfaces as a
    second packet, and the rays that meet one of those through the ordered walk as packets
    (``_make_packet_walk_func``); or, where the group crossed glass when last traced
    (``crossed`` of the cache's transmittance at the group's two ends), every unblocked ray
    through the walk at once (its first layer misses for the rays that meet nothing: they
    keep 1), so every pixel gets what the one-at-a-time kernel gives it, whichever way."""
    packet_transmittance = _make_packet_walk_func(cutouts)

    # (the loops over the group's lanes stay loops: unrolled eight ways the kernel was 81 kB
    # of machine code, 44 kB as loops, and 13-17% slower; a core's instruction cache is 32 kB)
    @wp.kernel(enable_backward=False, module="unique", module_options={"max_unroll": SHADOW_GROUP - 1})
    def trace_shadow_packets(
        scene: SceneGPU,
        tf: TraceFrame,
        visibility: wp.array3d(dtype=wp.float32),
        cache: ShadowCacheGPU,
        start: int,
        end: int,
    ):
        first = start + wp.tid() * SHADOW_GROUP
        # the group's pixels: -1 where no ray leaves (past the list, a miss, a cached pixel)
        xs = _group_ints()
        ys = _group_ints()
        rays = _group_ints()
        for j in range(SHADOW_GROUP):
            xs[j] = -1
            item = first + j
            if item < end:
                xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
                if xy[0] >= 0 and tf.gb.triangle_id[xy[1], xy[0]] >= 0:
                    if not _reuse_cached(scene, tf, visibility, cache, item, xy[0], xy[1]):
                        xs[j] = xy[0]
                        ys[j] = xy[1]
        # what each pixel's rays leave from, read once: point, normals, side; the error
        # bound (its triangle's corners) once a light reaches the pixel
        ps = _group_vec3s()
        ns = _group_vec3s()
        ngs = _group_vec3s()
        bounds = _group_floats()
        bounded = _group_ints()
        through = _group_ints()  # 1: transmissive, its rays may leave through the far side
        for j in range(SHADOW_GROUP):
            if xs[j] >= 0:
                ps[j] = tf.gb.position[ys[j], xs[j]]
                ns[j] = tf.gb.normal[ys[j], xs[j]]
                ngs[j] = tf.gb.geometric_normal[ys[j], xs[j]]
                mid = tf.gb.material_id[ys[j], xs[j]]
                through[j] = wp.where((scene.materials[mid].flags & FLAG_TRANSMISSIVE) != 0, 1, 0)
        for i in range(scene.light_count):
            light = scene.lights[i]
            samples = shadow_sample_count(tf.params, light, wp.static(soft))
            total = _group_vec3s()
            taken = _group_ints()
            states = _group_states()
            # per pixel, the light's centre as it sees it (no rays where the light cannot reach)
            wis = _group_vec3s()
            distances = _group_floats()
            reaches = _group_ints()
            reach = _reach_group(light, ps, ns, xs)
            crossed_lately = bool(False)
            if wp.static(layered):
                for j in range(0, SHADOW_GROUP, SHADOW_GROUP - 1):  # (the group's two ends)
                    if xs[j] >= 0:
                        if crossed(cache.transmittance[ys[j], xs[j], i]):
                            crossed_lately = True
            for j in range(SHADOW_GROUP):
                if xs[j] >= 0:
                    states[j] = shadow_rng(tf.params, i, 0, ys[j] * tf.cam.width + xs[j])
                    if reach[j, 4] != 0.0:
                        reaches[j] = 1
                        wis[j] = wp.vec3(reach[j, 0], reach[j, 1], reach[j, 2])
                        distances[j] = reach[j, 3]
                        if bounded[j] == 0:
                            bounds[j] = hit_bound(scene, tf.gb.triangle_id[ys[j], xs[j]])
                            bounded[j] = 1
            for _s in range(samples):
                o = _group_vec3s()
                d = _group_vec3s()
                max_t = _group_floats()  # 0: no ray in the packet
                ok = _group_ints()
                for j in range(SHADOW_GROUP):
                    if reaches[j] != 0:
                        r1 = float(0.0)
                        r2 = float(0.0)
                        if wp.static(soft):
                            if samples > 1:
                                state = states[j]
                                r1 = wp.randf(state)
                                r2 = wp.randf(state)
                                states[j] = state
                        ray = shadow_ray(
                            light, wis[j], distances[j], ps[j], ngs[j], bounds[j], through[j] != 0, samples > 1, r1, r2
                        )
                        if ray.ok:
                            ok[j] = 1
                            o[j] = ray.o
                            d[j] = ray.d
                            max_t[j] = ray.max_t
                blocked = int(0)
                if tf.occ.opaque != wp.uint64(0):
                    blocked = wide_any_hit_packet(tf.occ.opaque_wide, o, d, max_t)
                # the unblocked rays that walk through the transmissive, cut-out and blended
                # surfaces: those that meet one at all (the walk's first query finds nothing
                # for the others: they keep 1), or, where the group's pixels crossed one
                # lately (``crossed_lately``), every unblocked ray, whose first layer's
                # nearest hits then tell which do, without the any-hit pass first
                walking = int(0)
                if wp.static(layered):
                    if tf.occ.special != wp.uint64(0):
                        open_t = _group_floats()  # 0 for a blocked ray: none in the packet
                        for j in range(SHADOW_GROUP):
                            if ((blocked >> j) & 1) == 0 and max_t[j] > 0.0:
                                open_t[j] = max_t[j]
                                if crossed_lately:
                                    walking = walking | (1 << j)
                        if not crossed_lately:
                            walking = wide_any_hit_packet(tf.occ.special_wide, o, d, open_t)
                walked = _group_vec3s()
                if walking != 0:
                    walked = packet_transmittance(scene, tf.occ, o, d, max_t, walking)
                for j in range(SHADOW_GROUP):
                    if ok[j] != 0:
                        t = wp.vec3(1.0, 1.0, 1.0)
                        if max_t[j] > 0.0:
                            if ((blocked >> j) & 1) != 0:
                                t = wp.vec3(0.0, 0.0, 0.0)
                            elif ((walking >> j) & 1) != 0:
                                t = walked[j]
                        total[j] = total[j] + t
                        taken[j] = taken[j] + 1
            for j in range(SHADOW_GROUP):
                if xs[j] >= 0:
                    transmittance = wp.vec3(0.0, 0.0, 0.0)
                    if taken[j] > 0:
                        transmittance = total[j] / float(taken[j])
                    _store(tf, visibility, cache, first + j, xs[j], ys[j], i, transmittance)
                    rays[j] = rays[j] + taken[j]
        for j in range(SHADOW_GROUP):
            if xs[j] >= 0:
                cache.stamp[ys[j], xs[j]] = cache.generation
                tf.counts[first + j, 0] = rays[j]

    return trace_shadow_packets
