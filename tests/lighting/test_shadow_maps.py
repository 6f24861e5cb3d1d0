"""Shadow maps for the raster layer: they agree with the traced shadows, leave every pixel
of an unshadowed frame as it was, are drawn once for a still scene and again when it
moves, and refuse bad settings clearly."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from bad_input_kit import run_cli
from scipy.ndimage import maximum_filter, minimum_filter

from warp_hybrid import Renderer, RenderSettings, cli
from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.errors import ArgumentTypeError, RenderSettingsError
from warp_hybrid.lighting.deferred import SHADE_KERNELS, DeferredLighting
from warp_hybrid.lighting.shadow_maps import ShadowMaps, light_faces
from warp_hybrid.scene.authoring.builders import MeshInput, look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Light, LightKind, Material, Scene
from warp_hybrid.timing import StageTimer

W, H = 96, 72
MAP_SIZE = 256
FLOOR_TRIANGLES = 2  # the floor quad's triangles come first
LIGHTS = {
    "sphere": Light(LightKind.SPHERE, "/bulb", (60.0, 60.0, 60.0), position=(1.5, 5.0, 2.0), radius=0.1),
    "distant": Light(
        LightKind.DISTANT,
        "/sun",
        (3.0, 3.0, 3.0),
        direction=tuple((np.array([0.4, -1.0, 0.3]) / math.sqrt(1.25)).tolist()),
    ),
    "rect": Light(
        LightKind.RECT,
        "/panel",
        (30.0, 30.0, 30.0),
        position=(-1.5, 4.5, 0.5),
        direction=(0.0, -1.0, 0.0),
        axis_u=(0.5, 0.0, 0.0),
        axis_v=(0.0, 0.0, 0.5),
    ),
}


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float], material: int) -> list[MeshInput]:
    """An axis-aligned box as six quads (outward facing)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    return [
        quad((x0, y0, z1), (dx, 0, 0), (0, dy, 0), material),  # +z
        quad((x1, y0, z0), (-dx, 0, 0), (0, dy, 0), material),  # -z
        quad((x1, y0, z1), (0, 0, -dz), (0, dy, 0), material),  # +x
        quad((x0, y0, z0), (0, 0, dz), (0, dy, 0), material),  # -x
        quad((x0, y1, z1), (dx, 0, 0), (0, 0, -dz), material),  # +y
        quad((x0, y0, z0), (dx, 0, 0), (0, 0, dz), material),  # -y
    ]


def _scene(light: Light) -> Scene:
    """A quad floor (y = 0, 16 x 16), a box floating 0.6 above it, one light, a camera
    looking down at the floor from the front (the floor fills the view)."""
    mats = [
        Material("/floor", diffuse=(0.8, 0.8, 0.8), roughness=0.9),
        Material("/box", diffuse=(0.5, 0.4, 0.3), roughness=0.9),
    ]
    floor = quad((-8.0, 0.0, 8.0), (16.0, 0.0, 0.0), (0.0, 0.0, -16.0), 0)
    meshes = [floor, *_box((-1.0, 0.6, -1.0), (1.0, 2.2, 1.0), 1)]
    cam = look_at_camera((0.0, 6.0, 5.0), (0.0, 0.0, 0.0), hfov_deg=60.0)
    return make_scene(meshes, mats, lights=[light], cameras=[cam])


def _settings(mode: str, **extra: object) -> RenderSettings:
    return RenderSettings(width=W, height=H, mode=mode, antialias=False, exposure_ev=0.0, **extra)


def _interior_floor(gbuffer_ids: np.ndarray, visibility: np.ndarray, radius: int = 2) -> np.ndarray:
    """Floor pixels whose (2 radius + 1)^2 neighbourhood is all floor with one traced
    visibility: away from silhouettes and from shadow edges."""
    floor = (gbuffer_ids >= 0) & (gbuffer_ids < FLOOR_TRIANGLES)
    size = 2 * radius + 1
    all_floor = minimum_filter(floor.astype(np.uint8), size=size, mode="nearest") == 1
    flat = maximum_filter(visibility, size=size, mode="nearest") == minimum_filter(
        visibility, size=size, mode="nearest"
    )
    return floor & all_floor & flat


