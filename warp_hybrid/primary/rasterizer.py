"""Raster primary visibility: a key buffer of depth|triangle keys, then resolve.

``Rasterizer.find_hits`` runs two timed stages; a frame's ``render`` runs the first and
leaves the second to the surface pass (``hits_for_surface``: ``kernels.surface_kernel``
resolves each chunk of pixels as it reads it, "resolve" 0 ms, its time in "surface"):

* ``raster``: the points are transformed once (``kernels.camera_points_kernel``),
  then every cluster of ``kernels.CLUSTER_TRIANGLES`` consecutive triangles that is not
  wholly outside the view frustum (boxes from ``kernels.cluster_bounds_kernel``, kept
  until the points move) is rasterized (``kernels.coverage_kernel``) into a *key buffer*
  of packed 64-bit keys (float32 view-depth bits << 32 | triangle id) with one atomic
  min per covered pixel centre (``coverage.py``).  On a CPU, Warp's atomics are plain
  read-modify-writes and one launch runs on one thread, so the work is split between
  the launcher's threads and each thread owns one slice of the buffer; the resolve pass
  takes the minimum over the slices (no merge pass).  The clusters are split between
  the threads (bands of clusters, cut where the last frame's clusters cost the most
  time: ``parallel.CostBands``) unless there are fewer than ``MIN_BAND_CLUSTERS`` a
  thread (a small scene, whose few large triangles cost their pixels, not their set-up):
  then the rows are cut into one band a thread and each band clears and covers, with
  every cluster, only its own rows of the first slice (``kernels.cover_rows_kernel``,
  one launch item a band; the bands never meet, so one slice serves them all and the
  resolve reads one key a pixel).  Every pass here, the slices' clear included
  (``kernels.clear_keys_kernel``), is a band pass of the launcher (``parallel``).  On
  CUDA (one "thread", one slice) a GPU thread takes a cluster, whose key updates are
  atomic there.
* ``resolve``: per pixel, the winning triangle is intersected with the pixel's camera
  ray for exact depth and barycentrics: the hit record (``kernels.resolve_kernel``; in
  a frame's surface pass the same statements), the same one the ray-cast path writes.
"""

from __future__ import annotations

import weakref

import numpy as np
import warp as wp

from ..core.camera import CameraGPU
from ..core.gbuffer import GBuffer
from ..core.native_rows import spare_padded
from ..core.rows import RowSpan
from ..parallel import CostBands, Launcher, band, band_count, kept
from ..scene.device import DeviceScene
from ..timing import StageTimer
from . import kernels
from .base import PrimaryVisibility
from .clipping import ProjectedPoints
from .coverage import EMPTY_KEY, MODE_COUNT, MODE_DEPTH, RasterTarget

_EMPTY_KEY = int(EMPTY_KEY.value)
# The fewest clusters a band of the coverage pass holds.
MIN_BAND_CLUSTERS = 16
# How many coverage targets a rasterizer keeps (a frame's one per thread slot, or the
# moved rows' bands of a still view).
KEPT_TARGETS = 32


