"""The tracing kernels: one factory, one Warp module per specialisation.

Two kernels run over a compacted list of pixels (item ``start + tid * step`` of
``pixels``, each item writes only its own pixel and its own row of the scratch
arrays, so threads never collide):

* ``shadow`` (stage "trace_shadow"): per light, the RGB transmittance from the
  G-buffer point to the light, into ``transmittance[item, light]`` and its luminance
  into the visibility AOV.
* ``shade`` (stage "trace_secondary"): the traced radiance of the pixel: the primary
  point shaded with those transmittances, then an iterative path of reflection and
  refraction rays (no recursion) whose hits are shaded the same way, with their own
  shadow rays.

``TraceVariant`` holds the ``wp.static`` flags; ``shadow_kernel`` and ``shade_kernel``
build (and cache) one kernel per flag tuple, each in its own Warp module
(``module="unique"``), so a scene compiles only the code its features need: no
reflection rays without reflective materials, no transmission/refraction code
without transmissive/refractive ones, no dome lookups without a dome, no ordered
shadow walk (only the any-hit query) when every surface is opaque and none emits.

Rules (the README states them):

* Ray origins: ``offset.offset_ray_origin`` (Ray Tracing Gems ch. 6, scale-aware),
  along the geometric normal, to the far side for transmission.
* Shadow rays: hard from the light's centre (``shadow_samples`` = 1) or N samples
  over the light's sphere/rect/disk/cone (soft, the average over the samples that
  leave on the lit side); they stop at a sphere light's surface, just short
  (``LIGHT_END``) of a rect/disk light's point and pass through emissive surfaces
  (the emitter geometry of area lights) and cut-out holes.  Each is an any-hit query
  against the opaque triangles, then, if unblocked, an ordered walk through the
  transmissive/cut-out/emissive ones (``trace/occluders.py``).  At each crossing
  of a transmissive surface the transmittance is multiplied by
  ``(1 - opacity) (1 - F)`` with F the exact dielectric Fresnel reflectance for the
  material's IOR at the crossing angle (air-to-glass at every crossing: by
  reciprocity this is the reflectance a refracted ray would meet), and by the tint
  (the diffuse colour) once per passage: on every crossing of a thin-walled or
  non-refracting surface, on entering (front-face) crossings of a solid dielectric.
  The first opaque surface stops the ray (transmittance 0).  Straight lines, no
  caustics.  A light the point cannot see at all (below its horizon, outside a
  spot cone, or behind the geometric surface of an opaque point) gets 0, no ray.
* Shading of a hit (primary or secondary) at depth d < max_depth: emission + sum of
  T_i x direct_light + dome SH diffuse, plus
  - a reflection ray (mirror direction about the shading normal) when the material
    is smooth (roughness < ``ROUGH_REFLECTION``) and reflective, weighted by the
    split-sum ``env_brdf`` for opaque materials and by the exact Fresnel F for
    transmissive ones; rougher surfaces keep the raster prefiltered dome term;
  - for transmissive materials a transmission ray weighted ``(1 - opacity) (1 - F)``
    times the tint (once per passage, as for shadows): refracted by Snell's law
    with relative IOR ``ior`` entering (front face) and ``1 / ior`` leaving, total
    internal reflection when F = 1; straight through for thin-walled surfaces.
  At d = max_depth the hit gets the raster shading (prefiltered dome reflection,
  the raster transmission approximation) with traced shadows.  A secondary hit
  skips the shadow ray (and the light) where the light's unshadowed contribution
  to the pixel is below ``MIN_THROUGHPUT`` times E / pi (what the light gives a
  white Lambertian surface facing it): e.g. the near-delta highlights of clear glass.
* Branching: a dielectric spawns two rays; the path follows the heavier one and
  pushes the other on a small per-pixel stack (depth-first, at most ``max_depth``
  entries), so both branches reach full depth.  Branches whose throughput drops
  below ``MIN_THROUGHPUT`` (max RGB component) are not traced.
* Escaping rays and background pixels get ``environment_radiance`` (black without a
  dome).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import warp as wp

from ..lighting.ambient import AmbientGPU, ambient_diffuse, ambient_specular, env_brdf
from ..lighting.brdf import INV_PI, fresnel_dielectric, luma709
from ..lighting.deferred import camera_ray_direction
from ..lighting.lights import KIND_DISTANT, KIND_RECT, KIND_SPHERE, LightSample, light_sample
from ..lighting.shading import diffuse_albedo, light_response, shade_surface
from ..raster.kernels import GBufferArrays
from ..scene.device import FLAG_CUTOUT, FLAG_REFRACTIVE, FLAG_TRANSMISSIVE, CameraGPU, LightGPU, SceneGPU
from ..scene.environment import environment_radiance
from ..scene.surface import SurfaceHit, is_cut_away, surface_at
from .offset import offset_ray_origin

ROUGH_REFLECTION = wp.constant(0.35)
MIN_THROUGHPUT = wp.constant(1.0e-3)
MAX_DEPTH = 8
MAX_LAYERS = wp.constant(64)
LIGHT_END = wp.constant(1.0e-4)
TWO_PI = wp.constant(2.0 * math.pi)
STACK_COLS = 11
_stack_t = wp.types.matrix(shape=(MAX_DEPTH, STACK_COLS), dtype=wp.float32)

# Ray kinds (count columns): 0 primary shadow, 1 secondary shadow, 2 reflection, 3 refraction.
COUNT_COLUMNS = 4
KIND_REFLECT = wp.constant(2)
KIND_REFRACT = wp.constant(3)


@dataclass(frozen=True)
class TraceVariant:
    """The compile-time flags of one specialisation (see the module docstring)."""

    shadows: bool = False
    layered_shadows: bool = False
    soft_shadows: bool = False
    reflections: bool = False
    transparency: bool = False
    refractions: bool = False
    environment: bool = False
    cutouts: bool = False

    def shadow_key(self) -> tuple[bool, bool, bool]:
        """The flags the shadow kernel depends on."""
        return (self.layered_shadows, self.soft_shadows, self.cutouts)


@wp.struct
class TraceParams:
    """Per-frame constants: scene scale for ray offsets, path depth, shadow samples, seed."""

    scale: float
    max_depth: int
    shadow_samples: int
    seed: int


@wp.struct
class OccluderGPU:
    """The shadow BVHs (``trace/occluders.py``): opaque triangles (any-hit) and the
    transmissive/cut-out/emissive ones (ordered walk), ``special_faces`` mapping the
    latter's faces to scene triangle ids; an id of 0 means empty."""

    opaque: wp.uint64
    special: wp.uint64
    special_faces: wp.array(dtype=wp.int32)


