"""The renderer as a library: AOV contract, primary paths, injected clock, animation."""

from __future__ import annotations

import contextlib
import copy
import dataclasses

import numpy as np
import pytest
import warp as wp

from warp_hybrid.band_pool import BandPool, layout_matches
from warp_hybrid.errors import RenderSettingsError, SceneError
from warp_hybrid.parallel import Launcher
from warp_hybrid.post.postprocess import PostProcess
from warp_hybrid.primary.base import PrimaryVisibility
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.model import Light, LightKind, Material

W, H = 80, 60


def sphere_scene(center_x: float = 0.0):
    """A grey sphere over a floor, a sun, a camera at +Z looking at the origin."""
    mats = [
        Material("grey", diffuse=(0.5, 0.5, 0.5), roughness=0.8),
        Material("floor", diffuse=(0.3, 0.3, 0.3), roughness=0.9),
    ]
    meshes = [uv_sphere((center_x, 0.0, 0.0), 1.0, 32, 64, 0), quad((-4, -1, 4), (8, 0, 0), (0, 0, -8), 1, "/floor")]
    sun = Light(LightKind.DISTANT, "/sun", (3.0, 3.0, 3.0), direction=(0.3, -1.0, -0.2))
    cam = look_at_camera((0.0, 0.5, 6.0), (0.0, 0.0, 0.0), hfov_deg=50.0)
    return make_scene(meshes, mats, [sun], [cam])


