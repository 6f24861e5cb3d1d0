"""The path loop: the traced radiance of a pixel (stage "trace_secondary").

``path_kernel(variant)`` runs over a compacted pixel list (a grouped kernel,
``parallel.group_launch``: on the CPU a launch item takes a group of consecutive items;
each item writes only its own pixel and its own row of the scratch arrays).  Per pixel,
the primary point from the G-buffer is shaded with the transmittances the shadow
kernel left (``shadows.py``; the lights' sum over them computed for the launch item's
whole group at once, vectorised across its pixels: ``primary_light.py``), then an iterative path of reflection and refraction rays
(no recursion) whose hits are shaded the same way, with their own shadow rays.  On the
CPU (the 4-wide variant) a launch item first takes its group's paths to their primary
points (``begin_item``), finds the first ray of each as packets of ``PACKET``
(``wide_bvh.wide_closest_packet``: neighbouring pixels' reflections and refractions visit
the same nodes; the same hits as one query a ray, bit for bit), then takes each path on
from that hit (``finish_item``).  A
secondary hit reads its textures' mip chains over its pixel's ray cone (``cone.py``),
as the G-buffer reads them over the pixel's footprint.

Shading of a hit (primary or secondary) at depth d < max_depth (``shade_hit``):
emission + sum of T_i x direct_light + the diffuse ambient (dome SH, and the lights'
indirect estimate where it is on: ``lighting/ambient.ambient_diffuse``), plus

* a reflection ray (``optics.mirror_direction``) when the material is smooth
  (roughness < ``SMOOTH_ROUGHNESS``, the rule the feature analysis uses too) and
  reflective, weighted by the split-sum ``env_brdf`` for opaque materials and by the
  exact Fresnel F for transmissive ones, times ``mirror_share``: 1 up to
  ``GLOSSY_ROUGHNESS``, fading to 0 at ``SMOOTH_ROUGHNESS`` while the prefiltered dome
  term takes the rest (no speckle where a roughness texture crosses the cut); rougher
  surfaces keep the prefiltered dome term alone; total internal reflection is whole;
* for transmissive materials a transmission ray (``optics``);
* for alpha-blended ones (``FLAG_BLENDED``, coverage ``alpha`` = the opacity): the hit
  shaded as an opaque surface (its reflection ray too) times ``alpha``, and a ray
  straight on through it, untinted, weighted ``1 - alpha``.

At d = max_depth the hit gets the raster shading (prefiltered dome reflection, the
raster transmission approximation; an alpha-blended hit shows the dome through its
uncovered share) with traced shadows.  A secondary hit skips the
shadow ray (and the light) where the light's unshadowed contribution to the pixel is
below ``MIN_THROUGHPUT`` times E / pi (what the light gives a white Lambertian surface
facing it): e.g. the near-delta highlights of clear glass.

Branching: a dielectric spawns two rays; the path follows the heavier one and pushes
the other on a small per-pixel stack (``PathStack``: depth-first, at most
``MAX_DEPTH`` entries), so both branches reach full depth.  Branches whose throughput
drops below ``MIN_THROUGHPUT`` (max RGB component) are not traced.  Escaping rays and
background pixels get ``environment_radiance`` (black without a dome).
"""

from __future__ import annotations

import functools

import warp as wp

from ..core.constants import INV_PI, SMOOTH_ROUGHNESS, mirror_share
from ..core.gbuffer import GBufferArrays
from ..core.pixel_list import listed_pixel
from ..core.scene_gpu import FLAG_BLENDED, FLAG_REFRACTIVE, FLAG_TRANSMISSIVE, AmbientGPU, SceneGPU
from ..lighting.ambient import ambient_diffuse, ambient_specular, env_brdf
from ..lighting.lights import light_sample
from ..lighting.shading import diffuse_albedo, light_response, shade_surface
from ..parallel import ITEM_GROUP
from ..scene.device.environment import environment_radiance
from ..scene.device.surface import SurfaceHit, is_cut_away, samples_textures, surface_at_grad
from ..scene.device.wide_bvh import PACKET, WideHit, hit_from_row, wide_closest, wide_closest_packet
from .background import GroupDirections, GroupFlags, GroupHits, GroupRadiance, first_ray_sky, group_background
from .cone import cone_footprint
from .occluders import OccluderGPU
from .offset import hit_bound, offset_ray_origin
from .optics import make_transmission_func, mirror_direction, transmission_tint
from .primary_dome import HAS_GLOSSY, DomeRow, GroupDome, dome_diffuse, dome_glossy, primary_dome
from .primary_light import GroupDirect, primary_direct
from .rays import MAX_LAYERS, MIN_THROUGHPUT, RayHit, TraceFrame, max3, step_past
from .shadows import make_light_func
from .variant import TraceVariant