@wp.struct
class ShadowResult:
    """Transmittance toward one light and the shadow rays it took."""

    transmittance: wp.vec3
    rays: int


@wp.struct
class RayHit:
    """Closest surface along a ray (``face`` -1: none)."""

    face: int
    u: float
    v: float


@wp.func
def max3(c: wp.vec3) -> float:
    """Largest component."""
    return wp.max(c[0], wp.max(c[1], c[2]))


@wp.func
def is_emissive(scene: SceneGPU, face: int) -> bool:
    """The material of ``face`` emits light (constant colour or texture)."""
    m = scene.materials[scene.triangle_material[face]]
    return m.emissive_tex >= 0 or max3(m.emissive) > 0.0


@wp.func
def triangle_position(scene: SceneGPU, face: int, u: float, v: float) -> wp.vec3:
    """World point at barycentrics (u, v) of ``face`` (Warp's convention)."""
    k = 3 * face
    return (
        scene.points[scene.indices[k]] * u
        + scene.points[scene.indices[k + 1]] * v
        + scene.points[scene.indices[k + 2]] * (1.0 - u - v)
    )


@wp.func
def step_past(scene: SceneGPU, params: TraceParams, face: int, u: float, v: float, ng: wp.vec3, d: wp.vec3) -> wp.vec3:
    """Origin just beyond the surface hit at (face, u, v), on the side ``d`` travels to."""
    n = ng
    if wp.dot(n, d) < 0.0:
        n = -n
    return offset_ray_origin(triangle_position(scene, face, u, v), n, params.scale)


