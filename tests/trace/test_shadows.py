"""Shadow rays: an analytic sphere shadow, soft shadows, coloured shadows through a
tinted pane, cut-outs and emitters, no acne at grazing light at any scene scale,
animated occluders."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import warp as wp
from trace_kit import ALL_FEATURES, emissive, pane_scene, trace_variants

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Light, LightKind, Material
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import Tracer, TraceSettings

W, H = 96, 72


def _sphere_over_plane(tilt_deg: float, light: Light | None = None):
    """A unit sphere centred 3 above the plane y = 0, lit along (sin t, -cos t, 0);
    the camera looks straight down at the shadow's centre x = 3 tan t with a view
    4 units wide (24 pixels per unit)."""
    t = math.radians(tilt_deg)
    cx = 3.0 * math.tan(t)
    mats = [
        Material("/plane", diffuse=(0.8, 0.8, 0.8), roughness=0.9),
        Material("/ball", diffuse=(0.5, 0.5, 0.5), roughness=0.9),
    ]
    meshes = [
        quad((cx - 4.0, 0.0, 4.0), (8.0, 0.0, 0.0), (0.0, 0.0, -8.0), 0),
        uv_sphere((0.0, 3.0, 0.0), 1.0, 96, 192, 1),
    ]
    light = light or Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(math.sin(t), -math.cos(t), 0.0))
    hfov = math.degrees(2.0 * math.atan(2.0 / 10.0))
    cam = look_at_camera((cx, 10.0, 0.0), (cx, 0.0, 0.0), up=(0.0, 0.0, -1.0), hfov_deg=hfov)
    return make_scene(meshes, mats, lights=[light], cameras=[cam]), cam


def test_sphere_shadow_is_the_analytic_ellipse(device: str) -> None:
    """Distant light 45 degrees off vertical: the shadow is an ellipse with semi-axes
    r / cos 45 and r, i.e. pi sqrt(2) * 24^2 = 2559.3 pixels; visibility is exactly 0
    inside, 1 outside."""
    scene, cam = _sphere_over_plane(45.0)
    out = trace_variants(scene, cam, device, W, H)
    plane = (out.triangle_id >= 0) & (out.triangle_id < 2)
    assert plane.all(), "the view must see only the plane"
    vis = out.visibility[..., 0]
    assert set(np.unique(vis).tolist()) == {0.0, 1.0}
    expected = math.pi * math.sqrt(2.0) * 24.0**2
    assert abs((vis == 0.0).sum() - expected) / expected < 0.01
    # shadowed pixels lie inside the ellipse (x - 3)^2 / 2 + z^2 <= 1 (plus a pixel of slack)
    x, z = out.position[..., 0], out.position[..., 2]
    inside = (x - 3.0) ** 2 / 2.0 + z**2
    assert inside[vis == 0.0].max() < (1.0 + 1.5 / 24.0) ** 2
    assert inside[vis == 1.0].min() > (1.0 - 1.5 / 24.0) ** 2
    # shading: lit pixels get the light, shadowed ones only the (zero) ambient
    lit = out.color[vis == 1.0]
    assert np.all(lit > 0.1) and np.allclose(out.color[vis == 0.0], 0.0)
    assert out.counts.shadow == W * H and out.counts.reflection == 0 and out.counts.refraction == 0


def test_soft_shadow_of_a_sphere_light_has_a_penumbra(device: str) -> None:
    """A sphere light of radius 0.5: with 16 samples the umbra shrinks and a penumbra
    of partial visibility appears around it; with 1 sample it is hard."""
    light = Light(LightKind.SPHERE, "/bulb", (50.0, 50.0, 50.0), position=(-6.0, 9.0, 0.0), radius=0.5)
    scene, cam = _sphere_over_plane(45.0, light)
    hard = trace_variants(scene, cam, device, W, H).visibility[..., 0]
    soft_run = trace_variants(scene, cam, device, W, H, settings=TraceSettings(shadow_samples=16, seed=7))
    soft = soft_run.visibility[..., 0]
    assert set(np.unique(hard).tolist()) == {0.0, 1.0}
    partial = (soft > 0.0) & (soft < 1.0)
    assert partial.sum() > 100
    assert (soft == 0.0).sum() < (hard == 0.0).sum()
    assert soft_run.counts.shadow == 16 * W * H
    again = trace_variants(scene, cam, device, W, H, settings=TraceSettings(shadow_samples=16, seed=7)).visibility
    assert np.array_equal(again[..., 0], soft)


def _under_the_pane(device: str, opacity: float, blended: bool = False):
    """The pane scene traced, the floor alone traced (its unshadowed reference), the
    floor's pixels and those of them under the pane."""
    scene, cam = pane_scene(opacity, blended=blended)
    lit_scene = make_scene(
        [quad((-3.0, 0.0, 3.0), (6.0, 0.0, 0.0), (0.0, 0.0, -6.0), 0)],
        scene.materials[:1],
        lights=scene.lights,
        cameras=[cam],
    )
    out = trace_variants(scene, cam, device, W, H)
    ref = trace_variants(lit_scene, cam, device, W, H)
    floor = (out.triangle_id >= 0) & (out.triangle_id < 2)
    x, z = out.position[..., 0], out.position[..., 2]
    under = floor & (np.abs(x) < 0.9) & (np.abs(z) < 0.9)
    assert under.sum() > 50
    return out, ref, floor, under