MAX_DEPTH = 8

# Ray kinds: the columns of the per-item ray counts (0 primary shadow, 1 secondary
# shadow, 2 reflection, 3 refraction).
COUNT_COLUMNS = 4
KIND_NONE = wp.constant(0)
KIND_REFLECT = wp.constant(2)
KIND_REFRACT = wp.constant(3)

_stack_vec3s = wp.types.matrix(shape=(MAX_DEPTH, 3), dtype=wp.float32)
_stack_ints = wp.types.vector(length=MAX_DEPTH, dtype=wp.int32)
_stack_floats = wp.types.vector(length=MAX_DEPTH, dtype=wp.float32)


@wp.struct
class Ray:
    """A ray still to trace: origin, direction, path weight, the depth of the hit it
    will find, its kind (``KIND_*``; ``KIND_NONE`` = no ray) and the path length from
    the camera to its origin (its pixel cone's, ``cone.py``)."""

    origin: wp.vec3
    direction: wp.vec3
    weight: wp.vec3
    depth: int
    kind: int
    cone_length: float


@wp.struct
class HitShading:
    """What shading one hit gives: radiance already times the path weight, the shadow
    rays it took, and its continuation (``next.kind`` is ``KIND_NONE`` for none)
    plus a second branch to push (``pushed.kind`` likewise)."""

    radiance: wp.vec3
    shadow_rays: int
    next: Ray
    pushed: Ray


@wp.func
def facing_front(scene: SceneGPU, tri: int, d: wp.vec3) -> int:
    """1 when ``d`` meets triangle ``tri`` on the side its winding (counter-clockwise)
    faces, 0 on the back (``SurfaceHit.front_face``)."""
    k = 3 * tri
    p0 = scene.points[scene.indices[k]]
    winding = wp.cross(scene.points[scene.indices[k + 1]] - p0, scene.points[scene.indices[k + 2]] - p0)
    return wp.where(wp.dot(winding, d) > 0.0, 0, 1)


@wp.func
def gbuffer_surface(scene: SceneGPU, gb: GBufferArrays, y: int, x: int) -> SurfaceHit:
    """The primary surface of pixel (x, y) from the G-buffer with ``front_face`` 1: its
    triangle's corners are not fetched (a random read); a caller that reads the side
    sets it (``facing_front``)."""
    h = SurfaceHit()
    h.position = gb.position[y, x]
    h.normal = gb.normal[y, x]
    h.geometric_normal = gb.geometric_normal[y, x]
    h.front_face = 1
    h.albedo = gb.albedo[y, x]
    h.specular = gb.specular[y, x]
    h.emission = gb.emission[y, x]
    opt = gb.optics[y, x]
    h.ior = opt.ior
    h.opacity = opt.opacity
    h.roughness = opt.roughness
    h.material = gb.material_id[y, x]
    h.flags = scene.materials[h.material].flags
    return h


@wp.func
def make_ray(origin: wp.vec3, direction: wp.vec3, weight: wp.vec3, depth: int, kind: int, cone_length: float) -> Ray:
    """A ``Ray`` from its parts."""
    r = Ray()
    r.origin = origin
    r.direction = direction
    r.weight = weight
    r.depth = depth
    r.kind = kind
    r.cone_length = cone_length
    return r