@wp.func
def transmission_tint(h: SurfaceHit) -> wp.vec3:
    """``(1 - opacity)`` times the diffuse tint where the tint applies (every crossing
    of a thin-walled or non-refracting surface, entering crossings of a solid one)."""
    t = 1.0 - h.opacity
    if (h.flags & FLAG_REFRACTIVE) == 0 or h.front_face != 0:
        return h.albedo * t
    return wp.vec3(t, t, t)


@wp.func
def crossing_transmittance(scene: SceneGPU, face: int, u: float, v: float, d: wp.vec3) -> wp.vec3:
    """What a shadow ray keeps crossing a transmissive surface (module docstring)."""
    h = surface_at(scene, face, u, v, d)
    f = fresnel_dielectric(wp.dot(h.geometric_normal, d), h.ior)
    return transmission_tint(h) * (1.0 - f)


@wp.func
def orthonormal_u(n: wp.vec3) -> wp.vec3:
    """A unit vector perpendicular to unit ``n``."""
    a = wp.vec3(1.0, 0.0, 0.0)
    if wp.abs(n[0]) > 0.9:
        a = wp.vec3(0.0, 1.0, 0.0)
    return wp.normalize(wp.cross(n, a))


@wp.func
def sphere_entry(o: wp.vec3, d: wp.vec3, c: wp.vec3, r: float) -> float:
    """Distance along unit ``d`` from ``o`` to where it enters the sphere (c, r);
    the distance to its centre plane when it misses, 0 from inside."""
    oc = c - o
    b = wp.dot(oc, d)
    c2 = wp.dot(oc, oc) - r * r
    if c2 <= 0.0:
        return 0.0
    disc = b * b - c2
    if disc < 0.0:
        return b
    return b - wp.sqrt(disc)


@wp.func
def light_has_extent(light: LightGPU) -> bool:
    """Soft shadows need more than one sample from this light."""
    if light.kind == KIND_DISTANT:
        return light.cos_half_angle < 1.0
    if light.kind == KIND_SPHERE:
        return light.radius > 0.0
    return True


@wp.func
def sample_light_ray(light: LightGPU, p: wp.vec3, wi: wp.vec3, distance: float, r1: float, r2: float) -> wp.vec4:
    """A shadow ray toward a uniformly sampled point of the light: (direction, length).
    ``wi``/``distance``: the direction and distance to the light's centre."""
    phi = TWO_PI * r2
    if light.kind == KIND_DISTANT:
        cos_t = 1.0 - r1 * (1.0 - light.cos_half_angle)
        sin_t = wp.sqrt(wp.max(1.0 - cos_t * cos_t, 0.0))
        e1 = orthonormal_u(wi)
        e2 = wp.cross(wi, e1)
        dd = wi * cos_t + (e1 * wp.cos(phi) + e2 * wp.sin(phi)) * sin_t
        return wp.vec4(dd[0], dd[1], dd[2], distance)
    q = light.position
    if light.kind == KIND_RECT:
        q = light.position + light.axis_u * (2.0 * r1 - 1.0) + light.axis_v * (2.0 * r2 - 1.0)
    else:
        rad = wp.sqrt(r1)
        e1 = orthonormal_u(wi)
        e2 = wp.cross(wi, e1)
        if light.kind == KIND_SPHERE:
            e1 = e1 * light.radius
            e2 = e2 * light.radius
        elif wp.length(wp.cross(light.axis_u, light.axis_v)) > 0.0:
            e1 = light.axis_u
            e2 = light.axis_v
        else:
            e1 = orthonormal_u(light.direction) * light.radius
            e2 = wp.cross(light.direction, e1)
        q = light.position + (e1 * wp.cos(phi) + e2 * wp.sin(phi)) * rad
    to_q = q - p
    length = wp.length(to_q)
    if length <= 0.0:
        return wp.vec4(wi[0], wi[1], wi[2], 0.0)
    dd = to_q / length
    if light.kind == KIND_SPHERE:
        length = sphere_entry(p, dd, light.position, light.radius)
    else:
        length = length * (1.0 - LIGHT_END)
    return wp.vec4(dd[0], dd[1], dd[2], length)


