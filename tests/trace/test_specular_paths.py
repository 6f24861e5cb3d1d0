"""Reflection and refraction paths against geometric optics: a 45-degree mirror, the
lateral shift through a glass slab, total internal reflection in a prism and seen from
inside a glass sphere, Fresnel reflectance at normal incidence, the inverted image in a
glass sphere."""

from __future__ import annotations

import math

import numpy as np
import pytest
from trace_kit import box, camera_rays, emissive, trace_variants

from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Light, LightKind, Material
from warp_hybrid.trace import TraceSettings

W, H = 96, 72
RED = (1.0, 0.0, 0.0)
BLUE = (0.0, 0.0, 1.0)
GLASS = Material("/glass", diffuse=(1.0, 1.0, 1.0), roughness=0.0, opacity=0.0, ior=1.5)


def _plane_hit(o: np.ndarray, d: np.ndarray, point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Ray parameter of the plane (point, normal) for rays o + t d (d: (..., 3))."""
    return np.einsum("k,...k->...", normal, point - o) / np.einsum("k,...k->...", normal, d)


def _fresnel(cos_i: np.ndarray, eta: float) -> np.ndarray:
    """Exact unpolarised dielectric Fresnel reflectance, float64."""
    sin_t2 = (1.0 - cos_i**2) / eta**2
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(sin_t2 >= 1.0, 1.0, 0.5 * (rs**2 + rp**2))


def test_mirror_reflects_the_pattern_at_the_predicted_pixels(device: str) -> None:
    """A mirror at 45 degrees turns the view by 90 degrees onto a red|blue wall."""
    mats = [
        Material("/mirror", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
        emissive("/red", RED),
        emissive("/blue", BLUE),
    ]
    s = math.sqrt(0.5)
    # mirror through (0, 0, -5) with normal (-s, 0, s) (facing the camera and -x)
    mirror = quad((3.0 * s, -3.0, -5.0 + 3.0 * s), (-6.0 * s, 0.0, -6.0 * s), (0.0, 6.0, 0.0), 0)
    # wall x = -4 facing +x: red for z < -5, blue for z > -5
    red = quad((-4.0, -4.0, -5.0), (0.0, 0.0, -4.0), (0.0, 8.0, 0.0), 1)
    blue = quad((-4.0, -4.0, -1.0), (0.0, 0.0, -4.0), (0.0, 8.0, 0.0), 2)
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=30.0)
    scene = make_scene([mirror, red, blue], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H)
    o, d = camera_rays(cam, W, H)
    n = np.array([-s, 0.0, s])
    p = o + _plane_hit(o, d, np.array([0.0, 0.0, -5.0]), n)[..., None] * d
    r = d - 2.0 * np.einsum("...k,k->...", d, n)[..., None] * n
    q = p + _plane_hit(p, r, np.array([-4.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]))[..., None] * r
    on_mirror = out.triangle_id < 2
    assert on_mirror.all()
    px = 2.0 * 4.0 * math.tan(math.radians(15.0)) / W  # world size of a pixel at the wall, roughly
    want_red = on_mirror & (q[..., 2] < -5.0 - 2.0 * px)
    want_blue = on_mirror & (q[..., 2] > -5.0 + 2.0 * px)
    assert want_red.sum() > 1000 and want_blue.sum() > 1000
    c = out.color
    assert np.allclose(c[want_red], RED, atol=0.03)
    assert np.allclose(c[want_blue], BLUE, atol=0.03)
    assert out.counts.reflection == W * H and out.counts.refraction == 0


def test_glass_slab_shifts_the_view_by_the_analytic_amount(device: str) -> None:
    """Behind a 1-unit slab turned 45 degrees, the red|blue edge appears where the
    camera ray shifted sideways by t sin(i - r) / cos(r) meets the wall."""
    t, ior = 1.0, 1.5
    mats = [GLASS, emissive("/red", RED), emissive("/blue", BLUE)]
    slab = box((0.0, 0.0, -4.0), (3.0, 3.0, t / 2.0), rotation_y_deg=45.0, material=0)
    # wall z = -9 facing +z: red for x < 0.2, blue beyond
    red = quad((-6.0, -6.0, -9.0), (6.2, 0.0, 0.0), (0.0, 12.0, 0.0), 1)
    blue = quad((0.2, -6.0, -9.0), (6.0, 0.0, 0.0), (0.0, 12.0, 0.0), 2)
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=24.0)
    scene = make_scene([slab, red, blue], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H)

    o, d = camera_rays(cam, W, H)
    a = math.radians(45.0)
    n = np.array([math.sin(a), 0.0, math.cos(a)])  # front face normal (toward the camera)
    front = _plane_hit(o, d, np.array([0.0, 0.0, -4.0]) + n * t / 2.0, n)
    cos_i = -np.einsum("...k,k->...", d, n)
    i = np.arccos(cos_i)
    r = np.arcsin(np.sin(i) / ior)
    shift = t * np.sin(i - r) / np.cos(r)
    # refracted direction (Snell) gives the side the ray is displaced to
    tdir = d / ior + n * (cos_i / ior - np.cos(r))[..., None]
    side = tdir - np.einsum("...k,...k->...", tdir, d)[..., None] * d
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    entry = o + front[..., None] * d
    shifted_o = entry + shift[..., None] * side
    wall = _plane_hit(shifted_o, d, np.array([0.0, 0.0, -9.0]), np.array([0.0, 0.0, 1.0]))
    x = (shifted_o + wall[..., None] * d)[..., 0]
    x_straight = (o + _plane_hit(o, d, np.array([0.0, 0.0, -9.0]), np.array([0.0, 0.0, 1.0]))[..., None] * d)[..., 0]

    through = out.triangle_id < 12
    margin = 0.75 * 9.0 * 2.0 * math.tan(math.radians(12.0)) / W  # 3/4 of a pixel at the wall
    want_red = through & (x < 0.2 - margin)
    want_blue = through & (x > 0.2 + margin)
    flipped = through & ((x < 0.2) != (x_straight < 0.2))
    assert flipped.sum() > 200, "the shift must matter in this set-up"
    weight = (1.0 - _fresnel(cos_i, ior)) ** 2  # two interfaces (equal angles of incidence)
    c = out.color
    assert np.all(c[want_red][:, 0] > 0.9 * weight[want_red]) and np.all(c[want_red][:, 2] < 0.02)
    assert np.all(c[want_blue][:, 2] > 0.9 * weight[want_blue]) and np.all(c[want_blue][:, 0] < 0.02)
    # the direct red/blue transmission dominates; multiple internal reflections add < 1%
    assert np.allclose(c[want_red][:, 0], weight[want_red], rtol=0.01)
    assert out.counts.refraction > 0 and out.counts.reflection > 0


def _prism(material: int):
    """A right-angle glass prism, cross-section (x, z): (-1, 0), (1, 0), (1, -2), from
    y = -1 to 1: the face z = 0 faces the camera, the hypotenuse x + z = -1 is at
    45 degrees to the view, the face x = 1 looks at +x."""
    xz = [(-1.0, 0.0), (1.0, 0.0), (1.0, -2.0)]
    pts = np.array([(x, y, z) for y in (-1.0, 1.0) for (x, z) in xz], dtype=np.float32)
    # bottom 0 1 2, top 3 4 5
    idx = [(0, 2, 1), (3, 4, 5), (0, 1, 4), (0, 4, 3), (1, 2, 5), (1, 5, 4), (2, 0, 3), (2, 3, 5)]
    return MeshInput(pts, np.asarray(idx, np.int32), material)


def test_total_internal_reflection_in_a_prism(device: str) -> None:
    """Rays entering the prism head-on meet the hypotenuse at 45 > 41.8 degrees and are
    totally reflected out through the side face onto the red wall (weight (1 - 0.04)^2);
    the blue wall straight behind stays invisible through the prism."""
    mats = [GLASS, emissive("/red", RED), emissive("/blue", BLUE)]
    red = quad((4.0, -6.0, 6.0), (0.0, 12.0, 0.0), (0.0, 0.0, -12.0), 1)  # x = 4, facing -x
    blue = quad((-6.0, -6.0, -8.0), (12.0, 0.0, 0.0), (0.0, 12.0, 0.0), 2)  # z = -8, facing +z
    cam = look_at_camera((0.0, 0.0, 20.0), (0.0, 0.0, 0.0), hfov_deg=6.0)
    scene = make_scene([_prism(0), red, blue], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H)
    o, d = camera_rays(cam, W, H)
    p = o + _plane_hit(o, d, np.zeros(3), np.array([0.0, 0.0, 1.0]))[..., None] * d
    inner = (np.abs(p[..., 0]) < 0.9) & (np.abs(p[..., 1]) < 0.9) & (out.triangle_id >= 0) & (out.triangle_id < 8)
    assert inner.sum() > 1000
    cos_i = -d[..., 2]
    expected = (1.0 - _fresnel(cos_i, 1.5)) ** 2
    c = out.color[inner]
    assert np.allclose(c[:, 0], expected[inner], rtol=2e-3)
    assert np.all(c[:, 2] < 1e-3) and np.all(c[:, 1] < 1e-3)


def test_seen_from_inside_glass_a_primary_point_reflects_totally_beyond_the_critical_angle(device: str) -> None:
    """The camera inside a glass sphere (radius 2, IOR 1.5) sees its wall from within:
    the primary points are exits (``front_face`` 0, eta 1/1.5), so a ray whose line
    passes the centre farther than R / 1.5 meets the wall beyond the critical angle and
    sends no refraction ray; a closer one does.  With one bounce, the refraction rays are
    the pixels the analytic rule lets out (a primary point taken for an entry would let
    every pixel out)."""
    sphere = uv_sphere((0.0, 0.0, 0.0), 2.0, 96, 192, 0)
    cam = look_at_camera((1.4, 0.0, 0.0), (1.4, 0.0, -1.0), hfov_deg=60.0)
    scene = make_scene([sphere], [GLASS], cameras=[cam])
    out = trace_variants(scene, cam, device, W, H, settings=TraceSettings(max_depth=1))
    assert (out.triangle_id >= 0).all()
    o, d = camera_rays(cam, W, H)
    centre_distance = np.linalg.norm(np.cross(o, d), axis=-1)  # the centre is the origin
    critical = 2.0 / 1.5
    surely_out = int((centre_distance < 0.99 * critical).sum())
    maybe_out = int((centre_distance < 1.01 * critical).sum())
    assert 0.25 * W * H < surely_out and maybe_out < 0.6 * W * H  # both kinds of pixel in view
    assert surely_out <= out.counts.refraction <= maybe_out
    assert out.counts.reflection == W * H


def test_fresnel_reflectance_is_0_04_at_normal_incidence(device: str) -> None:
    """Looking head-on at a glass surface with black behind it: the pixel shows the
    Fresnel reflection of a white emitter behind the camera, 0.04 for IOR 1.5 at
    normal incidence and the exact F(theta) off-axis."""
    mats = [GLASS, emissive("/white", (1.0, 1.0, 1.0)), Material("/black", diffuse=(0.0, 0.0, 0.0), roughness=1.0)]
    glass = quad((-2.0, -2.0, 0.0), (4.0, 0.0, 0.0), (0.0, 4.0, 0.0), 0)  # z = 0 facing +z
    black = quad((-3.0, -3.0, -1.0), (6.0, 0.0, 0.0), (0.0, 6.0, 0.0), 2)
    emitter = quad((-50.0, -50.0, 20.0), (0.0, 100.0, 0.0), (100.0, 0.0, 0.0), 1)  # z = 20 facing -z
    cam = look_at_camera((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), hfov_deg=20.0)
    scene = make_scene([glass, black, emitter], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H)
    o, d = camera_rays(cam, W, H)
    on_glass = out.triangle_id < 2
    assert on_glass.all()
    expected = _fresnel(-d[..., 2], 1.5)
    assert np.allclose(out.color[..., 0], expected, rtol=1e-4, atol=1e-7)
    centre = out.color[H // 2 - 1 : H // 2 + 1, W // 2 - 1 : W // 2 + 1, 0]
    assert np.allclose(centre, 0.04, rtol=1e-3)


def test_glass_sphere_flips_the_image_behind_it(device: str) -> None:
    """A solid glass ball in front of a wall, red above and blue below: through the
    ball's centre the wall appears upside down (a ball lens of focal length 1.5 R)."""
    mats = [GLASS, emissive("/red", RED), emissive("/blue", BLUE)]
    red = quad((-20.0, 0.0, -10.0), (40.0, 0.0, 0.0), (0.0, 20.0, 0.0), 1)
    blue = quad((-20.0, -20.0, -10.0), (40.0, 0.0, 0.0), (0.0, 20.0, 0.0), 2)
    cam = look_at_camera((0.0, 0.0, 6.0), (0.0, 0.0, 0.0), hfov_deg=30.0)
    scene = make_scene([uv_sphere((0.0, 0.0, 0.0), 1.0, 48, 96, 0), red, blue], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H)
    o, d = camera_rays(cam, W, H)
    # where each camera ray passes the sphere's centre plane z = 0
    p = o + _plane_hit(o, d, np.zeros(3), np.array([0.0, 0.0, 1.0]))[..., None] * d
    rho = np.hypot(p[..., 0], p[..., 1])
    ball = out.triangle_id < scene.meshes[0].triangle_count
    core = ball & (rho < 0.6) & (np.abs(p[..., 1]) > 0.1)
    upper, lower = core & (p[..., 1] > 0), core & (p[..., 1] < 0)
    assert upper.sum() > 100 and lower.sum() > 100
    c = out.color
    assert np.all(c[upper][:, 2] > 0.5) and np.all(c[upper][:, 0] < 0.05)
    assert np.all(c[lower][:, 0] > 0.5) and np.all(c[lower][:, 2] < 0.05)
    # beside the ball the wall is seen the right way up
    wall = ~ball & (out.triangle_id >= 0)
    assert np.all(c[wall & (p[..., 1] > 0.1)][:, 0] > 0.99)
    assert np.all(c[wall & (p[..., 1] < -0.1)][:, 2] > 0.99)


@pytest.mark.parametrize("max_depth", [0, 1])
def test_depth_limit_falls_back_to_raster_shading(device: str, max_depth: int) -> None:
    """max_depth 0 traces no secondary ray; 1 traces exactly one per mirror pixel and
    its hit is shaded without further rays."""
    mats = [
        Material("/mirror", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
        Material("/mirror2", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
    ]
    a = quad((-3.0, -3.0, -5.0), (6.0, 0.0, 0.0), (0.0, 6.0, 0.0), 0)
    b = quad((-30.0, -30.0, 5.0), (0.0, 60.0, 0.0), (60.0, 0.0, 0.0), 1)
    cam = look_at_camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), hfov_deg=30.0)
    scene = make_scene([a, b], mats, cameras=[cam])
    out = trace_variants(scene, cam, device, W, H, settings=TraceSettings(max_depth=max_depth))
    assert out.counts.reflection == max_depth * W * H


def test_mirror_shows_the_floor_with_its_shadows(device: str) -> None:
    """A periscope mirror: the camera sees the floor (with a ball's shadow) through a
    45-degree mirror, exactly what a camera at the mirrored eye sees directly (left and
    right swapped): secondary hits are lit and shadowed like primary ones."""
    mats = [
        Material("/floor", diffuse=(0.8, 0.7, 0.6), roughness=0.9),
        Material("/ball", diffuse=(0.3, 0.5, 0.8), roughness=0.8),
        Material("/mirror", diffuse=(1.0, 1.0, 1.0), metallic=1.0, roughness=0.0),
    ]
    s = math.sqrt(0.5)
    # mirror through (0, 10, 0) facing (0, -1, 1); the sun comes in low from -x, so
    # the mirror itself shades none of the floor in view
    mirror = quad((-3.0, 10.0 - 3.0 * s, -3.0 * s), (6.0, 0.0, 0.0), (0.0, 6.0 * s, 6.0 * s), 2)
    meshes = [
        quad((-6.0, 0.0, 6.0), (12.0, 0.0, 0.0), (0.0, 0.0, -12.0), 0),
        uv_sphere((0.3, 1.0, 0.2), 1.0, 32, 64, 1),
    ]
    light = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(1.0, -0.6, 0.0))
    cam = look_at_camera((0.0, 10.0, 6.0), (0.0, 10.0, 0.0), hfov_deg=30.0)
    virtual = look_at_camera((0.0, 16.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), hfov_deg=30.0)
    via_mirror = trace_variants(make_scene(meshes + [mirror], mats, lights=[light]), cam, device, W, H)
    direct = trace_variants(make_scene(meshes, mats, lights=[light]), virtual, device, W, H)
    assert np.all(via_mirror.triangle_id >= via_mirror.triangle_id.max() - 1), "the view must see only the mirror"
    seen = direct.color[:, ::-1]
    shadowed = direct.visibility[:, ::-1, 0] == 0.0
    assert 200 < shadowed.sum() < 0.5 * W * H
    ratio = via_mirror.color.sum(axis=-1) / np.maximum(seen.sum(axis=-1), 1e-9)
    lit = ~shadowed & (seen.sum(axis=-1) > 0.05)
    agree = np.abs(ratio[lit] - 1.0) < 0.02
    assert agree.mean() > 0.98
    dark = via_mirror.color.sum(axis=-1) < 1e-6
    assert (dark == shadowed).mean() > 0.98
    assert via_mirror.counts.shadow > 0.9 * W * H  # the floor seen in the mirror (the mirror faces away from the sun)
