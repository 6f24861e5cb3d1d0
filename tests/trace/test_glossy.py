"""Glossy reflections fade out smoothly: a traced mirror ray carries ``mirror_share`` of
the specular reflection, 1 up to ``GLOSSY_ROUGHNESS`` and 0 from ``SMOOTH_ROUGHNESS``,
so a floor's mirror image dims continuously as its roughness crosses the cut instead of
switching off between two close roughness values."""

from __future__ import annotations

import numpy as np
import warp as wp

from warp_hybrid.core.constants import GLOSSY_ROUGHNESS, SMOOTH_ROUGHNESS, mirror_share
from warp_hybrid.core.scene_gpu import AmbientGPU
from warp_hybrid.lighting.ambient import env_brdf
from warp_hybrid.renderer import Renderer, RenderSettings
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Material


@wp.kernel
def _share_kernel(roughness: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = mirror_share(roughness[i])


@wp.kernel
def _env_brdf_kernel(
    amb: AmbientGPU, f0: wp.vec3, roughness: float, n_dot_v: wp.array(dtype=float), out: wp.array(dtype=wp.vec3)
):
    i = wp.tid()
    out[i] = env_brdf(amb, f0, roughness, n_dot_v[i])


def test_mirror_share_is_a_smoothstep_between_the_two_cuts(device: str) -> None:
    r = np.linspace(0.0, 1.0, 401).astype(np.float32)
    out = wp.zeros(len(r), dtype=float, device=device)
    wp.launch(_share_kernel, dim=len(r), inputs=[wp.array(r, dtype=float, device=device)], outputs=[out], device=device)
    share = out.numpy()
    t = np.clip((r - GLOSSY_ROUGHNESS) / (SMOOTH_ROUGHNESS - GLOSSY_ROUGHNESS), 0.0, 1.0)
    np.testing.assert_allclose(share, 1.0 - t * t * (3.0 - 2.0 * t), atol=1e-6)
    assert np.all(share[r <= GLOSSY_ROUGHNESS] == 1.0) and np.all(share[r >= SMOOTH_ROUGHNESS] == 0.0)
    assert np.all(np.diff(share) <= 0.0)


def test_the_feature_rule_follows_the_cut() -> None:
    assert Material("m", roughness=SMOOTH_ROUGHNESS - 0.01).is_reflective
    assert not Material("m", roughness=SMOOTH_ROUGHNESS).is_reflective


def _reflected(device: str, roughness: float) -> tuple[np.ndarray, np.ndarray]:
    """The traced radiance (red) of the floor pixels and the split-sum reflectance the
    tracer weighs their mirror rays by, for a black (specular-only) floor facing an
    emissive wall, no lights, no dome."""
    floor = Material("floor", diffuse=(0.0, 0.0, 0.0), roughness=roughness)
    wall = Material("wall", diffuse=(0.0, 0.0, 0.0), emissive=(4.0, 4.0, 4.0), roughness=1.0)
    camera = look_at_camera((0.0, 1.0, 3.0), (0.0, 0.0, 0.0), hfov_deg=30.0)
    scene = make_scene(
        [
            quad((-4.0, 0.0, 4.0), (8.0, 0.0, 0.0), (0.0, 0.0, -8.0), 0, "/floor"),
            quad((-4.0, 0.0, -4.0), (8.0, 0.0, 0.0), (0.0, 4.0, 0.0), 1, "/wall"),
        ],
        [floor, wall],
        cameras=[camera],
    )
    settings = RenderSettings(width=32, height=24, device=device, mode="full", exposure_ev=0.0, antialias=False)
    with Renderer(scene, settings) as r:
        frame = r.render(camera)
        gb = frame.gbuffer
        on_floor = gb.material_id.numpy() == 0
        position = gb.position.numpy()[on_floor]
        view = np.asarray(camera.cam_to_world)[:3, 3] - position
        n_dot_v = (view[:, 1] / np.linalg.norm(view, axis=1)).astype(np.float32)
        weights = wp.zeros(len(n_dot_v), dtype=wp.vec3, device=device)
        f0 = wp.vec3(*gb.specular.numpy()[on_floor][0].tolist())
        wp.launch(
            _env_brdf_kernel,
            dim=len(n_dot_v),
            inputs=[r.device_scene.ambient, f0, roughness, wp.array(n_dot_v, dtype=float, device=device)],
            outputs=[weights],
            device=device,
        )
    assert on_floor.sum() > 100
    return frame.color[on_floor][:, 0].astype(np.float64), weights.numpy()[:, 0].astype(np.float64)


def test_a_floor_dims_its_reflection_continuously_across_the_cut(device: str) -> None:
    """Stepping the floor's roughness by 0.025 from 0.15 to 0.55, each floor pixel's
    mirror image is exactly ``mirror_share(r)`` times the split-sum-weighted mirror
    image (1e-5): whole below the band, gone from its top, a smoothstep between; the
    floor's mean never rises and no step drops more than a fifth of it (a hard cut
    drops all of it in one step)."""
    steps = np.round(np.arange(0.15, 0.5501, 0.025), 3)
    base, base_weight = _reflected(device, 0.0)
    lit = base > 0.0  # pixels whose mirror ray meets the wall
    assert lit.sum() > 50
    wall = base[lit] / base_weight[lit]  # the wall's radiance, as the mirror sees it
    np.testing.assert_allclose(wall, 4.0, rtol=1e-5)
    means = []
    for r in steps:
        color, weight = _reflected(device, float(r))
        t = np.clip((r - GLOSSY_ROUGHNESS) / (SMOOTH_ROUGHNESS - GLOSSY_ROUGHNESS), 0.0, 1.0)
        share = 1.0 - t * t * (3.0 - 2.0 * t)
        np.testing.assert_allclose(color[lit], share * weight[lit] * 4.0, rtol=1e-4, atol=1e-7)
        assert np.all(color[~lit] == 0.0)
        means.append(color.mean())
    means = np.asarray(means)
    assert np.all(means[steps >= SMOOTH_ROUGHNESS] == 0.0) and means[0] > 0.0
    assert np.all(np.diff(means) <= 1e-9)
    assert (-np.diff(means) / means[0]).max() < 0.2