@wp.func
def center_ray_length(light: LightGPU, distance: float) -> float:
    """Where a hard shadow ray toward the light's centre stops."""
    if light.kind == KIND_DISTANT:
        return distance
    if light.kind == KIND_SPHERE:
        return wp.max(distance - light.radius, 0.0)
    return distance * (1.0 - LIGHT_END)


@wp.func
def light_reaches(ls_irradiance: wp.vec3, ls_e_normal: wp.vec3, n_dot_l: float) -> bool:
    """The light contributes at all (its unshadowed response is non-zero)."""
    return max3(ls_irradiance) > 0.0 or (n_dot_l > 0.0 and max3(ls_e_normal) > 0.0)


def _make_transmittance_func(layered: bool, cutouts: bool):
    """``ray_transmittance(scene, occ, params, o, d, max_t)``: any-hit against the opaque
    BVH, then (``layered``) the ordered walk through the transmissive, cut-out and
    emissive surfaces of the special BVH."""

    @wp.func
    def ray_transmittance(
        scene: SceneGPU, occ: OccluderGPU, params: TraceParams, o: wp.vec3, d: wp.vec3, max_t: float
    ) -> wp.vec3:
        zero = wp.vec3(0.0, 0.0, 0.0)
        t = wp.vec3(1.0, 1.0, 1.0)
        if max_t <= 0.0:
            return t
        if occ.opaque != wp.uint64(0):
            if wp.mesh_query_ray_anyhit(occ.opaque, o, d, max_t):
                return zero
        if wp.static(not layered):
            return t
        if occ.special == wp.uint64(0):
            return t
        origin = o
        remaining = max_t
        for _layer in range(MAX_LAYERS):
            q = wp.mesh_query_ray(occ.special, origin, d, remaining)
            if not q.result:
                return t
            face = occ.special_faces[q.face]
            m = scene.materials[scene.triangle_material[face]]
            if not is_emissive(scene, face):
                passes = False
                if wp.static(cutouts):
                    if (m.flags & FLAG_CUTOUT) != 0:
                        if not is_cut_away(scene, face, q.u, q.v):
                            return zero
                        passes = True
                if not passes:
                    if (m.flags & FLAG_TRANSMISSIVE) == 0:
                        return zero
                    t = wp.cw_mul(t, crossing_transmittance(scene, face, q.u, q.v, d))
                    if max3(t) <= 0.0:
                        return zero
            origin = step_past(scene, params, face, q.u, q.v, q.normal, d)
            remaining = max_t - wp.dot(origin - o, d)
            if remaining <= 0.0:
                return t
        return t

    return ray_transmittance


