"""The pixel-list contract: listed pixels get exactly the full-frame result, others are
untouched, the work scales with the list, variants follow the scene's features, and
without secondary rays or shadows the traced shading is the raster shading."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from trace_kit import ALL_FEATURES, trace_scene

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.features import SceneFeatures
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.errors import RenderSettingsError
from warp_hybrid.lighting.deferred import DeferredLighting
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Environment, Light, LightKind, Material
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import TraceSettings, TraceVariant

W, H = 96, 72


def _showcase(environment: bool = True):
    """Floor, diffuse ball, glass ball, mirror, a distant and a sphere light, a dome."""
    mats = [
        Material("/floor", diffuse=(0.7, 0.7, 0.7), roughness=0.8),
        Material("/ball", diffuse=(0.8, 0.3, 0.2), roughness=0.5),
        Material("/glass", diffuse=(0.9, 1.0, 0.9), roughness=0.0, opacity=0.0, ior=1.5),
        Material("/mirror", diffuse=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.05),
    ]
    meshes = [
        quad((-4.0, 0.0, 4.0), (8.0, 0.0, 0.0), (0.0, 0.0, -8.0), 0),
        uv_sphere((-1.2, 0.8, 0.0), 0.8, 24, 48, 1),
        uv_sphere((1.0, 0.7, 0.5), 0.7, 24, 48, 2),
        quad((-3.0, 0.0, -2.0), (6.0, 0.0, 0.0), (0.0, 3.0, 0.0), 3),
    ]
    lights = [
        Light(LightKind.DISTANT, "/sun", (2.0, 1.9, 1.8), direction=(0.3, -1.0, -0.4)),
        Light(LightKind.SPHERE, "/bulb", (30.0, 30.0, 30.0), position=(2.0, 3.0, 2.0), radius=0.2),
    ]
    env = Environment("/dome", (0.2, 0.25, 0.3)) if environment else None
    cam = look_at_camera((0.0, 3.0, 7.0), (0.0, 0.5, 0.0), hfov_deg=60.0)
    return make_scene(meshes, mats, lights=lights, cameras=[cam], environment=env), cam


def test_listed_pixels_equal_the_full_frame_and_others_are_untouched(device: str) -> None:
    scene, cam = _showcase()
    full = trace_scene(scene, cam, device, W, H, features=ALL_FEATURES, threads=2)
    rng = np.random.default_rng(1)
    listed = rng.choice(W * H, size=W * H // 3, replace=False).astype(np.int32)
    part = trace_scene(scene, cam, device, W, H, pixels=listed, features=ALL_FEATURES)
    mask = np.zeros(W * H, bool)
    mask[listed] = True
    mask = mask.reshape(H, W)
    assert np.array_equal(part.color[mask], full.color[mask])
    assert np.array_equal(part.visibility[mask], full.visibility[mask], equal_nan=True)
    assert np.all(part.color[~mask] == 0.0) and np.all(np.isnan(part.visibility[~mask]))
    assert part.counts.traced_pixels == len(listed)
    # background pixels: the dome along the camera ray, no visibility
    bg = full.triangle_id < 0
    assert bg.sum() > 50
    assert np.allclose(full.color[bg], (0.2, 0.25, 0.3)) and np.all(np.isnan(full.visibility[bg]))
    hit = ~bg
    assert np.all((full.visibility[hit] >= 0.0) & (full.visibility[hit] <= 1.0))
    assert full.counts.reflection > 0 and full.counts.refraction > 0


def test_rays_scale_with_the_pixel_count(device: str) -> None:
    """Two interleaved halves of the frame launch half the rays each, and together
    exactly the rays of the full list."""
    scene, cam = _showcase()
    idx = np.arange(W * H, dtype=np.int32)
    full = trace_scene(scene, cam, device, W, H, features=ALL_FEATURES).counts
    even = trace_scene(scene, cam, device, W, H, pixels=idx[0::2], features=ALL_FEATURES).counts
    odd = trace_scene(scene, cam, device, W, H, pixels=idx[1::2], features=ALL_FEATURES).counts
    for kind in ("traced_pixels", "shadow", "reflection", "refraction"):
        total = getattr(full, kind)
        assert getattr(even, kind) + getattr(odd, kind) == total
        assert abs(getattr(even, kind) - total / 2) <= 0.03 * total


def test_diffuse_scene_compiles_and_launches_no_secondary_rays(device: str) -> None:
    mats = [Material("/floor", roughness=0.9), Material("/ball", diffuse=(0.5, 0.5, 0.2), roughness=0.7)]
    scene = make_scene(
        [quad((-3.0, 0.0, 3.0), (6.0, 0.0, 0.0), (0.0, 0.0, -6.0), 0), uv_sphere((0.0, 1.0, 0.0), 1.0, 16, 32, 1)],
        mats,
        lights=[Light(LightKind.DISTANT, "/sun", (1.0, 1.0, 1.0), direction=(0.2, -1.0, 0.1))],
    )
    cam = look_at_camera((0.0, 4.0, 6.0), (0.0, 0.5, 0.0))
    out = trace_scene(scene, cam, device, W, H)
    # the CPU queries the 4-wide BVH copies, CUDA Warp's own
    wide = wp.get_device(device).is_cpu
    assert out.tracer.variant == TraceVariant(SceneFeatures(shadows=True), wide_bvh=wide)
    assert out.counts.reflection == 0 and out.counts.refraction == 0
    assert out.counts.shadow > 0


def test_without_secondary_rays_the_traced_shading_is_the_raster_shading(device: str) -> None:
    """max_depth 0 and nothing casting a shadow (lit from the camera's side, no floor):
    every pixel equals the deferred lighting pass."""
    scene, cam = _showcase()
    scene = make_scene(
        [
            uv_sphere((-1.2, 0.8, 0.0), 0.8, 24, 48, 1),
            uv_sphere((1.0, 0.7, 0.5), 0.7, 24, 48, 2),
            quad((-3.0, -1.0, -2.0), (6.0, 0.0, 0.0), (0.0, 3.0, 0.0), 3),
        ],
        scene.materials,
        lights=[Light(LightKind.DISTANT, "/sun", (2.0, 1.9, 1.8), direction=(0.0, -0.4, -1.0))],
        environment=scene.environment,
    )
    out = trace_scene(scene, cam, device, W, H, settings=TraceSettings(max_depth=0), features=ALL_FEATURES)
    ds = DeviceScene(scene, device)
    gb = GBuffer(W, H, device)
    raster = wp.zeros((H, W), dtype=wp.vec3, device=device)
    with Launcher(device, threads=1) as launcher:
        camera = make_camera_gpu(cam, W, H)
        Rasterizer(launcher).render(ds, camera, gb, StageTimer())
        DeferredLighting(launcher).shade(ds, camera, gb, raster, StageTimer())
    vis = out.visibility[..., 0]
    lit = (out.triangle_id >= 0) & (vis == 1.0)
    assert lit.sum() > 0.9 * (out.triangle_id >= 0).sum()
    assert np.allclose(out.color[lit], raster.numpy()[lit], rtol=1e-5, atol=1e-6)
    assert np.allclose(out.color[out.triangle_id < 0], raster.numpy()[out.triangle_id < 0])
    assert out.counts.reflection == 0 and out.counts.refraction == 0


def test_foreign_list_entries_are_skipped_and_feature_mismatches_rejected(device: str) -> None:
    scene, cam = _showcase()
    listed = np.array([5, -1, W * H, W * H + 7, 17], dtype=np.int32)
    out = trace_scene(scene, cam, device, W, H, pixels=listed, features=ALL_FEATURES)
    written = np.flatnonzero(np.any(out.color.reshape(-1, 3) != 0.0, axis=1))
    assert set(written.tolist()) <= {5, 17} and out.counts.traced_pixels == len(listed)
    with pytest.raises(ValueError, match="reflections, refractions, transparency, environment"):
        trace_scene(scene, cam, device, W, H, features=SceneFeatures(shadows=True))


@pytest.mark.parametrize(
    "bad", [TraceSettings(max_depth=-1), TraceSettings(max_depth=99), TraceSettings(shadow_samples=0)]
)
def test_bad_settings_are_rejected(bad: TraceSettings) -> None:
    with pytest.raises(RenderSettingsError):
        bad.validate()