def test_shadow_through_a_red_pane_is_red(device: str) -> None:
    """Transmittance (1 - opacity) (1 - F(0)) tint with F(0) = 0.04 for IOR 1.5: the
    floor under the pane keeps a red light, visibility = its luminance."""
    opacity = 0.3
    out, ref, floor, under = _under_the_pane(device, opacity)
    x, z = out.position[..., 0], out.position[..., 2]
    tint = (1.0 - opacity) * 0.96 * np.array([0.9, 0.1, 0.08])
    lum = 0.2126 * tint[0] + 0.7152 * tint[1] + 0.0722 * tint[2]
    vis = out.visibility[..., 0][under]
    assert 0.0 < lum < 1.0 and np.allclose(vis, lum, atol=1e-5)
    ratio = out.color[under] / ref.color[under]
    assert np.allclose(ratio, tint, rtol=1e-4)
    outside = floor & ((np.abs(x) > 1.1) | (np.abs(z) > 1.1))
    assert np.all(out.visibility[..., 0][outside] == 1.0)


@pytest.mark.parametrize("opacity", [0.3, 0.75])
def test_shadow_through_an_alpha_blended_pane_is_uncoloured(device: str, opacity: float) -> None:
    """Coverage, not glass: the same red pane alpha-blended lets 1 - opacity of the light
    through in every channel (no tint, no Fresnel)."""
    out, ref, _, under = _under_the_pane(device, opacity, blended=True)
    assert np.allclose(out.visibility[..., 0][under], 1.0 - opacity, atol=1e-6)
    assert np.allclose(out.color[under] / ref.color[under], 1.0 - opacity, rtol=1e-4)


@pytest.mark.parametrize("opacity", [0.3, 0.7])
def test_alpha_cutouts_cast_no_shadow_where_cut_away(device: str, opacity: float) -> None:
    """A cut-out quad (threshold 0.5) over the floor: cut away entirely below the
    threshold (no shadow), an opaque occluder above it."""
    mats = [
        Material("/floor", diffuse=(0.8, 0.8, 0.8), roughness=0.9),
        Material("/leaf", opacity=opacity, opacity_threshold=0.5),
    ]
    meshes = [
        quad((-3.0, 0.0, 3.0), (6.0, 0.0, 0.0), (0.0, 0.0, -6.0), 0),
        quad((-1.0, 1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 1),
    ]
    light = Light(LightKind.DISTANT, "/sun", (2.0, 2.0, 2.0), direction=(0.6, -1.0, 0.0))
    cam = look_at_camera((0.0, 5.0, 6.0), (0.0, 0.0, 0.0))
    out = trace_variants(make_scene(meshes, mats, lights=[light], cameras=[cam]), cam, device, W, H)
    floor = (out.triangle_id >= 0) & (out.triangle_id < 2)
    x, z = out.position[..., 0], out.position[..., 2]
    shadow = floor & (np.abs(x - 0.6) < 0.9) & (np.abs(z) < 0.9)  # the quad projected along the light
    assert shadow.sum() > 100
    assert np.all(out.visibility[..., 0][shadow] == (1.0 if opacity < 0.5 else 0.0))
    if opacity < 0.5:
        assert np.all(floor | (out.triangle_id < 0)), "a cut-away quad is invisible"


def test_emitter_geometry_of_an_area_light_casts_no_shadow(device: str) -> None:
    """The emitting quad that sits at a rect light (as in the Cornell boxes) is skipped
    by shadow rays; an opaque quad between them still blocks."""
    mats = [
        Material("/floor", diffuse=(0.8, 0.8, 0.8), roughness=0.9),
        emissive("/lamp", (5.0, 5.0, 5.0)),
        Material("/card"),
    ]
    meshes = [
        quad((-3.0, 0.0, 3.0), (6.0, 0.0, 0.0), (0.0, 0.0, -6.0), 0),
        quad((-0.5, 2.98, 0.5), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), 1),  # the emitter just below the light, facing down
        quad((1.0, 1.5, 1.0), (1.0, 0.0, 0.0), (0.0, 0.0, -2.0), 2),  # a card casting a shadow
    ]
    light = Light(
        LightKind.RECT,
        "/lamp",
        (5.0, 5.0, 5.0),
        position=(0.0, 3.0, 0.0),
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.5, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.5),
    )
    cam = look_at_camera((0.0, 2.5, 6.0), (0.0, 0.0, 0.0))
    out = trace_variants(make_scene(meshes, mats, lights=[light], cameras=[cam]), cam, device, W, H)
    floor = (out.triangle_id >= 0) & (out.triangle_id < 2)
    x, z = out.position[..., 0], out.position[..., 2]
    vis = out.visibility[..., 0]
    behind_card = floor & (x > 2.2) & (x < 3.8) & (np.abs(z) < 1.0)  # the card seen from the lamp's centre
    open_floor = floor & (x < 0.5)
    assert behind_card.sum() > 20 and open_floor.sum() > 500
    assert np.all(vis[open_floor] == 1.0) and np.all(vis[behind_card] == 0.0)