def _make_light_func(layered: bool, soft: bool, cutouts: bool):
    """``light_transmittance(scene, params, occ, i, ls, p, n, ng, transmissive, pixel, segment)``:
    the RGB transmittance toward light ``i`` (its sample ``ls`` at ``p``), averaged
    over the shadow samples that leave the surface on the lit side (transmissive
    points may send them through their far side)."""
    ray_transmittance = _make_transmittance_func(layered, cutouts)

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
        transmissive: bool,
        pixel: int,
        segment: int,
    ) -> ShadowResult:
        out = ShadowResult()
        out.transmittance = wp.vec3(0.0, 0.0, 0.0)
        out.rays = 0
        if not light_reaches(ls.irradiance, ls.e_normal, wp.dot(n, ls.wi)):
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
            o = offset_ray_origin(p, side, params.scale)
            total += ray_transmittance(scene, occ, params, o, d, length - wp.dot(o - p, d))
            out.rays += 1
        if out.rays > 0:
            out.transmittance = total / float(out.rays)
        return out

    return light_transmittance


@wp.func
def pixel_row(pixel: int, width: int) -> int:
    """Row of a flat pixel index ``row * width + col``."""
    return pixel // width


@functools.lru_cache(maxsize=None)
def shadow_kernel(layered: bool, soft: bool, cutouts: bool) -> wp.Kernel:
    """The primary shadow kernel for one flag tuple (its own Warp module, cached).

    Inputs: scene, cam, params, occluders, gbuffer, pixels, transmittance (items, L) vec3 out,
    visibility (H, W, L) out, counts (items, 4) out (column 0), start, step."""
    light_transmittance = _make_light_func(layered, soft, cutouts)

    @wp.kernel(enable_backward=False, module="unique")
    def trace_shadow(
        scene: SceneGPU,
        cam: CameraGPU,
        params: TraceParams,
        occ: OccluderGPU,
        gb: GBufferArrays,
        pixels: wp.array(dtype=wp.int32),
        transmittance: wp.array2d(dtype=wp.vec3),
        visibility: wp.array3d(dtype=wp.float32),
        counts: wp.array2d(dtype=wp.int32),
        start: int,
        step: int,
    ):
        item = start + wp.tid() * step
        pixel = pixels[item]
        if pixel < 0 or pixel >= cam.width * cam.height:
            return
        y = pixel_row(pixel, cam.width)
        x = pixel - y * cam.width
        if gb.triangle_id[y, x] < 0:
            return
        mid = gb.material_id[y, x]
        transmissive = (scene.materials[mid].flags & FLAG_TRANSMISSIVE) != 0
        p = gb.position[y, x]
        n = gb.normal[y, x]
        ng = gb.geometric_normal[y, x]
        rays = int(0)
        for i in range(scene.light_count):
            ls = light_sample(scene.lights[i], p, n)
            r = light_transmittance(scene, params, occ, i, ls, p, n, ng, transmissive, pixel, 0)
            transmittance[item, i] = r.transmittance
            visibility[y, x, i] = wp.clamp(luma709(r.transmittance), 0.0, 1.0)
            rays += r.rays
        counts[item, 0] = rays

    return trace_shadow


@wp.func
def gbuffer_surface(scene: SceneGPU, gb: GBufferArrays, y: int, x: int, d: wp.vec3) -> SurfaceHit:
    """The primary surface of pixel (x, y) from the G-buffer, seen along ``d``
    (``front_face`` from the winding of its triangle)."""
    h = SurfaceHit()
    tri = gb.triangle_id[y, x]
    h.position = gb.position[y, x]
    h.normal = gb.normal[y, x]
    h.geometric_normal = gb.geometric_normal[y, x]
    k = 3 * tri
    p0 = scene.points[scene.indices[k]]
    winding = wp.cross(scene.points[scene.indices[k + 1]] - p0, scene.points[scene.indices[k + 2]] - p0)
    h.front_face = 1
    if wp.dot(winding, d) > 0.0:
        h.front_face = 0
    h.albedo = gb.albedo[y, x]
    h.specular = gb.specular[y, x]
    h.emission = gb.emission[y, x]
    opt = gb.optics[y, x]
    h.ior = opt[1]
    h.opacity = opt[2]
    h.roughness = opt[3]
    h.material = gb.material_id[y, x]
    h.flags = scene.materials[h.material].flags
    return h


