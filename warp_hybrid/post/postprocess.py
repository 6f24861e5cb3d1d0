"""The output stage: exposure, tone mapping, sRGB encoding and FXAA -> 8-bit image.

Every pass runs on the device (``Launcher.launch_pixels``; the exposure kernels one
thread each), and the frame's exposure stays in device memory between them: nothing
is read back before the finished image.

A caller that knows which rows and columns of the colour changed since the last call
(``changed_rows``, ``changed_cols``: a still view whose raster layer was kept, where only
the focus window moves) gets that rectangle redrawn only: tone mapping over it, FXAA over
it widened by ``FXAA_REACH_PX`` (the farthest FXAA reads) on every side, the rest of the
image kept from the last call, which is the same bit for bit.  This holds only where
the last call drew the same colour buffer with the same settings and exposure;
otherwise, and for ``changed_rows`` None, the whole image is drawn.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..core.passes import FrameContext, MeteredRows, RenderPass
from ..core.rows import NO_ROWS, RowSpan, span_clip, span_grow
from ..parallel import FEW_BANDS_PER_THREAD, Launcher
from ..timing import StageTimer
from .aa import FXAA_REACH_PX, luma_buffer
from .color import make_srgb8_encoder
from .exposure import Exposure
from .kernels import (
    LOG_LUMINANCE_KERNELS,
    MASK_BOOL,
    MASK_ID,
    MASK_NONE,
    TONEMAP_KERNELS,
    exposure_from_rows,
    fixed_exposure,
    fxaa_pixels,
)
from .tonemap import OPERATORS

TONEMAPS = tuple(OPERATORS)


class PostProcess(RenderPass):
    """Linear HDR colour in, uint8 sRGB (H, W, 3) out (stages "tonemap" and "aa"); its
    host writes (the metered sums zeroed) and reads (the EV) wait for the pass in flight
    (``Launcher.join``), its launches queue behind it."""

    overlapped = True

    def __init__(
        self, launcher: Launcher, exposure_ev: float | None = None, tonemap: str = "aces", antialias: bool = True
    ) -> None:
        """Run on ``launcher``'s device, rows split across its threads; the other
        arguments are what ``execute`` applies (see ``process``)."""
        self.launcher = launcher
        self.exposure_ev = exposure_ev
        self.tonemap = tonemap
        self.antialias = antialias
        self._buffers: dict[str, wp.array] = {}
        self._encoder = make_srgb8_encoder(launcher.device)
        self._exposure = wp.zeros(1, dtype=Exposure, device=launcher.device)  # EV 0 until a frame runs
        # what the last call drew: its colour array (held, so no other array takes its
        # place), its 8-bit target and its settings (see ``process``)
        self._drawn: tuple | None = None
        launcher.ensure_loaded(fxaa_pixels)  # compiles the post module (all its kernels) up front

    @property
    def exposure(self) -> wp.array:
        """The last frame's exposure on the device: a 1-element ``Exposure`` array."""
        return self._exposure

    @property
    def last_exposure_ev(self) -> float:
        """The EV of the last frame (0 before any), read from the device: this waits
        for the frame's exposure, so read it after the frame (with its image)."""
        self.launcher.join()
        return float(self._exposure.numpy()[0]["ev"])

    def _targets(self, height: int, width: int) -> dict[str, wp.array]:
        if not self._buffers or tuple(self._buffers["ldr"].shape) != (height, width, 3):
            dev = self.launcher.device
            self._buffers = {
                "ldr": wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
                "smoothed": wp.zeros((height, width, 3), dtype=wp.uint8, device=dev),
                "luma": luma_buffer(height, width, dev),
                "edges": wp.zeros((height, width), dtype=wp.int32, device=dev),
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

    def auto_exposure(self, color: wp.array, hit_mask: np.ndarray | wp.array | None) -> None:
        """Set ``exposure`` to the automatic EV (key 0.18 over the log-average luminance
        of ``hit_mask``'s pixels, or of all non-black pixels), all on the device: the
        logs summed per row, then the rows and the EV in one thread.  Nothing is
        read back (``last_exposure_ev`` does that)."""
        self._drawn = None
        self.launcher.join()  # (the sums are zeroed from the host)
        h, w = int(color.shape[0]), int(color.shape[1])
        buffers = self._targets(h, w)
        kind, mask = self._mask(hit_mask, (h, w))
        if not (color.is_contiguous and mask.is_contiguous):
            raise ValueError(
                "the metered colour and hit_mask must be contiguous (the sums read their rows as flat arrays)"
            )
        buffers["row_sum"].zero_()
        buffers["row_count"].zero_()
        self.launcher.launch_pixels(
            LOG_LUMINANCE_KERNELS[kind],
            h,
            w,
            [color, mask, buffers["row_sum"], buffers["row_count"]],
            bands_per_thread=FEW_BANDS_PER_THREAD,
        )
        self.exposure_from_rows(buffers["row_sum"], buffers["row_count"])

    def exposure_from_rows(self, row_sum: wp.array, row_count: wp.array) -> None:
        """Set ``exposure`` to the automatic EV of log-luminance sums already summed per
        row (float64 ``row_sum``, int32 ``row_count``, one per row: ``MeteredRows``), on the
        device, in the order ``auto_exposure`` sums its own rows (so the same rows give
        the same EV)."""
        self._drawn = None
        self.launcher.launch_items(exposure_from_rows, 1, [row_sum, row_count, 2.0, self._exposure])

    def set_exposure(self, ev: float) -> None:
        """Set ``exposure`` to the fixed ``ev`` (scale ``2**ev`` from the host)."""
        self._drawn = None
        ev = float(ev)
        self.launcher.launch_items(fixed_exposure, 1, [ev, 2.0**ev, self._exposure])

    def execute(self, frame: FrameContext) -> None:
        """Post-process ``frame``'s colour into ``frame.image`` (a device array), the
        automatic exposure metered on ``frame.buffers.metered`` at the G-buffer's hit
        pixels (kept from the last frame where that is the raster layer and the frame
        kept it, ``FrameContext.raster_cached``: the same layer meters the same EV; from
        ``FrameContext.metered_rows`` where the pass that wrote that layer metered it)."""
        b = frame.buffers
        keep = frame.raster_cached and b.metered is b.raster_color
        rows = frame.metered_rows
        frame.image = self.process(
            b.color,
            self.exposure_ev,
            self.tonemap,
            self.antialias,
            frame.timer,
            frame.gbuffer.triangle_id,
            b.metered,
            keep_exposure=keep,
            changed_rows=frame.changed_rows,
            changed_cols=frame.changed_cols,
            metered_rows=rows if rows is not None and rows.layer is b.metered else None,
        )

    def process(
        self,
        color: wp.array,
        exposure_ev: float | None,
        tonemap: str,
        aa: bool,
        timer: StageTimer,
        hit_mask: np.ndarray | wp.array | None = None,
        metered: wp.array | None = None,
        keep_exposure: bool = False,
        changed_rows: RowSpan | None = None,
        changed_cols: RowSpan | None = None,
        metered_rows: MeteredRows | None = None,
    ) -> wp.array:
        """Expose ``color`` ((H, W) vec3, linear) by ``2**exposure_ev`` (None: automatic,
        key 0.18 over the log-average luminance of ``metered``, default ``color``
        itself, at ``hit_mask``'s pixels, or at all non-black pixels), tone map with
        ``tonemap`` (one of ``TONEMAPS``), encode to sRGB, anti-alias with FXAA when
        ``aa``; return the uint8 (H, W, 3) image on the device (a buffer reused by the
        next call).
        ``hit_mask`` (H, W): a numpy bool array, or a Warp array on the device, bool or
        int32 ids (hit where >= 0, e.g. the G-buffer's ``triangle_id``).
        The EV used stays on the device (``exposure``; ``last_exposure_ev`` reads it);
        ``keep_exposure``: an automatic exposure is the last call's, not metered again (the
        caller knows ``metered`` and the mask are the last call's).
        ``changed_rows``, ``changed_cols`` (first, stop): the only rows and columns of
        ``color`` that can differ from the last call's ``color`` (module docstring; None:
        any).  ``metered_rows``: ``metered``'s log-luminance sums at ``hit_mask``'s pixels,
        already summed per row (the automatic exposure then sums those alone)."""
        if tonemap not in TONEMAPS:
            raise ValueError(f"unknown tone mapping {tonemap!r}; choose one of {', '.join(TONEMAPS)}")
        if not color.is_contiguous:
            raise ValueError(
                "color must be a contiguous (H, W) vec3 array (the tone map reads its rows as flat floats)"
            )
        h, w = int(color.shape[0]), int(color.shape[1])
        buffers = self._targets(h, w)
        # what this call draws: the same as the last call's, with the same EV (a fixed one,
        # or the automatic one kept), means only ``changed_rows`` x ``changed_cols`` can change
        drawn = (color, buffers["ldr"], tonemap, aa, exposure_ev)
        same_exposure = exposure_ev is not None or keep_exposure
        rows, cols = (0, h), (0, w)
        last = self._drawn
        if (
            changed_rows is not None
            and same_exposure
            and last is not None
            and all(a is b for a, b in zip(drawn[:2], last[:2]))
            and drawn[2:] == last[2:]
        ):
            rows = span_clip(changed_rows, h)
            if changed_cols is not None:
                cols = span_clip(changed_cols, w)
        self._drawn = None  # until this call is done
        with timer.stage("tonemap"):
            if exposure_ev is not None:
                self.set_exposure(exposure_ev)
            elif metered_rows is not None and not keep_exposure:
                self.exposure_from_rows(metered_rows.row_sum, metered_rows.row_count)
            elif not keep_exposure:
                self.auto_exposure(color if metered is None else metered, hit_mask)
            inputs = [color, self._exposure, self._encoder, buffers["ldr"], buffers["luma"], *cols]
            self.launcher.launch_pixels(
                TONEMAP_KERNELS[(tonemap, aa)], h, w, inputs, rows=rows, bands_per_thread=FEW_BANDS_PER_THREAD
            )
        self._drawn = drawn
        if not aa:
            return buffers["ldr"]
        with timer.stage("aa"):
            smoothed = span_grow(rows, FXAA_REACH_PX, h)
            smoothed_cols = span_grow(cols, FXAA_REACH_PX, w)
            if smoothed != NO_ROWS and smoothed_cols != NO_ROWS:
                inputs = [buffers["ldr"], buffers["luma"], buffers["smoothed"], buffers["edges"], *smoothed_cols]
                self.launcher.launch_pixels(fxaa_pixels, h, w, inputs, rows=smoothed)
        return buffers["smoothed"]
