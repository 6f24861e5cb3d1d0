"""The path kernel's first rays as packets (``trace/path.py``: a launch item's first
reflection and refraction rays through ``wide_closest_packet``) give every pixel what
Warp's own queries, one ray at a time, give it: a mirror floor whose reflections meet a
sphere, a glass sphere, walls and a cut-out quad (the packet's first hit cut away: the
path steps past it and asks again on its own)."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from trace_kit import ALL_FEATURES

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad, uv_sphere
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Light, LightKind, Material
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import Tracer, TraceSettings

W, H = 96, 72


@pytest.mark.parametrize("opacity", [0.3, 1.0])
def test_first_rays_in_packets_trace_what_one_ray_at_a_time_does(opacity: float) -> None:
    """Row order (neighbouring pixels in one packet) and a shuffled list (packets of
    scattered rays), both bit for bit Warp's one-at-a-time answer (colour, visibility, ray
    counts); most pixels send a first ray, so packets are taken."""
    mats = [
        Material("/mirror", diffuse=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.0),
        Material("/wall", diffuse=(0.7, 0.5, 0.3), roughness=0.8),
        Material("/glass", diffuse=(0.9, 0.95, 1.0), roughness=0.0, opacity=0.0, ior=1.5),
        Material("/leaf", diffuse=(0.2, 0.8, 0.2), opacity=opacity, opacity_threshold=0.5),
    ]
    meshes = [
        quad((-4.0, 0.0, 4.0), (8.0, 0.0, 0.0), (0.0, 0.0, -8.0), 0),  # the mirror floor
        quad((-4.0, 0.0, -4.0), (8.0, 0.0, 0.0), (0.0, 5.0, 0.0), 1),  # the back wall
        uv_sphere((-1.2, 1.0, -0.5), 0.9, rings=12, segments=24, material=2, name="/glass_ball"),
        uv_sphere((1.3, 0.8, 0.3), 0.7, rings=10, segments=20, material=1, name="/ball"),
        quad((-3.0, 2.5, 2.0), (6.0, 0.0, 0.0), (0.0, 0.0, -5.0), 3),  # the cut-out, above
    ]
    light = Light(LightKind.SPHERE, "/bulb", (30.0, 30.0, 30.0), position=(0.5, 4.0, 1.5), radius=0.3)
    cam = look_at_camera((0.0, 3.0, 7.0), (0.0, 0.3, 0.0))
    scene = make_scene(meshes, mats, lights=[light], cameras=[cam])
    ds = DeviceScene(scene, "cpu")
    camera = make_camera_gpu(cam, W, H)
    gb = GBuffer(W, H, "cpu")
    orders = (np.arange(W * H), np.random.default_rng(5).permutation(W * H))
    with Launcher("cpu", threads=2) as launcher:
        Rasterizer(launcher).render(ds, camera, gb, StageTimer())
        for order in orders:
            pixels = wp.array(order.astype(np.int32), dtype=wp.int32, device="cpu")
            runs = []
            for wide_bvh in (None, False):  # packets (the CPU's default), Warp's own queries
                tracer = Tracer(launcher, TraceSettings(wide_bvh=wide_bvh), ALL_FEATURES)
                color = wp.zeros((H, W), dtype=wp.vec3, device="cpu")
                vis = wp.full((H, W, 1), value=float("nan"), dtype=wp.float32, device="cpu")
                tracer.begin_frame(W, H)
                tally = tracer.trace(ds, camera, gb, pixels, W * H, color, vis, StageTimer())
                runs.append((color.numpy(), vis.numpy(), tally.counts()))
            (color, vis, counts), (color_ref, vis_ref, counts_ref) = runs
            np.testing.assert_array_equal(color, color_ref)
            np.testing.assert_array_equal(vis, vis_ref)
            assert counts == counts_ref
            assert counts.reflection > W * H // 2 and counts.refraction > 100
