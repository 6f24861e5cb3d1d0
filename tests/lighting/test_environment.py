"""The dome's lat-long convention, its radiance lookup, SH irradiance and prefiltering."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from warp_hybrid.core.scene_gpu import AmbientGPU, SceneGPU
from warp_hybrid.lighting.ambient import (
    dome_irradiance,
    prefiltered_radiance,
)
from warp_hybrid.scene.authoring.builders import make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.dome import radiance_mips
from warp_hybrid.scene.device.environment import (
    environment_direction,
    environment_radiance,
    environment_uv,
    environment_uv_wp,
    fast_atan2,
    sh_basis,
    sh_constant_coefficients,
    sh_irradiance_coefficients,
    texel_directions,
)
from warp_hybrid.scene.model import Environment, Material, TextureBinding, TextureImage

wp.set_module_options({"enable_backward": False})


def sh_eval(coeffs: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Evaluate SH coefficients (9, C) at unit directions (..., 3) -> (..., C)."""
    return sh_basis(np.asarray(dirs, dtype=np.float64)) @ np.asarray(coeffs, dtype=np.float64)


@wp.kernel
def env_kernel(
    scene: SceneGPU,
    amb: AmbientGPU,
    dirs: wp.array(dtype=wp.vec3),
    roughness: float,
    uv: wp.array(dtype=wp.vec2),
    radiance: wp.array(dtype=wp.vec3),
    irradiance: wp.array(dtype=wp.vec3),
    prefiltered: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    uv[i] = environment_uv_wp(dirs[i])
    radiance[i] = environment_radiance(scene, dirs[i])
    irradiance[i] = dome_irradiance(scene, amb, dirs[i])
    prefiltered[i] = prefiltered_radiance(scene, amb, dirs[i], roughness)


@wp.kernel
def atan2_kernel(y: wp.array(dtype=float), x: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = fast_atan2(y[i], x[i])


def _dome_scene(
    device: str, pixels: np.ndarray | None, color=(1.0, 1.0, 1.0), world_to_light=None, scale=None, bias=None
):
    images, textures, tex = [], [], -1
    if pixels is not None:
        images = [TextureImage("<test>", np.ascontiguousarray(pixels, dtype=np.float32))]
        textures = [TextureBinding(0, scale=scale or (1.0,) * 4, bias=bias or (0.0,) * 4)]
        tex = 0
    env = Environment("/dome", color, tex)
    if world_to_light is not None:
        env.world_to_light = np.asarray(world_to_light, np.float32)
    scene = make_scene(
        [quad((0, 0, 0), (1, 0, 0), (0, 1, 0))], [Material("m")], environment=env, images=images, textures=textures
    )
    return DeviceScene(scene, device)


def _eval(device: str, ds: DeviceScene, dirs: np.ndarray, roughness: float = 0.0) -> dict[str, np.ndarray]:
    amb = ds.ambient
    count = len(dirs)
    out = {
        "uv": wp.zeros(count, dtype=wp.vec2, device=device),
        "radiance": wp.zeros(count, dtype=wp.vec3, device=device),
        "irradiance": wp.zeros(count, dtype=wp.vec3, device=device),
        "prefiltered": wp.zeros(count, dtype=wp.vec3, device=device),
    }
    wp.launch(
        env_kernel,
        dim=count,
        inputs=[
            ds.gpu,
            amb,
            wp.array(np.asarray(dirs, np.float32), dtype=wp.vec3, device=device),
            float(roughness),
        ],
        outputs=list(out.values()),
        device=device,
    )
    return {k: a.numpy() for k, a in out.items()}


def _random_dirs(count: int, seed: int = 1) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(count, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_latlong_convention():
    dirs = np.array([[0, 1, 0], [0, -1, 0], [0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 0, -1]], dtype=np.float64)
    uv = environment_uv(dirs)
    assert uv[0, 1] == pytest.approx(1.0) and uv[1, 1] == pytest.approx(0.0)  # +Y is the top row
    np.testing.assert_allclose(uv[2:, 1], 0.5, atol=1e-12)
    np.testing.assert_allclose(uv[2:5, 0], [0.5, 0.25, 0.75], atol=1e-12)  # centre faces +Z, +X left of it
    assert uv[5, 0] in (0.0, pytest.approx(1.0))  # the seam faces -Z
    d = _random_dirs(1000)
    np.testing.assert_allclose(environment_direction(environment_uv(d)), d, atol=1e-9)


def test_fast_atan2_is_float_accurate(device):
    rng = np.random.default_rng(4)
    angle = rng.uniform(-math.pi, math.pi, 200_000)
    radius = np.exp(rng.uniform(-30.0, 30.0, angle.size))
    special_y = [0.0, -0.0, 0.0, -0.0, 1.0, -1.0, 0.0, 0.0, 1e-30, -1e-30, 3.0, -3.0]
    special_x = [0.0, 0.0, -0.0, -0.0, 0.0, -0.0, 1.0, -1.0, -1.0, -1.0, 3.0, -3.0]
    y = np.concatenate([np.sin(angle) * radius, special_y]).astype(np.float32)
    x = np.concatenate([np.cos(angle) * radius, special_x]).astype(np.float32)
    out = wp.zeros(y.size, dtype=float, device=device)
    wp.launch(
        atan2_kernel,
        dim=y.size,
        inputs=[wp.array(y, device=device), wp.array(x, device=device)],
        outputs=[out],
        device=device,
    )
    got = out.numpy()
    exact = np.arctan2(y.astype(np.float64), x.astype(np.float64))
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    assert (np.abs(got - exact) / ulp).max() <= 3.0  # libm's atan2f is within ~1.5 ulp
    np.testing.assert_array_equal(np.signbit(got[-12:]), np.signbit(exact[-12:]))  # IEEE signed zeros and pi


def test_latlong_kernel_matches_host_and_fetches_texels(device):
    h, w = 8, 16
    rng = np.random.default_rng(0)
    pixels = rng.uniform(0.1, 2.0, size=(h, w, 4)).astype(np.float32)
    dirs, _ = texel_directions(h, w)
    ds = _dome_scene(device, pixels, color=(2.0, 1.0, 0.5), scale=(1.0, 2.0, 1.0, 1.0), bias=(0.0, 0.0, 0.25, 0.0))
    res = _eval(device, ds, dirs.reshape(-1, 3))
    uv_host = environment_uv(dirs.reshape(-1, 3))
    du = np.abs(res["uv"][:, 0] - uv_host[:, 0])
    assert np.minimum(du, 1.0 - du).max() < 1e-5
    np.testing.assert_allclose(res["uv"][:, 1], uv_host[:, 1], atol=1e-5)
    # the lookup does not need unit directions
    scaled = _eval(device, ds, dirs.reshape(-1, 3) * np.geomspace(1e-3, 1e3, h * w)[:, None])
    np.testing.assert_allclose(scaled["uv"], res["uv"], atol=1e-6)
    # at texel centres the bilinear fetch returns the texel itself (row 0 = top)
    expected = (pixels[..., :3] * [1.0, 2.0, 1.0] + [0.0, 0.0, 0.25]) * [2.0, 1.0, 0.5]
    np.testing.assert_allclose(res["radiance"], expected.reshape(-1, 3), rtol=1e-4)
    # the dome's rotation: world -X seen as dome-local +Z (rotation about Y by +90 deg)
    rot = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], dtype=np.float32)  # world -> dome
    assert np.allclose(rot @ [-1, 0, 0], [0, 0, 1])
    ds_rot = _dome_scene(device, pixels, world_to_light=rot)
    centre = _eval(device, ds_rot, np.array([[-1.0, 0.0, 0.0]]))["radiance"][0]
    np.testing.assert_allclose(
        centre, pixels[h // 2 - 1 : h // 2 + 1, w // 2 - 1 : w // 2 + 1, :3].mean(axis=(0, 1)), rtol=1e-4
    )


def test_sh_irradiance_of_constant_and_linear_domes(device):
    n = _random_dirs(200, seed=2)
    const = sh_irradiance_coefficients(np.full((64, 128, 3), 0.7))
    np.testing.assert_allclose(sh_eval(const, n), math.pi * 0.7, rtol=3e-4)
    np.testing.assert_allclose(const, sh_constant_coefficients((0.7, 0.7, 0.7)), rtol=1e-5, atol=1e-3)
    # L(w) = 1 + 0.5 y  =>  E(n) = pi + 0.5 * (2 pi / 3) n_y  (exact in bands 0-1)
    dirs, _ = texel_directions(64, 128)
    sky = np.repeat((1.0 + 0.5 * dirs[..., 1])[..., None], 3, axis=-1)
    coeffs = sh_irradiance_coefficients(sky)
    np.testing.assert_allclose(sh_eval(coeffs, n)[:, 0], math.pi + math.pi / 3.0 * n[:, 1], rtol=2e-3)
    # the kernel-side evaluation agrees, also for the constant-colour dome
    ds = _dome_scene(device, np.concatenate([sky, np.ones((64, 128, 1))], axis=-1).astype(np.float32))
    res = _eval(device, ds, n)
    np.testing.assert_allclose(res["irradiance"][:, 0], math.pi + math.pi / 3.0 * n[:, 1], rtol=2e-3)
    flat = _eval(device, _dome_scene(device, None, color=(0.2, 0.4, 0.6)), n)
    np.testing.assert_allclose(flat["irradiance"], np.tile(math.pi * np.array([0.2, 0.4, 0.6]), (len(n), 1)), rtol=1e-5)
    np.testing.assert_allclose(flat["radiance"], np.tile([0.2, 0.4, 0.6], (len(n), 1)), rtol=1e-6)


def test_prefiltered_radiance(device):
    h, w = 64, 128
    dirs = _random_dirs(300, seed=3)
    uniform = _dome_scene(device, np.full((h, w, 4), 0.8, np.float32), color=(1.0, 0.5, 0.25))
    for r in (0.0, 0.3, 0.6, 1.0):
        res = _eval(device, uniform, dirs, r)
        np.testing.assert_allclose(res["prefiltered"], np.tile([0.8, 0.4, 0.2], (len(dirs), 1)), rtol=2e-3)
    # a one-texel-wide bright stripe: sharp at roughness 0, spread and dimmer when rough
    stripe = np.full((h, w, 4), 0.1, np.float32)
    stripe[:, w // 2] = 10.0
    ds = _dome_scene(device, stripe)
    on = np.array([environment_direction(np.array([(w // 2 + 0.5) / w, 0.5]))])
    off = np.array([environment_direction(np.array([(w // 2 + 8.5) / w, 0.5]))])
    sharp_on = _eval(device, ds, on, 0.0)["prefiltered"][0, 0]
    assert sharp_on == pytest.approx(10.0, rel=1e-4)
    assert _eval(device, ds, off, 0.0)["prefiltered"][0, 0] == pytest.approx(0.1, rel=1e-4)
    rough_on = _eval(device, ds, on, 0.6)["prefiltered"][0, 0]
    rough_off = _eval(device, ds, off, 0.6)["prefiltered"][0, 0]
    assert 0.1 < rough_on < 0.5 * sharp_on
    assert rough_off > 0.1
    assert [m.shape[:2] for m in radiance_mips(stripe[..., :3])] == [(32, 64), (16, 32), (8, 16), (4, 8)]


def test_the_mip_pool_holds_the_levels_back_to_back_then_one_spare_texel(device):
    # (the CPU's lookups load a vec3 texel's three floats as four: the last level's last
    # texel needs the spare one after it inside the pool)
    rng = np.random.default_rng(3)
    pixels = rng.uniform(0.0, 4.0, (32, 64, 4)).astype(np.float32)
    amb = _dome_scene(device, pixels).ambient
    mips = radiance_mips(pixels[..., :3])
    pool = amb.mip_texels.numpy()
    sizes = [m.shape[0] * m.shape[1] for m in mips]
    assert pool.shape == (sum(sizes) + 1, 3)
    np.testing.assert_array_equal(amb.mip_offset.numpy(), np.cumsum([0] + sizes[:-1]))
    np.testing.assert_array_equal(pool[:-1], np.concatenate([m.reshape(-1, 3) for m in mips]))
    np.testing.assert_array_equal(pool[-1], 0.0)


def test_ambient_data_is_owned_by_the_device_scene_and_follows_the_dome(device):
    ds = _dome_scene(device, None, color=(0.2, 0.4, 0.6))
    first = ds.ambient
    ds.update(ds.scene)
    assert ds.ambient is first
    brighter = make_scene(
        [quad((0, 0, 0), (1, 0, 0), (0, 1, 0))], [Material("m")], environment=Environment("/dome", (1.0, 1.0, 1.0))
    )
    ds.update(brighter)
    second = ds.ambient
    assert second is not first
    n = np.array([[0.0, 1.0, 0.0]])
    np.testing.assert_allclose(_eval(device, ds, n)["irradiance"][0], math.pi, rtol=1e-5)