@wp.func
def mirror_direction(d: wp.vec3, n: wp.vec3, ng: wp.vec3) -> wp.vec3:
    """``d`` reflected about the shading normal ``n``, nudged above the geometric
    surface (``ng`` facing against ``d``) where interpolated normals would send it below."""
    r = d - n * (2.0 * wp.dot(d, n))
    c = wp.dot(r, ng)
    if c < 1.0e-4:
        r = wp.normalize(r + ng * (1.0e-4 - c))
    return r


@wp.func
def refract_direction(d: wp.vec3, n: wp.vec3, eta: float) -> wp.vec4:
    """Snell refraction of unit ``d`` at unit normal ``n`` (facing against ``d``) with
    relative IOR ``eta = n_t / n_i``: (direction, 1) or (0, 0) under total internal
    reflection."""
    cos_i = -wp.dot(d, n)
    sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin_t2 >= 1.0:
        return wp.vec4(0.0, 0.0, 0.0, 0.0)
    cos_t = wp.sqrt(1.0 - sin_t2)
    t = wp.normalize(d / eta + n * (cos_i / eta - cos_t))
    return wp.vec4(t[0], t[1], t[2], 1.0)


@wp.struct
class Transmission:
    """A surface's transmission event: Fresnel reflectance, outgoing direction, and
    whether a transmitted ray exists (not under total internal reflection)."""

    fresnel: float
    direction: wp.vec3
    valid: int


def _make_transmission_func(refractions: bool):
    """``transmission(h, d)``: Fresnel and the transmitted direction at a transmissive
    hit; Snell refraction only when ``refractions`` (thin surfaces pass straight)."""

    @wp.func
    def transmission(h: SurfaceHit, d: wp.vec3) -> Transmission:
        out = Transmission()
        out.direction = d
        out.valid = 1
        cos_i = wp.max(-wp.dot(d, h.normal), 1.0e-6)
        if wp.static(refractions):
            if (h.flags & FLAG_REFRACTIVE) != 0:
                eta = h.ior
                if h.front_face == 0:
                    eta = 1.0 / h.ior
                out.fresnel = fresnel_dielectric(cos_i, eta)
                r = refract_direction(d, h.normal, eta)
                t = wp.vec3(r[0], r[1], r[2])
                if r[3] > 0.0 and wp.dot(t, h.geometric_normal) >= 0.0:
                    r = refract_direction(d, h.geometric_normal, eta)
                    t = wp.vec3(r[0], r[1], r[2])
                if r[3] == 0.0 or out.fresnel >= 1.0:
                    out.fresnel = 1.0
                    out.valid = 0
                out.direction = t
                return out
        out.fresnel = fresnel_dielectric(cos_i, h.ior)
        return out

    return transmission


