"""The output stage: exposure, tone mapping, sRGB encoding and FXAA -> 8-bit image."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..parallel import Launcher
from ..timing import StageTimer
from .aa import luma_table
from .color import make_srgb8_encoder
from .exposure import ev_from_log_sum
from .kernels import LOG_LUMINANCE_KERNELS, MASK_BOOL, MASK_ID, MASK_NONE, TONEMAP_KERNELS, fxaa_rows
from .tonemap import OPERATORS

TONEMAPS = tuple(OPERATORS)


class PostProcess:
    """Linear HDR colour in, uint8 sRGB (H, W, 3) out (stages "tonemap" and "aa")."""

    def __init__(self, launcher: Launcher) -> None:
        """Run on ``launcher``'s device, rows split across its threads."""
        self.launcher = launcher
        self.last_exposure_ev = 0.0
        self._buffers: dict[str, wp.array] = {}
        self._encoder = make_srgb8_encoder(launcher.device)
        self._luma_lut = wp.array(luma_table(), dtype=wp.vec3, device=launcher.device)
        launcher.ensure_loaded(fxaa_rows)  # compiles the post module (all its kernels) up front

    def _targets(self, height: int, width: int) -> dict[str, wp.array]:
        if not self._buffers or tuple(self._buffers["ldr"].shape) != (height, width, 3):
            dev = self.launcher.device
            self._buffers = {
                "ldr": wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
                "smoothed": wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
                "luma": wp.zeros((height, width), dtype=float, device=dev),
                "row_sum": wp.zeros(height, dtype=wp.float64, device=dev),
                "row_count": wp.zeros(height, dtype=wp.int32, device=dev),
                "no_mask": wp.zeros((1, 1), dtype=wp.bool, device=dev),
            }
        return self._buffers

    def _mask(self, hit_mask: np.ndarray | wp.array | None, shape: tuple[int, int]) -> tuple[str, wp.array]:
        """The mask kind and device array for ``auto_exposure``."""
        if hit_mask is None:
            return MASK_NONE, self._buffers["no_mask"]
        if tuple(hit_mask.shape) != shape:
            raise ValueError(f"hit_mask has shape {tuple(hit_mask.shape)}, expected {shape}")
        if isinstance(hit_mask, wp.array):
            if hit_mask.dtype == wp.int32:
                return MASK_ID, hit_mask
            if hit_mask.dtype == wp.bool:
                return MASK_BOOL, hit_mask
            raise ValueError(f"hit_mask must be a bool or int32 (id) array, got {hit_mask.dtype.__name__}")
        mask = np.ascontiguousarray(hit_mask, dtype=bool)
        return MASK_BOOL, wp.array(mask, dtype=wp.bool, device=self.launcher.device)

    def auto_exposure(self, color: wp.array, hit_mask: np.ndarray | wp.array | None) -> float:
        """The automatic EV (key 0.18 over the log-average luminance of ``hit_mask``'s
        pixels, or of all non-black pixels), reduced on the device per row."""
        h, w = int(color.shape[0]), int(color.shape[1])
        buffers = self._targets(h, w)
        kind, mask = self._mask(hit_mask, (h, w))
        self.launcher.launch_items(
            LOG_LUMINANCE_KERNELS[kind], h, [color, mask, buffers["row_sum"], buffers["row_count"]]
        )
        return ev_from_log_sum(float(buffers["row_sum"].numpy().sum()), int(buffers["row_count"].numpy().sum()))

    def run(
        self,
        color: wp.array,
        exposure_ev: float | None,
        tonemap: str,
        aa: bool,
        timer: StageTimer,
        hit_mask: np.ndarray | wp.array | None = None,
    ) -> np.ndarray:
        """Expose ``color`` ((H, W) vec3, linear) by ``2**exposure_ev`` (None: automatic,
        key 0.18 over the log-average luminance of ``hit_mask``'s pixels, or of all
        non-black pixels), tone map with ``tonemap`` (one of ``TONEMAPS``), encode to
        sRGB, anti-alias with FXAA when ``aa``; return the uint8 (H, W, 3) image.
        ``hit_mask`` (H, W): a numpy bool array, or a Warp array on the device, bool or
        int32 ids (hit where >= 0, e.g. the G-buffer's ``triangle_id``).
        The EV used is kept in ``last_exposure_ev``."""
        if tonemap not in TONEMAPS:
            raise ValueError(f"unknown tone mapping {tonemap!r}; choose one of {', '.join(TONEMAPS)}")
        h, w = int(color.shape[0]), int(color.shape[1])
        buffers = self._targets(h, w)
        with timer.stage("tonemap"):
            ev = float(exposure_ev) if exposure_ev is not None else self.auto_exposure(color, hit_mask)
            self.last_exposure_ev = ev
            inputs = [color, 2.0**ev, self._encoder, buffers["ldr"], self._luma_lut, buffers["luma"]]
            self.launcher.launch_items(TONEMAP_KERNELS[(tonemap, aa)], h, inputs)
        if not aa:
            return np.array(buffers["ldr"].numpy(), copy=True)
        with timer.stage("aa"):
            wp.copy(buffers["smoothed"], buffers["ldr"])
            self.launcher.launch_items(fxaa_rows, h, [buffers["ldr"], buffers["luma"], buffers["smoothed"]])
        return np.array(buffers["smoothed"].numpy(), copy=True)