class Rasterizer(PrimaryVisibility):
    """Finds each pixel's nearest surface by rasterization (stages "raster" and "resolve";
    in ``render`` the surface pass resolves)."""

    def __init__(self, launcher: Launcher) -> None:
        """Use ``launcher`` for the device and the host threads."""
        super().__init__(launcher)
        self._keys: wp.array | None = None
        self._points: ProjectedPoints | None = None
        self._bounds: wp.array | None = None
        # The scene (weakly: never kept alive for this) and geometry_version the boxes are of.
        self._bounds_of: tuple[weakref.ref, int] | None = None
        # The coverage pass's bands of clusters, cut where the last frame's cost lay.
        self._cluster_bands = CostBands()
        # Coverage targets by (keys' data, shape, slot, mode, rows): ``_target``.
        self._targets: dict[tuple, RasterTarget] = {}
        # The key buffer, how many of its slices the last frame wrote, and those slices.
        self._written: tuple[wp.array, int, wp.array] | None = None

    @property
    def projected_points(self) -> ProjectedPoints | None:
        """The last frame's points in camera space and on screen (None before a frame)."""
        return self._points

    @property
    def cluster_boxes(self) -> wp.array | None:
        """The clusters' boxes (clusters, 2) vec3 the last frame culled with (None before)."""
        return self._bounds

    @property
    def key_slices(self) -> wp.array | None:
        """The key buffer (threads, height, width) the last frame rasterized into (None before)."""
        return self._keys

    def _slices(self, height: int, width: int) -> wp.array:
        """The key buffer, one (height, width) slice per thread, reused."""
        shape = (self.launcher.threads, height, width)
        if self._keys is None or self._keys.shape != shape:
            self._keys = wp.empty(shape, dtype=wp.uint64, device=self.launcher.device)
            self._targets.clear()  # (they hold the buffer before)
        return self._keys

    def _target(self, keys: wp.array, slot: int, mode: int, rows: RowSpan) -> RasterTarget:
        """The coverage target: slice ``slot`` of ``keys`` in ``mode``, rows ``rows``; the
        one made before for the same (a frame asks for the same targets as the frame
        before, and a Warp struct's fields cost microseconds each to set)."""

        def make() -> RasterTarget:
            target = RasterTarget()
            target.keys = keys
            target.slot = slot
            target.mode = mode
            target.row_begin, target.row_end = rows
            return target

        return kept(self._targets, (keys.ptr, keys.shape, slot, mode, rows), make, KEPT_TARGETS)

    def _transform_points(self, scene: DeviceScene, camera: CameraGPU) -> ProjectedPoints:
        """The scene's points in camera space and on screen (buffers reused between
        frames), see ``kernels.camera_points_kernel``."""
        count = len(scene.points)
        if self._points is None or self._points.camera.shape[0] != count:
            self._points = ProjectedPoints()
            self._points.camera = wp.zeros(count, dtype=wp.vec3, device=self.launcher.device)
            self._points.outcodes = wp.zeros(count, dtype=wp.int32, device=self.launcher.device)
            # (with a spare point after the last: the coverage pass loads a screen point as four
            # floats, ``cover_batch``)
            self._points.screen = spare_padded(count, wp.vec3, self.launcher.device)
        self.launcher.launch_groups(kernels.camera_points_kernel, count, [scene.gpu.points, camera, self._points])
        return self._points

    def _cluster_bounds(self, scene: DeviceScene) -> wp.array:
        """The clusters' boxes (clusters, 2) vec3, computed again when the points moved."""
        count = scene.scene.triangle_count
        clusters = -(-count // kernels.CLUSTER_TRIANGLES)
        known = self._bounds_of
        fresh = known is not None and known[0]() is scene and known[1] == scene.geometry_version
        if self._bounds is None or self._bounds.shape[0] != clusters or not fresh:
            if self._bounds is None or self._bounds.shape[0] != clusters:
                self._bounds = wp.empty((clusters, 2), dtype=wp.vec3, device=self.launcher.device)
            self.launcher.launch_items(kernels.cluster_bounds_kernel, clusters, [scene.gpu, count, self._bounds])
            self._bounds_of = (weakref.ref(scene), scene.geometry_version)
        return self._bounds

    def _rasterize(
        self,
        scene: DeviceScene,
        camera: CameraGPU,
        keys: wp.array,
        mode: int,
        clear: int,
        rows: RowSpan | None = None,
    ) -> int:
        """Transform the points, then clear each thread's slice and run the coverage kernel
        into it: over bands of clusters (``Launcher.launch_bands``), or, on the CPU for fewer
        than ``MIN_BAND_CLUSTERS`` clusters a thread (and on one thread), every cluster into
        piece k's band of rows, piece k clearing and writing those rows of slice 0 (module
        docstring); on CUDA one launch of a thread a cluster into the one slice.  ``rows``
        (first, stop): only those rows of the slices are cleared and covered.  Returns how
        many slices, from the first, were written (the others are untouched)."""
        launcher = self.launcher
        count = scene.scene.triangle_count
        pts = self._transform_points(scene, camera)
        threads, height, width = keys.shape
        top, bottom = (0, height) if rows is None else rows
        bounds = self._cluster_bounds(scene) if count > 0 else None
        clusters = bounds.shape[0] if bounds is not None else 0

        def inputs(slot: int, band_rows: RowSpan = (top, bottom)) -> list:
            return [scene.gpu, camera, pts, self._target(keys, slot, mode, band_rows), bounds, count]

        if launcher.device.is_cpu and (clusters < threads * MIN_BAND_CLUSTERS or threads == 1):
            # piece k clears and covers its band of rows of slice 0, every cluster each
            spans = [band(k, threads, bottom - top) for k in range(threads)]
            launcher.launch_bands(
                kernels.cover_rows_kernel,
                [*inputs(0), clusters, wp.uint64(clear)],
                [(1, (top + first, top + first + size)) for first, size in spans],
            )
            return 1

        launcher.launch_pixels(
            kernels.clear_keys_kernel, threads * (bottom - top), width, [keys, wp.uint64(clear), top, bottom - top]
        )
        if launcher.device.is_cuda:  # a GPU thread a cluster, its key updates atomic (one slice)
            launcher.launch_items(kernels.coverage_kernel, clusters, inputs(0))
            return threads
        spans = self._cluster_bands.spans(clusters, band_count(clusters, threads, MIN_BAND_CLUSTERS))
        launcher.launch_bands(
            kernels.coverage_kernel,
            inputs,
            [(size, (first, 1)) for first, size in spans],
            measured=(lambda costs: self._cluster_bands.measured(spans, costs)) if mode == MODE_DEPTH else None,
        )
        return threads

    def find_hits(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> None:
        """Rasterize ``scene`` seen by ``camera`` and resolve each pixel's hit record (in
        ``rows``, default every row)."""
        keys = self._raster_stage(scene, camera, gbuffer, timer, rows)
        if keys is None:
            return
        with timer.stage("resolve"):
            self.launcher.launch_pixels(
                kernels.resolve_kernel,
                gbuffer.height,
                gbuffer.width,
                [scene.gpu, camera, keys, gbuffer.rows()],
                rows=rows,
            )

    def hits_for_surface(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None = None
    ) -> wp.array | None:
        """The raster stage alone: the key slices it wrote, which the surface pass resolves
        as it reads them (``kernels.surface_kernel``: the resolve's work inside the surface
        stage, whose pixels it would re-read; the "resolve" stage stays, 0 ms)."""
        keys = self._raster_stage(scene, camera, gbuffer, timer, rows)
        if keys is not None:
            timer.add("resolve", 0.0)
        return keys

    def _raster_stage(
        self, scene: DeviceScene, camera: CameraGPU, gbuffer: GBuffer, timer: StageTimer, rows: RowSpan | None
    ) -> wp.array | None:
        """Stage "raster" over ``rows`` (default every row) of key slices sized for
        ``gbuffer``: the slices it wrote, as one array (kept: a Warp array's slice costs
        ~7 us to make); None where ``rows`` is empty."""
        if rows is not None and rows[0] >= rows[1]:
            return None
        keys = self._slices(gbuffer.height, gbuffer.width)
        with timer.stage("raster"):
            written = self._rasterize(scene, camera, keys, MODE_DEPTH, _EMPTY_KEY, rows)
            if self._written is None or self._written[0] is not keys or self._written[1] != written:
                self._written = (keys, written, keys[:written])
        return self._written[2]

    def overdraw(self, scene: DeviceScene, camera: CameraGPU) -> np.ndarray:
        """Diagnostic: (height, width) int64 count of rasterized fragments per pixel
        (depth complexity; 1 where a flat mesh covers a pixel exactly once)."""
        shape = (self.launcher.threads, camera.height, camera.width)
        keys = wp.empty(shape, dtype=wp.uint64, device=self.launcher.device)
        written = self._rasterize(scene, camera, keys, MODE_COUNT, 0)
        self._targets = {key: t for key, t in self._targets.items() if key[0] != keys.ptr}  # (its own buffer)
        return keys.numpy()[:written].sum(axis=0).astype(np.int64)