@functools.lru_cache(maxsize=None)
def shade_kernel(variant: TraceVariant) -> wp.Kernel:
    """The shading/secondary-ray kernel for one variant (its own Warp module, cached).

    Inputs: scene, amb, cam, params, occluders, gbuffer, pixels, transmittance (items, L) from the
    shadow kernel, color (H, W) out, counts (items, 4) out (columns 1-3), start, step."""
    v_ = variant
    light_transmittance = _make_light_func(v_.layered_shadows, v_.soft_shadows, v_.cutouts)
    transmission = _make_transmission_func(v_.refractions)
    shadows = v_.shadows
    reflections = v_.reflections
    transparency = v_.transparency
    environment = v_.environment
    cutouts = v_.cutouts
    secondary = v_.reflections or v_.transparency

    @wp.func
    def closest_hit(scene: SceneGPU, params: TraceParams, o: wp.vec3, d: wp.vec3) -> RayHit:
        out = RayHit()
        out.face = -1
        origin = o
        for _layer in range(MAX_LAYERS):
            q = wp.mesh_query_ray(scene.mesh, origin, d, wp.inf)
            if not q.result:
                return out
            if wp.static(cutouts):
                if is_cut_away(scene, q.face, q.u, q.v):
                    origin = step_past(scene, params, q.face, q.u, q.v, q.normal, d)
                    continue
            out.face = q.face
            out.u = q.u
            out.v = q.v
            return out
        return out

    @wp.kernel(enable_backward=False, module="unique")
    def trace_secondary(
        scene: SceneGPU,
        amb: AmbientGPU,
        cam: CameraGPU,
        params: TraceParams,
        occ: OccluderGPU,
        gb: GBufferArrays,
        pixels: wp.array(dtype=wp.int32),
        transmittance: wp.array2d(dtype=wp.vec3),
        color: wp.array2d(dtype=wp.vec3),
        counts: wp.array2d(dtype=wp.int32),
        start: int,
        step: int,
    ):
        item = start + wp.tid() * step
        pixel = pixels[item]
        if pixel < 0 or pixel >= cam.width * cam.height:
            return
        y = pixel_row(pixel, cam.width)
        x = pixel - y * cam.width
        zero = wp.vec3(0.0, 0.0, 0.0)
        if gb.triangle_id[y, x] < 0:
            bg = zero
            if wp.static(environment):
                bg = environment_radiance(scene, camera_ray_direction(cam, x, y))
            color[y, x] = bg
            counts[item, 1] = 0
            counts[item, 2] = 0
            counts[item, 3] = 0
            return

        d = wp.normalize(gb.position[y, x] - cam.origin)
        h = gbuffer_surface(scene, gb, y, x, d)
        weight = wp.vec3(1.0, 1.0, 1.0)
        depth = int(0)
        segment = int(0)
        radiance = wp.vec3(0.0, 0.0, 0.0)
        shadow_rays = int(0)
        reflect_rays = int(0)
        refract_rays = int(0)
        stack = _stack_t()
        stack_size = int(0)
        have_hit = int(1)
        while True:
            ray_kind = int(0)
            ray_o = zero
            ray_d = zero
            ray_w = zero
            if have_hit != 0:
                have_hit = 0
                v = -d
                n = h.normal
                ng = h.geometric_normal
                transmissive = False
                if wp.static(transparency):
                    transmissive = (h.flags & FLAG_TRANSMISSIVE) != 0
                traced = depth < params.max_depth
                kd = h.albedo
                if traced:
                    if transmissive:
                        kd = h.albedo * h.opacity
                else:
                    kd = diffuse_albedo(scene, n, v, h.albedo, h.opacity, h.ior, h.flags)
                direct = wp.vec3(0.0, 0.0, 0.0)
                if wp.static(shadows):
                    for i in range(scene.light_count):
                        ls = light_sample(scene.lights[i], h.position, n)
                        c = light_response(ls, n, v, kd, h.specular, h.roughness)
                        tr = wp.vec3(0.0, 0.0, 0.0)
                        if segment == 0:
                            tr = transmittance[item, i]
                        elif max3(wp.cw_mul(weight, c)) >= MIN_THROUGHPUT * INV_PI * max3(ls.e_normal):
                            r = light_transmittance(
                                scene, params, occ, i, ls, h.position, n, ng, transmissive, pixel, segment
                            )
                            tr = r.transmittance
                            shadow_rays += r.rays
                        direct += wp.cw_mul(c, tr)
                segment += 1
                if not traced:
                    c = h.emission + direct
                    if wp.static(environment):
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
                    radiance += wp.cw_mul(weight, c)
                else:
                    c = h.emission + direct
                    if wp.static(environment):
                        c += ambient_diffuse(scene, amb, n, v, kd, h.specular)
                    # children: a = reflection, b = transmission
                    a_w = zero
                    a_d = zero
                    b_w = zero
                    b_d = zero
                    smooth = h.roughness < ROUGH_REFLECTION
                    if wp.static(secondary):
                        if transmissive:
                            tm = transmission(h, d)
                            if smooth or tm.valid == 0:
                                a_w = wp.vec3(tm.fresnel, tm.fresnel, tm.fresnel)
                                a_d = mirror_direction(d, n, ng)
                            elif wp.static(environment):
                                c += ambient_specular(scene, amb, n, v, h.specular, h.roughness)
                            if tm.valid != 0:
                                b_w = transmission_tint(h) * (1.0 - tm.fresnel)
                                b_d = tm.direction
                        else:
                            if wp.static(reflections):
                                if smooth:
                                    a_w = env_brdf(amb, h.specular, h.roughness, wp.dot(n, v))
                                    a_d = mirror_direction(d, n, ng)
                            if max3(a_w) <= 0.0:
                                if wp.static(environment):
                                    c += ambient_specular(scene, amb, n, v, h.specular, h.roughness)
                    elif wp.static(environment):
                        c += ambient_specular(scene, amb, n, v, h.specular, h.roughness)
                    radiance += wp.cw_mul(weight, c)
                    if wp.static(secondary):
                        a_w = wp.cw_mul(a_w, weight)
                        b_w = wp.cw_mul(b_w, weight)
                        a_ok = max3(a_w) >= MIN_THROUGHPUT
                        b_ok = max3(b_w) >= MIN_THROUGHPUT
                        if a_ok and b_ok and stack_size < wp.static(MAX_DEPTH):
                            # follow the heavier branch, push the other
                            push_o = offset_ray_origin(h.position, -ng, params.scale)
                            push_d = b_d
                            push_w = b_w
                            push_kind = KIND_REFRACT
                            if max3(b_w) > max3(a_w):
                                push_o = offset_ray_origin(h.position, ng, params.scale)
                                push_d = a_d
                                push_w = a_w
                                push_kind = KIND_REFLECT
                                a_ok = False
                            else:
                                b_ok = False
                            for j in range(3):
                                stack[stack_size, j] = push_o[j]
                                stack[stack_size, 3 + j] = push_d[j]
                                stack[stack_size, 6 + j] = push_w[j]
                            stack[stack_size, 9] = float(depth + 1)
                            stack[stack_size, 10] = float(push_kind)
                            stack_size += 1
                        if a_ok:
                            ray_kind = KIND_REFLECT
                            ray_o = offset_ray_origin(h.position, ng, params.scale)
                            ray_d = a_d
                            ray_w = a_w
                        elif b_ok:
                            ray_kind = KIND_REFRACT
                            ray_o = offset_ray_origin(h.position, -ng, params.scale)
                            ray_d = b_d
                            ray_w = b_w
            if wp.static(not secondary):
                break
            next_depth = depth + 1
            if ray_kind == 0:
                if stack_size == 0:
                    break
                stack_size -= 1
                ray_o = wp.vec3(stack[stack_size, 0], stack[stack_size, 1], stack[stack_size, 2])
                ray_d = wp.vec3(stack[stack_size, 3], stack[stack_size, 4], stack[stack_size, 5])
                ray_w = wp.vec3(stack[stack_size, 6], stack[stack_size, 7], stack[stack_size, 8])
                next_depth = int(stack[stack_size, 9])
                ray_kind = int(stack[stack_size, 10])
            if ray_kind == KIND_REFLECT:
                reflect_rays += 1
            else:
                refract_rays += 1
            hit = closest_hit(scene, params, ray_o, ray_d)
            if hit.face >= 0:
                h = surface_at(scene, hit.face, hit.u, hit.v, ray_d)
                d = ray_d
                weight = ray_w
                depth = next_depth
                have_hit = 1
            else:
                if wp.static(environment):
                    radiance += wp.cw_mul(ray_w, environment_radiance(scene, ray_d))
        color[y, x] = radiance
        counts[item, 1] = shadow_rays
        counts[item, 2] = reflect_rays
        counts[item, 3] = refract_rays

    return trace_secondary