@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_shadow_maps_agree_with_traced_shadows(device: str, kind: str) -> None:
    """On the floor away from edges, shadow-map visibility agrees with the traced one on
    >= 99% of the pixels, and the raster layer lit through the maps matches full ray
    tracing there; the shadow is real (a good share of the floor is in it)."""
    scene = _scene(LIGHTS[kind])
    cam = scene.cameras[0]
    with Renderer(scene, _settings("full", device=device)) as full:
        traced = full.render(cam)
        ids = traced.gbuffer.triangle_id.numpy()
        maps = ShadowMaps(full.launcher, MAP_SIZE)
        maps.set_scene(full.device_scene)
        assert maps.update()
        mapped = maps.visibility(traced.gbuffer)[..., 0]
    vis = traced.visibility[..., 0]
    interior = _interior_floor(ids, vis)
    assert interior.sum() > 0.5 * W * H
    shadowed = interior & (vis == 0.0)
    assert shadowed.sum() > 100, "the box must shadow a part of the floor in view"
    agree = np.abs(mapped - vis)[interior] < 0.5
    assert agree.mean() >= 0.99, f"{kind}: {agree.mean():.4f} of the interior floor agrees"

    with Renderer(scene, _settings("raster", device=device, shadow_maps=True, shadow_map_size=MAP_SIZE)) as raster:
        lit = raster.render(cam).color
    close = np.isclose(lit, traced.color, rtol=1e-3, atol=1e-5).all(axis=-1)[interior]
    assert close.mean() >= 0.99, f"{kind}: {close.mean():.4f} of the interior floor has the traced colour"


def test_hybrid_window_shows_no_shadow_pop(device: str) -> None:
    """A hybrid frame with shadow maps: inside the window (traced), across its feather
    and outside it (shadow-mapped), the interior floor has full ray tracing's colour."""
    scene = _scene(LIGHTS["sphere"])
    cam = scene.cameras[0]
    with Renderer(scene, _settings("full", device=device)) as full:
        traced = full.render(cam)
    settings = _settings("hybrid", device=device, shadow_maps=True, shadow_map_size=MAP_SIZE, window_fraction=0.2)
    with Renderer(scene, settings) as hybrid:
        mixed = hybrid.render(cam, hybrid.default_window((0.55, 0.6))).color
    interior = _interior_floor(traced.gbuffer.triangle_id.numpy(), traced.visibility[..., 0])
    close = np.isclose(mixed, traced.color, rtol=1e-3, atol=1e-5).all(axis=-1)[interior]
    assert close.mean() >= 0.99


@pytest.mark.parametrize("mode", ["raster", "hybrid"])
def test_off_is_bit_identical(device: str, mode: str) -> None:
    """With shadow maps off (the default) no map pass runs, the lighting kernel is the
    lighting module's own, and every pixel equals a render with the setting off
    explicitly."""
    scene = _scene(LIGHTS["sphere"])
    cam = scene.cameras[0]
    frames = []
    for settings in (_settings(mode, device=device), _settings(mode, device=device, shadow_maps=False)):
        with Renderer(scene, settings) as r:
            assert not any(isinstance(p, ShadowMaps) for p in r.passes)
            lighting = next(p for p in r.passes if isinstance(p, DeferredLighting))
            assert lighting.shadow_maps is None
            frames.append(r.render(cam))
            assert "shadow_maps" not in frames[-1].stats["stages_ms"]
    assert SHADE_KERNELS[False].module.name == "warp_hybrid.lighting.deferred"
    assert np.array_equal(frames[0].color, frames[1].color)
    assert np.array_equal(frames[0].image, frames[1].image)


def test_maps_are_drawn_once_until_the_scene_moves(device: str) -> None:
    """A still scene: drawn at warm-up, never in the frames after (stage "shadow_maps"
    each frame, the drawing counter still 1); moved points or a moved light draw them
    again, a new light colour does not; full mode has no map pass."""
    scene = _scene(LIGHTS["sphere"])
    cam = scene.cameras[0]
    with Renderer(scene, _settings("raster", device=device, shadow_maps=True, shadow_map_size=32)) as r:
        maps = next(p for p in r.passes if isinstance(p, ShadowMaps))
        r.warm_up(cam)
        assert maps.renders == 1
        for _ in range(3):
            frame = r.render(cam)
            assert "shadow_maps" in frame.stats["stages_ms"]
        assert maps.renders == 1
        moved = scene.points.copy()
        moved[4:] += np.array([0.3, 0.0, 0.0], dtype=np.float32)  # the box (the floor's 4 points first)
        scene = dataclasses.replace(scene, points=moved, time=1.0)
        r.update_scene(scene)
        r.render(cam)
        r.render(cam)
        assert maps.renders == 2
        light = dataclasses.replace(LIGHTS["sphere"], position=(1.0, 5.0, 2.0))
        scene = dataclasses.replace(scene, lights=[light])
        r.update_scene(scene)
        r.render(cam)
        assert maps.renders == 3
        r.update_scene(dataclasses.replace(scene, lights=[dataclasses.replace(light, color=(1.0, 2.0, 3.0))]))
        r.render(cam)
        assert maps.renders == 3
    with Renderer(scene, _settings("full", device=device, shadow_maps=True)) as r:
        assert not any(isinstance(p, ShadowMaps) for p in r.passes)


