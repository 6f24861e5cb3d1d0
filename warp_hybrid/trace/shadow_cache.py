"""The primary hits' shadows kept across the frames of a still view.

In a still view (``RenderSettings.cache_raster``: the same camera, scene content and
buffers as the last frame, ``FrameContext.raster_cached``) a pixel's G-buffer is the
last frame's, and so is everything its primary shadow rays depend on: the point, its
normals, the lights, the shadow BVHs and the tracer's settings (the soft-shadow seed
follows the sample index alone).  So the transmittance toward each light that the
shadow kernel found for a pixel is the same bit for bit in every later frame of that
view, and the window, which moves with the gaze, mostly covers pixels it covered a frame
ago.  ``ShadowCache`` keeps each pixel's transmittances and the *generation* they
belong to; the shadow kernel reuses a pixel's entry when it is of the current
generation (no shadow ray: its count is 0, so the frame's tally, and the budget
controller's cost model, see the rays actually traced) and otherwise traces and stores
it.  Every frame that is not a kept frame of the same view starts a new generation,
which makes every entry stale at once; so does a change of the tracer's own state (its
scene, variant, shadow BVHs or the size).  The traced colour and the visibility AOV are
therefore the same as without the cache; only the shadow rays already traced for the
view are not traced again.  The path kernel's secondary hits trace theirs every frame.
Whatever the generation, a pixel's last transmittances also tell the CPU's packet
kernel which groups of pixels crossed glass lately (``shadows.crossed``): a hint of
which way to query, never of what the answer is.
"""

from __future__ import annotations

import warp as wp


@wp.struct
class ShadowCacheGPU:
    """The kernel side: ``transmittance`` (H, W, L) per pixel and light, ``stamp`` (H, W)
    the generation each pixel's entry belongs to (0: none), ``generation`` the current
    one (traced pixels store theirs under it), ``reuse`` (0 or 1) whether its entries may
    be read."""

    transmittance: wp.array3d(dtype=wp.vec3)
    stamp: wp.array2d(dtype=wp.int32)
    generation: int
    reuse: int


class ShadowCache:
    """One tracer's cache (module docstring), allocated for the frame size and light count."""

    def __init__(self, device: wp.context.Device) -> None:
        """An empty cache on ``device`` (allocated by the first ``frame``)."""
        self.device = device
        self.gpu = ShadowCacheGPU()
        self._key: tuple | None = None

    def _allocate(self, height: int, width: int, lights: int) -> None:
        self.gpu.transmittance = wp.zeros((height, width, lights), dtype=wp.vec3, device=self.device)
        self.gpu.stamp = wp.zeros((height, width), dtype=wp.int32, device=self.device)
        self.gpu.generation = 1
        self.gpu.reuse = 0

    def frame(self, height: int, width: int, lights: int, state: tuple, reuse: bool) -> ShadowCacheGPU:
        """The cache for one tracing call of an ``height`` x ``width`` frame with ``lights``
        lights: its entries are read when ``reuse`` (the caller's word that the view is the
        last call's) and ``state`` (what the tracer's shadows depend on) is the last call's;
        otherwise a new generation starts."""
        shape = (height, width, max(lights, 1))
        if self.gpu.transmittance is None or tuple(self.gpu.transmittance.shape) != shape:
            self._allocate(*shape)
            self._key = None
        fresh = reuse and state == self._key
        if not fresh:
            self.gpu.generation += 1
        self.gpu.reuse = int(fresh)
        self._key = state
        return self.gpu