class StepClock:
    """Advances one millisecond per reading."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        self.t += 0.001
        return self.t


def test_aov_contract(device: str) -> None:
    scene = sphere_scene()
    with Renderer(scene, RenderSettings(width=W, height=H, device=device)) as r:
        frame = r.render(scene.cameras[0])
    aovs = frame.aovs()
    assert set(aovs) == {"depth", "position", "normal", "albedo", "color", "visibility"}
    assert aovs["visibility"].shape == (H, W, 1) and aovs["visibility"].dtype == np.float32
    assert aovs["depth"].shape == (H, W) and aovs["depth"].dtype == np.float32
    for k in ("position", "normal", "albedo", "color"):
        assert aovs[k].shape == (H, W, 3) and aovs[k].dtype == np.float32
    hit = np.isfinite(aovs["depth"])
    assert hit[H // 2, W // 2] and not hit[0, 0]  # sphere at the centre, sky in the top corner
    assert np.isposinf(aovs["depth"][~hit]).all()
    assert np.isnan(aovs["position"][~hit]).all() and np.isnan(aovs["normal"][~hit]).all()
    n = aovs["normal"][hit]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    # normals face the camera
    cam_pos = scene.cameras[0].position
    to_cam = cam_pos - aovs["position"][hit]
    assert (np.einsum("ij,ij->i", n, to_cam) > 0).all()
    # depth is the distance along the forward axis
    fwd = scene.cameras[0].forward
    np.testing.assert_allclose(aovs["depth"][hit], (aovs["position"][hit] - cam_pos) @ fwd, rtol=1e-4)
    assert frame.image.shape == (H, W, 3) and frame.image.dtype == np.uint8
    assert frame.stats["resolution"] == [W, H] and frame.stats["triangles"] == scene.triangle_count


def test_raster_and_raycast_primary_agree(device: str) -> None:
    scene = sphere_scene()
    frames = {}
    for primary in ("raster", "raycast"):
        with Renderer(scene, RenderSettings(width=W, height=H, device=device, primary=primary, exposure_ev=0.0)) as r:
            frames[primary] = r.render(scene.cameras[0]).aovs()
    a, b = frames["raster"], frames["raycast"]
    same_hit = np.isfinite(a["depth"]) == np.isfinite(b["depth"])
    assert same_hit.mean() > 0.99
    both = np.isfinite(a["depth"]) & np.isfinite(b["depth"])
    close = np.isclose(a["color"], b["color"], rtol=1e-3, atol=1e-5).all(axis=2)
    assert close[both].mean() > 0.99


def test_injected_clock_times_every_stage(device: str) -> None:
    scene = sphere_scene()
    clock = StepClock()
    with Renderer(scene, RenderSettings(width=W, height=H, device=device), clock=clock) as r:
        frame = r.render(scene.cameras[0])
    stages = frame.stats["stages_ms"]
    assert {"raster", "resolve", "surface", "lighting", "tonemap", "aa"} <= set(stages)
    # each stage reads the clock twice, one tick apart: exactly 1 ms per stage; tracing is
    # one pass, timed so, and split between its two stages
    traced = stages.pop("trace_shadow") + stages.pop("trace_secondary")
    assert traced == pytest.approx(1.0)
    # the raster frame's surface pass resolves the hit record itself: "resolve" stays, 0 ms
    assert stages.pop("resolve") == 0.0
    assert all(v == pytest.approx(1.0) for v in stages.values())
    assert r.setup_ms == {"upload": pytest.approx(1.0), "bvh_build": pytest.approx(1.0)}


@pytest.mark.parametrize("primary", ["raster", "raycast"])
@pytest.mark.parametrize("wide_bvh", [None, False])
def test_update_scene_refits_moved_geometry(device: str, primary: str, wide_bvh: bool | None) -> None:
    """The moved sphere is where the next frame draws it, through every BVH its passes
    query: the rasterizer or ray-cast primaries, the tracer's 4-wide copies (the CPU's
    default) or Warp's own trees."""
    scene = sphere_scene()
    settings = RenderSettings(width=W, height=H, device=device, primary=primary, wide_bvh=wide_bvh)
    with Renderer(scene, settings) as r:
        before = r.render(scene.cameras[0]).aovs()["depth"].copy()
        r.update_scene(sphere_scene(center_x=1.5))
        after = r.render(scene.cameras[0]).aovs()["depth"]
    cols_before = np.where(np.isfinite(before[H // 2]) & (before[H // 2] < 5.9))[0]
    cols_after = np.where(np.isfinite(after[H // 2]) & (after[H // 2] < 5.9))[0]
    assert cols_after.mean() > cols_before.mean() + 5  # the sphere moved right on screen


@pytest.mark.parametrize(
    "settings, message",
    [
        (RenderSettings(width=0), "out of range"),
        (RenderSettings(primary="magic"), "primary path"),
        (RenderSettings(tonemap="filmic"), "tone mapping"),
        (RenderSettings(device="cuda:7"), "not available"),
    ],
)
def test_bad_settings_are_clear_errors(settings: RenderSettings, message: str) -> None:
    with pytest.raises(RenderSettingsError, match=message):
        Renderer(sphere_scene(), settings)


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_a_light_added_between_two_times_is_lit(device: str, mode: str) -> None:
    """``update_scene`` with one more light (and a recoloured material) gives the frame a
    fresh renderer of the new scene gives: lights, materials and the visibility AOV are
    re-uploaded, not just the points."""
    before = sphere_scene()
    lamp = Light(LightKind.SPHERE, "/lamp", (40.0, 10.0, 10.0), position=(2.0, 2.0, 2.0), radius=0.1)
    red = dataclasses.replace(before.materials[0], diffuse=(0.8, 0.1, 0.1))
    after = dataclasses.replace(before, lights=[*before.lights, lamp], materials=[red, before.materials[1]])
    settings = dict(width=W, height=H, device=device, mode=mode, exposure_ev=0.0, threads=1)
    cam = before.cameras[0]
    with Renderer(before, RenderSettings(**settings)) as renderer:
        first = renderer.render(cam)
        renderer.update_scene(after)
        second = renderer.render(cam)
    with Renderer(after, RenderSettings(**settings)) as fresh:
        reference = fresh.render(cam)
    np.testing.assert_array_equal(second.color, reference.color)
    np.testing.assert_array_equal(second.visibility, reference.visibility)
    assert second.visibility.shape == (H, W, 2) and first.visibility.shape == (H, W, 1)
    hit = second.gbuffer.hit_mask()
    gain = second.color[hit].sum(axis=-1) - first.color[hit].sum(axis=-1)
    assert np.mean(gain > 0.0) > 0.3  # the lamp lights a good part of what is seen


def test_topology_change_is_refused_clearly(device: str) -> None:
    scene = sphere_scene()
    other = make_scene([quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), 0)], scene.materials, scene.lights, scene.cameras)
    with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode="raster", threads=1)) as renderer:
        with pytest.raises(SceneError, match="topology changed"):
            renderer.update_scene(other)


@pytest.mark.parametrize("blended", [False, True])
@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_automatic_exposure_meters_the_raster_layer_as_drawn(device: str, mode: str, blended: bool) -> None:
    """On the CPU the lighting row loop meters the raster layer as it writes it
    (``FrameContext.metered_rows``) and the post stage sums its rows; the frame's EV is
    still the post stage's own metering of the layer as the frame left it, at the
    G-buffer's hit pixels, bit for bit: also where a later pass changes the layer (the
    layer behind an alpha-blended sphere, blended in)."""
    scene = sphere_scene()
    if blended:
        grey = dataclasses.replace(scene.materials[0], opacity=0.4, alpha_blended=True)
        scene = dataclasses.replace(scene, materials=[grey, *scene.materials[1:]])
    with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode=mode, threads=2)) as r:
        frame = r.render(scene.cameras[0])
        post = PostProcess(r.launcher)
        post.auto_exposure(r.buffers.raster_color, r.buffers.gbuffer.triangle_id)
        assert frame.stats["exposure_ev"] != 0.0
        assert frame.stats["exposure_ev"] == post.last_exposure_ev


