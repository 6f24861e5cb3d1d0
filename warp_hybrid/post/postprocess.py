"""The output stage: exposure, tone mapping, sRGB encoding and FXAA -> 8-bit image."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..parallel import Launcher
from ..timing import StageTimer
from .color import make_srgb8_encoder
from .exposure import auto_exposure_ev
from .kernels import TONEMAP_KERNELS, fxaa_pixels

TONEMAPS = tuple(TONEMAP_KERNELS)


class PostProcess:
    """Linear HDR colour in, uint8 sRGB (H, W, 3) out (stages "tonemap" and "aa")."""

    def __init__(self, launcher: Launcher) -> None:
        """Run on ``launcher``'s device, rows split across its threads."""
        self.launcher = launcher
        self.last_exposure_ev = 0.0
        self._buffers: tuple[wp.array, wp.array] | None = None
        self._encoder = make_srgb8_encoder(launcher.device)
        launcher.ensure_loaded(fxaa_pixels)  # compiles the post module (all its kernels) up front

    def _targets(self, height: int, width: int) -> tuple[wp.array, wp.array]:
        if self._buffers is None or tuple(self._buffers[0].shape) != (height, width, 3):
            dev = self.launcher.device
            self._buffers = (
                wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
                wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
            )
        return self._buffers

    def run(
        self,
        color: wp.array,
        exposure_ev: float | None,
        tonemap: str,
        aa: bool,
        timer: StageTimer,
        hit_mask: np.ndarray | None = None,
    ) -> np.ndarray:
        """Expose ``color`` ((H, W) vec3, linear) by ``2**exposure_ev`` (None: automatic,
        key 0.18 over the log-average luminance of ``hit_mask``'s pixels, or of all
        non-black pixels), tone map with ``tonemap`` (one of ``TONEMAPS``), encode to
        sRGB, anti-alias with FXAA when ``aa``; return the uint8 (H, W, 3) image.
        The EV used is kept in ``last_exposure_ev``."""
        if tonemap not in TONEMAP_KERNELS:
            raise ValueError(f"unknown tone mapping {tonemap!r}; choose one of {', '.join(TONEMAPS)}")
        h, w = int(color.shape[0]), int(color.shape[1])
        ldr, smoothed = self._targets(h, w)
        with timer.stage("tonemap"):
            ev = float(exposure_ev) if exposure_ev is not None else auto_exposure_ev(color.numpy(), hit_mask)
            self.last_exposure_ev = ev
            self.launcher.launch_rows(TONEMAP_KERNELS[tonemap], h, w, [color, 2.0**ev, self._encoder, ldr])
        if not aa:
            return np.array(ldr.numpy(), copy=True)
        with timer.stage("aa"):
            self.launcher.launch_rows(fxaa_pixels, h, w, [ldr, smoothed])
        return np.array(smoothed.numpy(), copy=True)