@wp.func
def leaving_origin(ray: Ray, ng: wp.vec3, bound: float) -> wp.vec3:
    """Where ``ray``, spawned at ``ray.origin`` on a surface with geometric normal ``ng``
    (facing against the incoming ray) and ``offset.hit_bound`` ``bound``, leaves it:
    moved off along ``ng`` for a reflection, along ``-ng`` for a ray that goes on
    through (refraction, transmission, an alpha-blended pass-through)."""
    return offset_ray_origin(ray.origin, wp.where(ray.kind == KIND_REFLECT, ng, -ng), bound)


@wp.func
def no_ray() -> Ray:
    """The empty ``Ray`` (``KIND_NONE``)."""
    return make_ray(wp.vec3(0.0), wp.vec3(0.0), wp.vec3(0.0), 0, KIND_NONE, 0.0)


@wp.struct
class PathStart:
    """A pixel's path after its primary point (``begin_item``): ``live`` 0 where nothing is
    left to do (no pixel, or the dome's colour already written), the radiance and shadow
    rays so far, the ray it goes on with (``next``) and the branch on its stack
    (``pushed``), each ``KIND_NONE`` for none."""

    live: int
    radiance: wp.vec3
    shadow_rays: int
    next: Ray
    pushed: Ray


# A ``PathStart`` as a row of floats, so a launch item keeps its group's in one matrix
# (the integers are small: exact as floats): live, shadow rays, radiance, then each ray
# as origin, direction, weight, depth, kind, cone length.
_LIVE = wp.constant(0)
_SHADOW_RAYS = wp.constant(1)
_RADIANCE = wp.constant(2)
_NEXT = wp.constant(5)
_RAY_FLOATS = 12
_PUSHED = wp.constant(_NEXT + _RAY_FLOATS)
_DEPTH = wp.constant(9)
_KIND = wp.constant(10)
_CONE = wp.constant(11)
_START_FLOATS = _PUSHED + _RAY_FLOATS
#: The fewest first rays of a packet worth a packet query (fewer: each its own query).
#: On this machine packets of 2 and of 4 gave the same path-kernel times, and never
#: using them 4-7% more on the staircase, the glass-mirror box and the smoke test
#: (docs/speed_journal.md, "First rays as packets"); 4 keeps sparse groups' scattered rays
#: single.
_PACKET_MIN = wp.constant(4)
if ITEM_GROUP % PACKET != 0:
    raise ValueError(f"a launch item's group ({ITEM_GROUP}) must be whole packets of {PACKET}")
_start_floats = wp.types.vector(length=_START_FLOATS, dtype=wp.float32)
_group_starts = wp.types.matrix(shape=(ITEM_GROUP, _START_FLOATS), dtype=wp.float32)
#: A packet's ray origins or directions, and its rays' lengths (0: no ray in the lane).
_packet_vec3s = wp.types.matrix(shape=(PACKET, 3), dtype=wp.float32)
_packet_floats = wp.types.vector(length=PACKET, dtype=wp.float32)


@wp.func
def _put_ray(row: _start_floats, at: int, r: Ray) -> _start_floats:
    """``row`` with ray ``r`` written from column ``at``."""
    out = row
    for k in range(3):
        out[at + k] = r.origin[k]
        out[at + 3 + k] = r.direction[k]
        out[at + 6 + k] = r.weight[k]
    out[at + _DEPTH] = float(r.depth)
    out[at + _KIND] = float(r.kind)
    out[at + _CONE] = r.cone_length
    return out


@wp.func(inline=True)
def _get_ray(row: _start_floats, at: int) -> Ray:
    """The ray written from column ``at`` of ``row``."""
    return make_ray(
        wp.vec3(row[at], row[at + 1], row[at + 2]),
        wp.vec3(row[at + 3], row[at + 4], row[at + 5]),
        wp.vec3(row[at + 6], row[at + 7], row[at + 8]),
        int(row[at + _DEPTH]),
        int(row[at + _KIND]),
        row[at + _CONE],
    )


@wp.func
def _start_row(st: PathStart) -> _start_floats:
    """``st`` as a row of floats (``_row_start`` reads it back)."""
    row = _start_floats()
    row[_LIVE] = float(st.live)
    row[_SHADOW_RAYS] = float(st.shadow_rays)
    for k in range(3):
        row[_RADIANCE + k] = st.radiance[k]
    row = _put_ray(row, _NEXT, st.next)
    return _put_ray(row, _PUSHED, st.pushed)