@pytest.mark.parametrize(
    ("panel", "casts"),
    [
        (Material("/emitter", emissive=(5.0, 5.0, 5.0)), False),
        (Material("/glass", opacity=0.2), False),
        (Material("/cut_away", opacity=0.2, opacity_threshold=0.5), False),
        (Material("/cut_kept", opacity=0.8, opacity_threshold=0.5), True),
        (Material("/opaque"), True),
    ],
    ids=lambda v: v.name.strip("/") if isinstance(v, Material) else str(v),
)
def test_which_surfaces_cast(device: str, panel: Material, casts: bool) -> None:
    """Emitters and transmissive surfaces cast no shadow-map shadow; cut-outs follow the
    rasterizer's alpha test (cut away: none, kept: a shadow); opaque ones cast."""
    mats = [Material("/floor", diffuse=(0.8, 0.8, 0.8), roughness=0.9), panel]
    meshes = [
        quad((-8.0, 0.0, 8.0), (16.0, 0.0, 0.0), (0.0, 0.0, -16.0), 0),
        quad((-1.0, 1.5, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 1),
    ]
    scene = make_scene(meshes, mats, lights=[LIGHTS["sphere"]], cameras=[_scene(LIGHTS["sphere"]).cameras[0]])
    # (shadow maps on: a raster frame without them leaves the geometric normals the maps' lookups read out)
    with Renderer(scene, _settings("raster", device=device, shadow_maps=True)) as r:
        frame = r.render(scene.cameras[0])
        maps = ShadowMaps(r.launcher, 64)
        maps.set_scene(r.device_scene)
        maps.update()
        mapped = maps.visibility(frame.gbuffer)[..., 0]
    floor = frame.gbuffer.triangle_id.numpy() < FLOOR_TRIANGLES
    floor &= frame.gbuffer.triangle_id.numpy() >= 0
    shadowed = int((mapped[floor] < 0.5).sum())
    assert (shadowed > 100) if casts else (shadowed == 0), shadowed


def test_a_g_buffer_without_geometric_normals_is_refused_clearly(device: str) -> None:
    """A raster frame without shadow maps leaves the geometric normals out: the maps'
    lookups (the diagnostic, the shadow-mapped lighting) refuse its G-buffer, naming why."""
    scene = _scene(LIGHTS["sphere"])
    with Renderer(scene, _settings("raster", device=device)) as r:
        frame = r.render(scene.cameras[0])
        assert not frame.gbuffer.geometric_normals
        maps = ShadowMaps(r.launcher, 64)
        maps.set_scene(r.device_scene)
        maps.update()
        with pytest.raises(ValueError, match="ShadowMaps.visibility reads the G-buffer's geometric normals"):
            maps.visibility(frame.gbuffer)
        color = r.buffers.raster_color
        with pytest.raises(ValueError, match="shadow-mapped lighting reads the G-buffer's geometric normals"):
            DeferredLighting(r.launcher, maps).shade(
                r.device_scene, make_camera_gpu(scene.cameras[0], W, H), frame.gbuffer, color, StageTimer(), maps.gpu
            )


def test_one_sided_lights_draw_only_their_side() -> None:
    """A rect light facing down draws the five faces that see below it, a sphere light
    all six, a distant light one."""
    scene = _scene(LIGHTS["rect"])
    assert [drawn for _, drawn in light_faces(LIGHTS["rect"], scene, 16)] == [True, True, False, True, True, True]
    assert all(drawn for _, drawn in light_faces(LIGHTS["sphere"], scene, 16))
    assert len(light_faces(LIGHTS["distant"], scene, 16)) == 1


def test_bad_settings_are_refused_clearly(capsys: pytest.CaptureFixture) -> None:
    """A non-bool switch names the field; a size out of range says the range; the CLI
    maps --shadow-maps/--shadow-map-size and refuses a bad size in one line."""
    with pytest.raises(ArgumentTypeError, match=r"RenderSettings.shadow_maps must be True or False, got str 'yes'"):
        RenderSettings(shadow_maps="yes").validate()  # type: ignore[arg-type]
    with pytest.raises(ArgumentTypeError, match=r"RenderSettings.shadow_map_size must be an integer"):
        RenderSettings(shadow_map_size=2.5).validate()  # type: ignore[arg-type]
    for size in (0, 8, 4097, -1):
        with pytest.raises(
            RenderSettingsError, match=rf"shadow map size must be in 16..4096 texels per face, got {size}"
        ):
            RenderSettings(shadow_map_size=size).validate()
    args = cli.build_parser().parse_args(
        ["render", "x.usda", "-o", "x.png", "--shadow-maps", "--shadow-map-size", "64"]
    )
    settings = cli._render_settings(args)
    assert settings.shadow_maps is True and settings.shadow_map_size == 64
    plain = cli._render_settings(cli.build_parser().parse_args(["render", "x.usda", "-o", "x.png"]))
    assert plain.shadow_maps is False and plain.shadow_map_size == RenderSettings().shadow_map_size
    run = run_cli(capsys, ["render", "missing.usda", "-o", "x.png", "--shadow-maps", "--shadow-map-size", "0"])
    assert run.code == 2 and len(run.err) == 1
    assert "shadow map size must be in 16..4096 texels per face, got 0" in run.err[0]