@pytest.mark.parametrize("scale", [1.0e-3, 1.0, 1.0e4])
@pytest.mark.parametrize("incidence_deg", [85.0, 87.0, 89.0])
def test_no_acne_at_grazing_light(device: str, scale: float, incidence_deg: float) -> None:
    """A finely tessellated, tilted plane away from the origin lit at 85-89 degrees
    from its normal: every shadow ray reaches the light (visibility 1 everywhere)."""
    rng = np.random.default_rng(3)
    n = 24
    s, t = np.meshgrid(np.linspace(0.0, 1.0, n + 1), np.linspace(0.0, 1.0, n + 1))
    jitter = rng.uniform(-0.3, 0.3, size=(2,) + s.shape) / n
    jitter[:, [0, -1], :] = 0.0
    jitter[:, :, [0, -1]] = 0.0
    s, t = s + jitter[0], t + jitter[1]
    normal = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
    u = np.cross(normal, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(u, normal)
    origin = np.array([7.0, -3.0, 5.0])
    pts = origin + (s[..., None] - 0.5) * 10.0 * u + (t[..., None] - 0.5) * 10.0 * v
    idx = []
    for r in range(n):
        for c in range(n):
            a, b, d, e = r * (n + 1) + c, r * (n + 1) + c + 1, (r + 1) * (n + 1) + c, (r + 1) * (n + 1) + c + 1
            idx += [(a, d, b), (b, d, e)]
    idx = np.asarray(idx, np.int32)
    pts = (pts.reshape(-1, 3) * scale).astype(np.float32)

    theta = math.radians(incidence_deg)
    to_light = math.cos(theta) * normal + math.sin(theta) * u
    light = Light(LightKind.DISTANT, "/sun", (1.0, 1.0, 1.0), direction=tuple(-to_light))
    eye = (origin + 12.0 * normal) * scale
    cam = look_at_camera(tuple(eye), tuple(origin * scale), hfov_deg=40.0, near=0.01 * scale, far=100.0 * scale)
    scene = make_scene([MeshInput(pts, idx, 0)], [Material("/plane", roughness=0.9)], lights=[light], cameras=[cam])
    out = trace_variants(scene, cam, device, 64, 48)
    hit = out.triangle_id >= 0
    assert hit.sum() > 0.8 * hit.size
    assert np.all(out.visibility[..., 0][hit] == 1.0)
    assert np.all(np.isnan(out.visibility[..., 0][~hit]))


@pytest.mark.parametrize("opacity", [0.3, 1.0])
@pytest.mark.parametrize("wide_bvh", [None, False])
def test_shadow_bvhs_follow_animated_points(device: str, wide_bvh: bool | None, opacity: float) -> None:
    """Moving the red pane (same topology, ``DeviceScene.update``) moves its shadow in the
    next frame traced by the same tracer (its BVHs are refitted), with the 4-wide copies
    (the CPU's default) and with Warp's own trees; the glass pane's shadow comes from the
    tracer's own two BVHs, the opaque one's from the scene's BVH."""
    scene, cam = pane_scene(opacity)
    ds = DeviceScene(scene, device)
    camera = make_camera_gpu(cam, W, H)
    gb = GBuffer(W, H, device)
    pixels = wp.array(np.arange(W * H, dtype=np.int32), dtype=wp.int32, device=device)
    shadows = []
    with Launcher(device, threads=1) as launcher:
        tracer = Tracer(launcher, TraceSettings(wide_bvh=wide_bvh), ALL_FEATURES)
        for shift in (0.0, 1.5):
            points = scene.points.copy()
            points[4:] += np.array([shift, 0.0, 0.0], np.float32)  # the pane's vertices
            ds.update(dataclasses.replace(scene, points=points))
            Rasterizer(launcher).render(ds, camera, gb, StageTimer())
            color = wp.zeros((H, W), dtype=wp.vec3, device=device)
            vis = wp.full((H, W, 1), value=float("nan"), dtype=wp.float32, device=device)
            tracer.trace(ds, camera, gb, pixels, W * H, color, vis, StageTimer())
            floor = (gb.triangle_id.numpy() >= 0) & (gb.triangle_id.numpy() < 2)
            x = gb.position.numpy()[..., 0]
            tinted = floor & (vis.numpy()[..., 0] < 1.0)
            shadows.append(x[tinted].mean())
    assert abs(shadows[0]) < 0.05 and abs(shadows[1] - 1.5) < 0.05


@pytest.mark.parametrize("opacity", [0.3, 1.0])
def test_packets_of_pixels_trace_what_one_pixel_at_a_time_does(opacity: float) -> None:
    """The CPU's primary shadow kernel traces eight list items' rays toward a light as one
    packet (``wide_any_hit_packet``): past opaque panes and through two glass ones (the
    ordered walk, one or two layers), toward a hard light and a soft spot and rect light
    (three samples each; each light's reach decided for the packet at once, ``_reach_group``),
    over a shuffled list whose length is no multiple of eight, with misses in it, again
    from the still view's cache, and traced once more (the cache's partial transmittances
    then send groups through the glass walk without the any-hit pass first:
    ``crossed``), it gives every pixel the transmittance, the visibility and the ray count
    that Warp's own queries, one pixel a thread, give."""
    scene, cam = pane_scene(opacity, panes=2)
    # (a spot: the points outside its cone get no ray)
    bulb = Light(
        LightKind.SPHERE,
        "/bulb",
        (20.0, 20.0, 20.0),
        position=(0.5, 3.0, 0.5),
        radius=0.4,
        direction=(0.0, -1.0, 0.0),
        cone_angle_deg=25.0,
    )
    panel = Light(
        LightKind.RECT,
        "/panel",
        (6.0, 6.0, 6.0),
        position=(-0.5, 2.5, 0.0),
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.4, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.3),
    )
    scene = dataclasses.replace(scene, lights=[*scene.lights, bulb, panel])
    ds = DeviceScene(scene, "cpu")
    camera = make_camera_gpu(cam, W, H)
    gb = GBuffer(W, H, "cpu")
    order = np.random.default_rng(3).permutation(W * H).astype(np.int32)
    count = W * H - 5
    pixels = wp.array(order, dtype=wp.int32, device="cpu")
    results = []
    with Launcher("cpu", threads=2) as launcher:
        Rasterizer(launcher).render(ds, camera, gb, StageTimer())
        assert 0 < (gb.triangle_id.numpy() < 0).sum() < W * H  # the list holds misses
        for wide_bvh in (None, False):
            tracer = Tracer(launcher, TraceSettings(wide_bvh=wide_bvh, shadow_samples=3, seed=5), ALL_FEATURES)
            runs = []
            for reuse in (False, True, False):
                color = wp.zeros((H, W), dtype=wp.vec3, device="cpu")
                vis = wp.full((H, W, 3), value=float("nan"), dtype=wp.float32, device="cpu")
                tracer.begin_frame(W, H)
                tally = tracer.trace(ds, camera, gb, pixels, count, color, vis, StageTimer(), reuse_shadows=reuse)
                runs.append((color.numpy(), vis.numpy(), tally.counts().shadow))
            results.append(runs)
    for (color, vis, rays), (color_ref, vis_ref, rays_ref) in zip(*results):
        np.testing.assert_array_equal(vis, vis_ref)
        np.testing.assert_array_equal(color, color_ref)
        assert rays == rays_ref
    vis = results[0][0][1]
    assert (vis == 1.0).any() and (((vis > 0.0) & (vis < 1.0)) if opacity < 1.0 else (vis == 0.0)).any()
    if opacity < 1.0:  # (under the sun straight above: through one pane, and through both)
        sun = vis[..., 0]
        assert len(np.unique(np.round(sun[(sun > 0.0) & (sun < 1.0)], 4))) >= 2
    # traced, then the primary hits' rays from the cache (what is left: the reflections' shadow rays)
    assert results[0][0][2] > count and results[0][1][2] < results[0][0][2] / 4 and results[0][2][2] == results[0][0][2]