# (``_get_ray`` and ``_row_start`` inline: out of line, each read of a row's copy waited
# on the copy's stores, a failed store-to-load forward that the line profile put at 12%
# of Suzanne's path kernel; inline, the reads come from the group's matrix itself)
@wp.func(inline=True)
def _row_start(row: _start_floats) -> PathStart:
    """The ``PathStart`` of a ``_start_row`` row."""
    st = PathStart()
    st.live = int(row[_LIVE])
    st.shadow_rays = int(row[_SHADOW_RAYS])
    st.radiance = wp.vec3(row[_RADIANCE], row[_RADIANCE + 1], row[_RADIANCE + 2])
    st.next = _get_ray(row, _NEXT)
    st.pushed = _get_ray(row, _PUSHED)
    return st


@functools.lru_cache(maxsize=None)
def path_kernel(variant: TraceVariant) -> wp.Kernel:
    """The path kernel for one variant (its own Warp module, cached).

    Inputs: scene, amb, the call's ``TraceFrame`` (transmittance rows from the shadow
    kernel; count columns 1-3 are written), color (H, W) out, then ``start, stop, group``
    (``parallel.group_launch``)."""
    light_transmittance = make_light_func(
        variant.layered_shadows, variant.soft_shadows, variant.cutouts, variant.wide_bvh
    )
    transmission = make_transmission_func(variant.refractions)
    refractions = variant.refractions
    shadows = variant.shadows
    reflections = variant.reflections
    transparency = variant.transparency
    blending = variant.blending
    environment = variant.environment
    ambient = variant.ambient
    cutouts = variant.cutouts
    secondary = variant.secondary
    wide = variant.wide_bvh

    @wp.func
    def closest_hit(
        scene: SceneGPU, occ: OccluderGPU, o: wp.vec3, d: wp.vec3, first: WideHit, first_found: bool
    ) -> RayHit:
        """The nearest hit of the ray from ``o`` along ``d`` that is not cut away; with
        ``first_found`` (the 4-wide variant) ``first`` is its first query's answer."""
        out = RayHit()
        out.face = -1
        origin = o
        given = first_found
        for _layer in range(MAX_LAYERS):
            if wp.static(wide):
                q = first
                if not given:
                    q = wide_closest(occ.scene_wide, origin, d, wp.inf)
                given = False
            else:
                q = wp.mesh_query_ray(scene.mesh, origin, d, wp.inf)
            if not q.result:
                return out
            if wp.static(cutouts):
                if is_cut_away(scene, q.face, q.u, q.v):
                    origin = step_past(scene, q.face, q.u, q.v, q.normal, d)
                    continue
            out.face = q.face
            out.u = q.u
            out.v = q.v
            return out
        return out

    # Inline (its one call site is the path loop): Warp passes struct arguments by value,
    # and where clang kept this body out of line (the variants with glass and a dome, whose
    # body is biggest) each call copied the ~2.8 KB of scene, ambient and frame arguments;
    # the smoke test's path kernel took 1.7x as long (docs/speed_journal.md, "`shade_hit` inline").
    @wp.func(inline=True)
    def shade_hit(
        scene: SceneGPU,
        amb: AmbientGPU,
        tf: TraceFrame,
        item: int,
        pixel: int,
        segment: int,
        h: SurfaceHit,
        bound: float,
        d: wp.vec3,
        weight: wp.vec3,
        depth: int,
        cone_length: float,
        can_push: bool,
        primary_direct: wp.vec3,
        primary_dome: DomeRow,
    ) -> HitShading:
        """Shade hit ``h`` seen along ``d`` with path ``weight`` at ``depth``,
        ``cone_length`` from the camera along the path (what its rays carry on); segment
        0 (the primary point) takes ``primary_direct``, its lights' sum over the shadow
        kernel's transmittances (``primary_light.primary_direct``), and its dome terms from
        ``primary_dome`` (``primary_dome.primary_dome``'s row; the glossy one where the row
        has it), a secondary hit
        traces its shadow rays from its triangle's ``offset.hit_bound`` ``bound``.  The
        continuation rays start at ``h.position`` itself: the caller moves them off the
        surface (``leaving_origin``).  Two branches split only when ``can_push`` (room on
        the stack); otherwise the reflection goes on."""
        zero = wp.vec3(0.0, 0.0, 0.0)
        out = HitShading()
        out.shadow_rays = 0
        out.next = no_ray()
        out.pushed = no_ray()
        v = -d
        n = h.normal
        ng = h.geometric_normal
        transmissive = False
        if wp.static(transparency):
            transmissive = (h.flags & FLAG_TRANSMISSIVE) != 0
        coverage = float(1.0)
        if wp.static(blending):
            if (h.flags & FLAG_BLENDED) != 0:
                coverage = h.opacity
        traced = depth < tf.params.max_depth
        kd = h.albedo
        if traced:
            if transmissive:
                kd = h.albedo * h.opacity
        else:
            kd = diffuse_albedo(scene, n, v, h.albedo, h.opacity, h.ior, h.flags)
        direct = wp.vec3(0.0, 0.0, 0.0)
        if wp.static(shadows):
            if segment == 0:
                direct = primary_direct
            else:
                for i in range(scene.light_count):
                    ls = light_sample(scene.lights[i], h.position, n)
                    c = light_response(ls, n, v, kd, h.specular, h.roughness)
                    tr = wp.vec3(0.0, 0.0, 0.0)
                    if max3(wp.cw_mul(weight, c)) >= MIN_THROUGHPUT * INV_PI * max3(ls.e_normal):
                        r = light_transmittance(
                            scene, tf.params, tf.occ, i, ls, h.position, n, ng, bound, transmissive, pixel, segment
                        )
                        tr = r.transmittance
                        out.shadow_rays += r.rays
                    direct += wp.cw_mul(c, tr)
        if not traced:
            c = h.emission + direct
            if wp.static(ambient):
                c = shade_surface(
                    scene,
                    amb,
                    n,
                    v,
                    h.albedo,
                    kd,
                    h.specular,
                    h.roughness,
                    h.emission,
                    h.opacity,
                    h.ior,
                    h.flags,
                    direct,
                )
            if wp.static(blending):
                if coverage < 1.0:
                    c = c * coverage
                    if wp.static(environment):
                        c += environment_radiance(scene, d) * (1.0 - coverage)
            out.radiance = wp.cw_mul(weight, c)
            return out
        c = h.emission + direct
        if wp.static(ambient):
            if segment == 0:
                c += dome_diffuse(primary_dome)
            else:
                c += ambient_diffuse(scene, amb, n, v, kd, h.specular)
        glossy = float(0.0)  # the weight of the dome's glossy term (``ambient_specular``)
        # children: a = reflection, b = transmission
        a_w = zero
        a_d = zero
        b_w = zero
        b_d = zero
        share = mirror_share(h.roughness)
        smooth = h.roughness < SMOOTH_ROUGHNESS
        if wp.static(secondary):
            if transmissive:
                tm = transmission(h, d)
                if tm.valid == 0:  # total internal reflection: all of it, whatever the roughness
                    a_w = wp.vec3(tm.fresnel, tm.fresnel, tm.fresnel)
                    a_d = mirror_direction(d, n, ng)
                elif smooth:
                    a_w = wp.vec3(tm.fresnel, tm.fresnel, tm.fresnel) * share
                    a_d = mirror_direction(d, n, ng)
                    if share < 1.0:
                        glossy = 1.0 - share
                else:
                    glossy = 1.0
                if tm.valid != 0:
                    b_w = transmission_tint(h) * (1.0 - tm.fresnel)
                    b_d = tm.direction
            else:
                if wp.static(reflections):
                    if smooth:
                        a_w = env_brdf(amb, h.specular, h.roughness, wp.dot(n, v)) * share
                        a_d = mirror_direction(d, n, ng)
                if max3(a_w) <= 0.0:
                    glossy = 1.0
                elif share < 1.0:
                    glossy = 1.0 - share
        else:
            glossy = 1.0
        if wp.static(environment):
            if glossy > 0.0:  # (times 1 where the whole term is added: the same bits)
                g = wp.vec3(0.0, 0.0, 0.0)
                if segment == 0 and primary_dome[HAS_GLOSSY] != 0.0:
                    g = dome_glossy(primary_dome)
                else:
                    g = ambient_specular(scene, amb, n, v, h.specular, h.roughness)
                c += g * glossy
        if wp.static(blending):
            if coverage < 1.0:  # the covered share as an opaque surface, the rest straight on
                c = c * coverage
                a_w = a_w * coverage
                b_w = wp.vec3(1.0 - coverage, 1.0 - coverage, 1.0 - coverage)
                b_d = d
        out.radiance = wp.cw_mul(weight, c)
        if wp.static(secondary):
            a_w = wp.cw_mul(a_w, weight)
            b_w = wp.cw_mul(b_w, weight)
            a_ok = max3(a_w) >= MIN_THROUGHPUT
            b_ok = max3(b_w) >= MIN_THROUGHPUT
            if a_ok and b_ok and can_push:
                # follow the heavier branch, push the other
                if max3(b_w) > max3(a_w):
                    out.pushed = make_ray(h.position, a_d, a_w, depth + 1, KIND_REFLECT, cone_length)
                    a_ok = False
                else:
                    out.pushed = make_ray(h.position, b_d, b_w, depth + 1, KIND_REFRACT, cone_length)
                    b_ok = False
            if a_ok:
                out.next = make_ray(h.position, a_d, a_w, depth + 1, KIND_REFLECT, cone_length)
            elif b_ok:
                out.next = make_ray(h.position, b_d, b_w, depth + 1, KIND_REFRACT, cone_length)
        return out

    @wp.func(inline=True)
    def begin_item(
        scene: SceneGPU,
        amb: AmbientGPU,
        tf: TraceFrame,
        color: wp.array2d(dtype=wp.vec3),
        item: int,
        primary_direct: wp.vec3,
        primary_dome: DomeRow,
        background: wp.vec3,
    ) -> PathStart:
        """List item ``item``'s path up to its primary point: that point shaded
        (``primary_direct``: its lights' sum; ``primary_dome``: its dome terms) and the
        rays it goes on with; a pixel that
        sees no surface gets ``background``, the dome along its camera ray
        (``background.group_background``; its colour and counts written, ``live`` 0)."""
        out = PathStart()
        out.live = 0
        out.next = no_ray()
        out.pushed = no_ray()
        xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
        x = xy[0]
        y = xy[1]
        if x < 0:
            return out
        pixel = y * tf.cam.width + x
        if tf.gb.triangle_id[y, x] < 0:
            color[y, x] = background
            tf.counts[item, 1] = 0
            tf.counts[item, 2] = 0
            tf.counts[item, 3] = 0
            return out

        d = wp.normalize(tf.gb.position[y, x] - tf.cam.origin)
        face = tf.gb.triangle_id[y, x]
        h = gbuffer_surface(scene, tf.gb, y, x)
        if wp.static(refractions):  # only a refracting surface's side is read (``optics``)
            if (h.flags & FLAG_REFRACTIVE) != 0:
                h.front_face = facing_front(scene, face, d)
        bound = float(0.0)  # the primary point's shadow rays are the shadow kernel's
        cone_length = wp.length(h.position - tf.cam.origin)
        s = shade_hit(
            scene,
            amb,
            tf,
            item,
            pixel,
            0,
            h,
            bound,
            d,
            wp.vec3(1.0, 1.0, 1.0),
            0,
            cone_length,
            True,
            primary_direct,
            primary_dome,
        )
        if s.next.kind != KIND_NONE or s.pushed.kind != KIND_NONE:
            bound = hit_bound(scene, face)  # only now: the corners are a random fetch
        out.live = 1
        out.radiance = wp.vec3(0.0, 0.0, 0.0)
        out.radiance += s.radiance
        out.shadow_rays = s.shadow_rays
        out.next = s.next
        out.next.origin = leaving_origin(s.next, h.geometric_normal, bound)
        if s.pushed.kind != KIND_NONE:
            out.pushed = s.pushed
            out.pushed.origin = leaving_origin(s.pushed, h.geometric_normal, bound)
        return out

    @wp.func(inline=True)
    def finish_item(
        scene: SceneGPU,
        amb: AmbientGPU,
        tf: TraceFrame,
        color: wp.array2d(dtype=wp.vec3),
        item: int,
        start: PathStart,
        first_hit: WideHit,
        first_found: bool,
        first_sky: wp.vec3,
    ):
        """List item ``item``'s path on from ``start`` (``begin_item``): its rays traced
        and their hits shaded, the radiance into ``color`` and the ray counts into
        ``tf.counts``.  With ``first_found`` the first ray's nearest hit is ``first_hit``
        (the group's packet query) instead of a query of its own, and where it misses
        ``first_sky`` is the dome along it (``background.first_ray_sky``)."""
        if start.live == 0:
            return
        xy = listed_pixel(tf.pixels, item, tf.cam.width, tf.cam.height)
        x = xy[0]
        y = xy[1]
        pixel = y * tf.cam.width + x
        radiance = start.radiance
        shadow_rays = start.shadow_rays
        reflect_rays = int(0)
        refract_rays = int(0)
        # PathStack: the pushed branches, one column per field.
        stack_origin = _stack_vec3s()
        stack_direction = _stack_vec3s()
        stack_weight = _stack_vec3s()
        stack_depth = _stack_ints()
        stack_kind = _stack_ints()
        stack_cone = _stack_floats()
        stack_size = int(0)
        if start.pushed.kind != KIND_NONE:
            stack_origin[0] = start.pushed.origin
            stack_direction[0] = start.pushed.direction
            stack_weight[0] = start.pushed.weight
            stack_depth[0] = start.pushed.depth
            stack_kind[0] = start.pushed.kind
            stack_cone[0] = start.pushed.cone_length
            stack_size = 1
        ray = start.next
        segment = int(1)
        have_hit = int(0)
        given = first_found
        h = SurfaceHit()
        bound = float(0.0)
        d = wp.vec3(0.0, 0.0, 0.0)
        weight = wp.vec3(0.0, 0.0, 0.0)
        depth = int(0)
        cone_length = float(0.0)
        while True:
            if have_hit != 0:
                have_hit = 0
                can_push = stack_size < wp.static(MAX_DEPTH)
                s = shade_hit(
                    scene,
                    amb,
                    tf,
                    item,
                    pixel,
                    segment,
                    h,
                    bound,
                    d,
                    weight,
                    depth,
                    cone_length,
                    can_push,
                    wp.vec3(0.0, 0.0, 0.0),
                    DomeRow(),
                )
                segment += 1
                radiance += s.radiance
                shadow_rays += s.shadow_rays
                ray = s.next
                ray.origin = leaving_origin(ray, h.geometric_normal, bound)
                if s.pushed.kind != KIND_NONE:
                    stack_origin[stack_size] = leaving_origin(s.pushed, h.geometric_normal, bound)
                    stack_direction[stack_size] = s.pushed.direction
                    stack_weight[stack_size] = s.pushed.weight
                    stack_depth[stack_size] = s.pushed.depth
                    stack_kind[stack_size] = s.pushed.kind
                    stack_cone[stack_size] = s.pushed.cone_length
                    stack_size += 1
            if wp.static(not secondary):
                break
            if ray.kind == KIND_NONE:
                if stack_size == 0:
                    break
                stack_size -= 1
                ray = make_ray(
                    stack_origin[stack_size],
                    stack_direction[stack_size],
                    stack_weight[stack_size],
                    stack_depth[stack_size],
                    stack_kind[stack_size],
                    stack_cone[stack_size],
                )
            if ray.kind == KIND_REFLECT:
                reflect_rays += 1
            else:
                refract_rays += 1
            hit = closest_hit(scene, tf.occ, ray.origin, ray.direction, first_hit, given)
            was_given = given
            given = False
            if hit.face >= 0:
                footprint = wp.vec4(0.0, 0.0, 0.0, 0.0)
                if samples_textures(scene, hit.face):
                    footprint = cone_footprint(scene, tf.cam, hit.face, ray.origin, ray.direction, ray.cone_length)
                h = surface_at_grad(scene, hit.face, hit.u, hit.v, ray.direction, footprint)
                cone_length = ray.cone_length + wp.length(h.position - ray.origin)
                bound = hit_bound(scene, hit.face)
                d = ray.direction
                weight = ray.weight
                depth = ray.depth
                have_hit = 1
            else:
                if wp.static(environment):
                    sky = first_sky  # (the group's lookup: a first ray the packet query found to miss)
                    if not was_given or first_hit.result:  # (a first hit cut away, a later ray)
                        sky = environment_radiance(scene, ray.direction)
                    radiance += wp.cw_mul(ray.weight, sky)
            ray = no_ray()  # traced: the next comes from this hit or the stack
        color[y, x] = radiance
        tf.counts[item, 1] = shadow_rays
        tf.counts[item, 2] = reflect_rays
        tf.counts[item, 3] = refract_rays

    @wp.kernel(enable_backward=False, module="unique")
    def trace_path(
        scene: SceneGPU,
        amb: AmbientGPU,
        tf: TraceFrame,
        color: wp.array2d(dtype=wp.vec3),
        start: int,
        stop: int,
        group: int,
    ):
        first = start + wp.tid() * group
        last = wp.min(first + group, stop)
        # in chunks of ITEM_GROUP items (one chunk: ``group`` is ITEM_GROUP on the CPU, 1 on CUDA)
        for chunk in range(first, last, ITEM_GROUP):
            chunk_end = wp.min(chunk + ITEM_GROUP, last)
            direct = GroupDirect()
            if wp.static(shadows):
                direct = primary_direct(scene, tf, chunk, chunk_end, transparency)
            terms = GroupDome()
            if wp.static(ambient):
                terms = primary_dome(scene, amb, tf, chunk, chunk_end, transparency, environment)
            dome = GroupRadiance()
            if wp.static(environment):
                dome = group_background(scene, tf, chunk, chunk_end)
            if wp.static(wide and secondary):
                # the chunk's paths up to their primary points, then the first ray of each
                # as packets (neighbouring pixels' reflections and refractions share the
                # nodes they visit), then each path on from its first hit
                starts = _group_starts()
                first_hits = GroupHits()
                first_directions = GroupDirections()
                given = GroupFlags()
                packet_o = _packet_vec3s()
                packet_d = _packet_vec3s()
                for item in range(chunk, chunk_end):
                    starts[item - chunk] = _start_row(
                        begin_item(
                            scene, amb, tf, color, item, direct[item - chunk], terms[item - chunk], dome[item - chunk]
                        )
                    )
                for p in range(wp.static(ITEM_GROUP // PACKET)):
                    packet_t = _packet_floats()  # 0: no ray in the lane
                    rays = int(0)
                    for k in range(PACKET):
                        j = p * PACKET + k
                        if chunk + j < chunk_end:
                            ray = _get_ray(starts[j], _NEXT)
                            if starts[j, _LIVE] != 0.0 and ray.kind != KIND_NONE:
                                packet_o[k] = ray.origin
                                packet_d[k] = ray.direction
                                first_directions[j] = ray.direction
                                packet_t[k] = wp.inf
                                rays += 1
                    if rays >= _PACKET_MIN:
                        found = wide_closest_packet(tf.occ.scene_wide, packet_o, packet_d, packet_t)
                        for k in range(PACKET):
                            if packet_t[k] > 0.0:
                                first_hits[p * PACKET + k] = found[k]
                                given[p * PACKET + k] = 1
                sky = GroupRadiance()
                if wp.static(environment):
                    sky = first_ray_sky(scene, first_directions, first_hits, given)
                for item in range(chunk, chunk_end):
                    j = item - chunk
                    finish_item(
                        scene,
                        amb,
                        tf,
                        color,
                        item,
                        _row_start(starts[j]),
                        hit_from_row(first_hits[j]),
                        given[j] != 0,
                        sky[j],
                    )
            else:
                for item in range(chunk, chunk_end):
                    st = begin_item(
                        scene, amb, tf, color, item, direct[item - chunk], terms[item - chunk], dome[item - chunk]
                    )
                    finish_item(scene, amb, tf, color, item, st, WideHit(), False, wp.vec3(0.0, 0.0, 0.0))

    return trace_path