@pytest.mark.parametrize("blended", [False, True])
@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_passes_running_on_past_their_call_draw_the_frame_that_waits_for_each(
    device: str, mode: str, blended: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A frame whose passes run on while the next pass's Python prepares
    (``Launcher.overlapping``) is the frame that waits for every pass, bit for bit (image,
    colour, visibility, AOVs, EV; an alpha-blended sphere's second layer too), and its
    stages, the waits charged to the passes waited for, are each >= 0."""
    scene = sphere_scene()
    if blended:
        grey = dataclasses.replace(scene.materials[0], opacity=0.4, alpha_blended=True)
        scene = dataclasses.replace(scene, materials=[grey, *scene.materials[1:]])
    posted = []  # the passes posted without waiting for them
    run = BandPool.run
    monkeypatch.setattr(
        BandPool, "run", lambda pool, *a, wait=True, **k: posted.append(wait) or run(pool, *a, wait=wait, **k)
    )
    frames = {}
    for overlap in (True, False):
        if not overlap:
            monkeypatch.setattr(Launcher, "overlapping", lambda self, timer: contextlib.nullcontext())
        with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode=mode, threads=2)) as r:
            frames[overlap] = [r.render(scene.cameras[0]) for _ in range(2)]
        if overlap and wp.get_device(device).is_cpu and layout_matches():
            assert posted.count(False) >= 10  # (the raster passes, the exposure, the post)
    for ran_on, waited in zip(frames[True], frames[False], strict=True):
        np.testing.assert_array_equal(ran_on.image, waited.image)
        for name, aov in waited.aovs().items():
            np.testing.assert_array_equal(ran_on.aovs()[name], aov, err_msg=name)
        assert ran_on.stats["exposure_ev"] == waited.stats["exposure_ev"] != 0.0
        assert min(ran_on.stats["stages_ms"].values()) >= 0.0
        assert set(ran_on.stats["stages_ms"]) == set(waited.stats["stages_ms"])


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_the_geometric_normals_are_drawn_where_a_pass_reads_them(device: str, mode: str) -> None:
    """A raster frame without shadow maps leaves the geometric normals out (no traced ray
    leaves its surfaces, no shadow map is looked up) and says so; every other channel and
    the image are what a frame drawing them holds, bit for bit.  A hybrid frame and a raster
    frame with shadow maps draw them: unit face normals facing the camera."""
    scene = sphere_scene()
    cam = scene.cameras[0]
    frames = {}
    for draw in (False, True):
        with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode=mode)) as r:
            if draw:
                next(p for p in r.passes if isinstance(p, PrimaryVisibility)).geometric_normals = True
            frames[draw] = r.render(cam)
            assert r.buffers.gbuffer.geometric_normals == (draw or mode != "raster")
    kept, drawn = frames[False], frames[True]
    np.testing.assert_array_equal(kept.image, drawn.image)
    for name, array in drawn.gbuffer.arrays().items():
        if name != "geometric_normal" or mode != "raster":
            np.testing.assert_array_equal(kept.gbuffer.channel_numpy(name), drawn.gbuffer.channel_numpy(name), name)
    if mode == "raster":
        assert not kept.gbuffer.geometric_normal.numpy().any()  # (the cleared buffer's zero)
    for frame in (drawn, kept if mode != "raster" else None):
        if frame is None:
            continue
        hit = frame.gbuffer.hit_mask()
        ng = frame.gbuffer.channel_numpy("geometric_normal")[hit]
        np.testing.assert_allclose(np.linalg.norm(ng, axis=1), 1.0, atol=1e-5)
    with Renderer(scene, RenderSettings(width=W, height=H, device=device, mode="raster", shadow_maps=True)) as r:
        assert r.render(cam).gbuffer.geometric_normals


def test_a_camera_changed_in_place_is_drawn_and_checked_again(device: str) -> None:
    """The renderer keeps the last frame's kernel camera while the camera's values stay
    the same; a camera moved in place (the same object), zoomed or made unusable between
    frames is drawn from, or refused by, its new values, as a fresh renderer would."""
    scene = sphere_scene()
    cam = scene.cameras[0]
    settings = RenderSettings(width=W, height=H, device=device)
    depths, states = [], []
    with Renderer(scene, settings) as r:
        for change in (None, "move", "zoom"):
            if change == "move":
                cam.cam_to_world[0, 3] += 1.5
            elif change == "zoom":
                cam.focal_length *= 2.0
            depths.append(r.render(cam).aovs()["depth"].copy())
            np.testing.assert_array_equal(r.render(cam).aovs()["depth"], depths[-1])
            states.append(copy.deepcopy(cam))
        cam.cam_to_world[:3, :3] = 0.0  # scaled by 0: no view
        with pytest.raises(RenderSettingsError, match="scales it by 0"):
            r.render(cam)
    assert not np.array_equal(depths[1], depths[0]) and not np.array_equal(depths[2], depths[1])
    for depth, state in zip(depths, states, strict=True):
        with Renderer(scene, settings) as fresh:
            np.testing.assert_array_equal(fresh.render(state).aovs()["depth"], depth)


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_the_emission_channel_follows_the_scene_to_no_emitter_and_back(device: str, mode: str) -> None:
    """A scene without an emissive material leaves the emission channel at its zero once
    it holds zero everywhere (the surface pass no longer writes it); a scene updated from
    an emitter to none and back gets, frame by frame, the G-buffer and colour a fresh
    renderer of that scene gets."""
    glowing = sphere_scene()
    glowing = dataclasses.replace(
        glowing, materials=[dataclasses.replace(glowing.materials[0], emissive=(2.0, 1.0, 0.5)), glowing.materials[1]]
    )
    dark = sphere_scene()
    settings = dict(width=W, height=H, device=device, mode=mode, exposure_ev=0.0, threads=2)
    cam = dark.cameras[0]
    with Renderer(glowing, RenderSettings(**settings)) as r:
        for scene in (glowing, dark, dark, glowing, dark):
            r.update_scene(scene)
            frame = r.render(cam)
            gb = frame.gbuffer
            with Renderer(scene, RenderSettings(**settings)) as fresh:
                reference = fresh.render(cam)
            np.testing.assert_array_equal(gb.channel_numpy("emission"), reference.gbuffer.channel_numpy("emission"))
            np.testing.assert_array_equal(frame.color, reference.color)
            assert gb.channel_numpy("emission").any() == (scene is glowing)
            assert gb.emission_background == (scene is dark)
        # (a channel known to hold zero is not written again: what else writes it must clear)
        gb.emission.fill_(wp.vec3(7.0, 7.0, 7.0))
        r.render(cam)
        assert (gb.channel_numpy("emission") == 7.0).all()
        gb.clear()
        r.render(cam)
        np.testing.assert_array_equal(gb.channel_numpy("emission"), reference.gbuffer.channel_numpy("emission"))
