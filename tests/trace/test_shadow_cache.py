"""The primary hits' shadows kept across the frames of a still view
(``trace/shadow_cache.py``): reused bit for bit where the caller says the view stood
still, traced again where it did not or where the tracer's own state changed."""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp
from trace_kit import pane_scene

from warp_hybrid.core.camera import make_camera_gpu
from warp_hybrid.core.gbuffer import GBuffer
from warp_hybrid.parallel import Launcher
from warp_hybrid.primary import Rasterizer
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.model import Light, LightKind
from warp_hybrid.timing import StageTimer
from warp_hybrid.trace import Tracer, TraceSettings

W, H = 48, 36


class _Frames:
    """One tracer tracing lists of pixels of one rasterized view of the pane scene, its
    pane made opaque and rough (no secondary rays: every shadow ray is a primary hit's)."""

    def __init__(self, launcher: Launcher, device: str, shadow_samples: int = 1) -> None:
        scene, cam = pane_scene(1.0)
        pane = dataclasses.replace(scene.materials[1], roughness=0.9)
        self.scene = dataclasses.replace(scene, materials=[scene.materials[0], pane])
        if shadow_samples > 1:  # a light with an extent: the samples spread over it
            bulb = Light(LightKind.SPHERE, "/bulb", (20.0, 20.0, 20.0), position=(0.3, 3.0, 0.2), radius=0.6)
            self.scene = dataclasses.replace(self.scene, lights=[bulb])
        self.device = device
        self.ds = DeviceScene(self.scene, device)
        self.camera = make_camera_gpu(cam, W, H)
        self.gb = GBuffer(W, H, device)
        self.launcher = launcher
        Rasterizer(launcher).render(self.ds, self.camera, self.gb, StageTimer())
        self.tracer = Tracer(launcher, TraceSettings(shadow_samples=shadow_samples))

    def trace(self, pixels: np.ndarray, reuse: bool) -> tuple[np.ndarray, np.ndarray, int]:
        """The traced colour, visibility and shadow rays of one call."""
        color = wp.zeros((H, W), dtype=wp.vec3, device=self.device)
        vis = wp.full((H, W, 1), value=float("nan"), dtype=wp.float32, device=self.device)
        listed = wp.array(pixels.astype(np.int32), dtype=wp.int32, device=self.device)
        self.tracer.begin_frame(W, H)
        counts = self.tracer.trace(
            self.ds, self.camera, self.gb, listed, len(pixels), color, vis, StageTimer(), reuse_shadows=reuse
        ).counts()
        return color.numpy(), vis.numpy(), counts.shadow

    def move_pane(self, shift: float) -> None:
        """Move the pane along x and draw the G-buffer again."""
        points = self.scene.points.copy()
        points[4:] += np.array([shift, 0.0, 0.0], np.float32)
        self.ds.update(dataclasses.replace(self.scene, points=points))
        Rasterizer(self.launcher).render(self.ds, self.camera, self.gb, StageTimer())


def test_a_second_call_reuses_what_the_first_traced(device: str) -> None:
    """Two overlapping pixel lists of one view: the second call traces shadow rays only
    for the pixels the first did not list, and its colour and visibility are the same
    bit for bit as those of a call that traces every pixel again."""
    with Launcher(device, threads=2) as launcher:
        frames = _Frames(launcher, device)
        everything = np.arange(W * H)
        first, second = everything[: W * H * 2 // 3], everything[W * H // 3 :]
        _, _, rays_first = frames.trace(first, reuse=False)
        color, vis, rays_second = frames.trace(second, reuse=True)
        plain = _Frames(launcher, device)
        color_ref, vis_ref, rays_ref = plain.trace(second, reuse=False)
        new = second[second >= len(first)]
        _, _, rays_new = plain.trace(new, reuse=False)
    assert rays_first > 0 and 0 < rays_new < rays_ref
    assert rays_second == rays_new
    np.testing.assert_array_equal(color, color_ref)
    np.testing.assert_array_equal(vis, vis_ref)


def test_without_the_callers_word_every_pixel_is_traced_again(device: str) -> None:
    with Launcher(device, threads=1) as launcher:
        frames = _Frames(launcher, device)
        pixels = np.arange(W * H)
        _, _, first = frames.trace(pixels, reuse=False)
        _, _, again = frames.trace(pixels, reuse=False)
        _, _, reused = frames.trace(pixels, reuse=True)
    assert first == again > 0 and reused == 0


def test_a_scene_update_makes_every_entry_stale(device: str) -> None:
    """A caller that says the view stood still while the pane moved (its G-buffer drawn
    again) still gets the moved shadow: the scene's content changed, so the tracer
    traces every pixel again."""
    with Launcher(device, threads=1) as launcher:
        frames = _Frames(launcher, device)
        pixels = np.arange(W * H)
        _, vis_before, _ = frames.trace(pixels, reuse=False)
        frames.move_pane(1.5)
        _, vis_after, rays = frames.trace(pixels, reuse=True)
        fresh = _Frames(launcher, device)
        fresh.move_pane(1.5)
        _, vis_ref, rays_ref = fresh.trace(pixels, reuse=False)
    assert rays == rays_ref > 0
    np.testing.assert_array_equal(vis_after, vis_ref)
    assert not np.array_equal(np.nan_to_num(vis_before), np.nan_to_num(vis_after))


def test_soft_shadows_are_reused_as_traced(device: str) -> None:
    """With four shadow samples over a sphere light (their seed follows the sample index
    alone) a reused pixel keeps the traced average bit for bit."""
    with Launcher(device, threads=1) as launcher:
        frames = _Frames(launcher, device, shadow_samples=4)
        pixels = np.arange(W * H)
        color, vis, rays = frames.trace(pixels, reuse=False)
        color_again, vis_again, rays_again = frames.trace(pixels, reuse=True)
    hit = ~np.isnan(vis[..., 0])
    assert rays > 3 * hit.sum() and rays_again == 0  # several samples a pixel
    assert ((vis[hit] > 0.0) & (vis[hit] < 1.0)).any()  # a penumbra
    np.testing.assert_array_equal(color, color_again)
    np.testing.assert_array_equal(vis, vis_again)
