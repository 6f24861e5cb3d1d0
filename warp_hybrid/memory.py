"""The memory a renderer needs, estimated before anything is allocated, and the check
that refuses what cannot fit.

``frame_bytes`` is what a ``Renderer`` allocates per frame size, from the tables that
size the buffers: the G-buffer channels (``core.gbuffer.CHANNELS``), the three radiance
layers and the per-light visibility of ``FrameBuffers``, the rasterizer's 64-bit key
slice per host thread, the passes' own per-pixel lists (focus list and weights, ray
counts and transmittance, the shadowed lighting pass's direct sums (counted whether
shadow maps are on or not), the post's luma, 8-bit images and FXAA edge list:
``PASS_BYTES_PER_PIXEL`` plus ``PASS_BYTES_PER_PIXEL_LIGHT`` per light), a supersampled frame's sums, a
supersampled window's own G-buffer and layers, the second visibility layer behind
alpha-blended surfaces where the scene has any, and the host copies a frame returns.
``scene_bytes`` is the device copy of the scene with its BVHs; ``shadow_map_bytes``
the shadow maps where they are on (``lighting.shadow_maps``); ``probe_bytes`` the
reflection probe where it is on (``lighting.probes``).  A test holds the
estimate against the arrays a renderer really holds (never below, at most 1.5x).

``check_memory`` refuses, with the estimate in the message, a renderer whose estimate
exceeds the memory available now (``MemAvailable`` on the CPU, the device's free memory
on a GPU plus the host's for the host copies), before the first allocation, so a huge
``--size`` is one clear error instead of an allocator failure seconds later.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import warp as wp

from .core.gbuffer import CHANNELS
from .errors import RenderSettingsError
from .lighting.probes import level_sizes
from .scene.model import Scene

#: Radiance layers of ``FrameBuffers`` (raster, traced, composed), one vec3 each.
COLOR_LAYERS = 3
#: The passes' own per-pixel buffers, and the part of them that grows with the lights.
PASS_BYTES_PER_PIXEL = 72
PASS_BYTES_PER_PIXEL_LIGHT = 4
#: Temporal reuse: two frames of history, each a colour, an age, a depth and a normal.
REUSE_BYTES_PER_PIXEL = 2 * (12 + 4 + 4 + 12)
#: The rasterizer's depth/triangle key, one slice per host thread.
KEY_BYTES = 8
#: A frame's host copies per pixel: the 8-bit image, colour and visibility, and the
#: G-buffer AOVs (position promoted to float64 on its way to world space).
HOST_BYTES_PER_PIXEL = 3 + 12 + 64
#: Device bytes per triangle besides its arrays: the main BVH and the shadow BVHs.
BVH_BYTES_PER_TRIANGLE = 128
#: Device bytes per triangle of its error bound for ray origins (``scene/device/triangle_bound.py``).
TRIANGLE_BOUND_BYTES = 4
#: On the CPU, the 4-wide BVHs over those triangles that the tracer and the ray-cast
#: primaries query (``scene/device/wide_bvh.py``): 52-55 bytes a triangle each measured
#: on the shared scenes, and the scene's and the opaque shadow one hold nearly every
#: triangle.  (Their build's scratch, at most 116 bytes a triangle, lives only while one
#: is built.)
WIDE_BVH_BYTES_PER_TRIANGLE = 112
#: Texel mip chains add a third to every image (float4 texels).
MIP_FACTOR = 4.0 / 3.0
#: Shadow maps: faces per light at most (a cube map), float32 depth per texel, the hit
#: record target a face is drawn into (per texel) and the map rasterizer's projected
#: points (per scene point).
SHADOW_FACES = 6
SHADOW_TEXEL_BYTES = 4
SHADOW_SCRATCH_BYTES = 12
PROJECTED_POINT_BYTES = 24
#: Reflection probe: a cube's faces, vec4 texels, a vec3 colour per capture texel.
PROBE_FACES = 6
PROBE_TEXEL_BYTES = 16
PROBE_COLOR_BYTES = 12


def gbuffer_bytes_per_pixel() -> int:
    """Bytes of one G-buffer pixel (every channel of ``CHANNELS``)."""
    return sum(wp.types.type_size_in_bytes(c.dtype) for c in CHANNELS)


@dataclass(frozen=True)
class MemoryEstimate:
    """Bytes a renderer needs: ``device`` (frame buffers and scene on the device),
    ``host`` (the frame's host copies) and how much of the device part is the scene."""

    device: int
    host: int
    scene: int

    @property
    def total(self) -> int:
        """Everything, for a CPU device where both live in the same memory."""
        return self.device + self.host


def frame_bytes(
    width: int,
    height: int,
    lights: int,
    threads: int,
    spp: int = 1,
    fovea_spp: int = 1,
    alpha_layer: bool = False,
    reuse: bool = False,
) -> int:
    """Device bytes of the frame buffers of a ``width`` x ``height`` renderer (module docs;
    ``alpha_layer``: the second visibility layer behind alpha-blended surfaces;
    ``reuse``: temporal reuse's two frames of history)."""
    gbuffer = gbuffer_bytes_per_pixel()
    layers = COLOR_LAYERS * 12 + 4 * lights
    per_pixel = gbuffer + layers + KEY_BYTES * threads + PASS_BYTES_PER_PIXEL + PASS_BYTES_PER_PIXEL_LIGHT * lights
    if spp > 1:
        per_pixel += 12 + 4 * lights  # the sums of colour and visibility
    if fovea_spp > 1:
        per_pixel += gbuffer + layers  # the window's own G-buffer and layers
    if alpha_layer:
        per_pixel += gbuffer + 12 + KEY_BYTES * threads  # its G-buffer, colour and rasterizer keys
    if reuse:
        per_pixel += REUSE_BYTES_PER_PIXEL
    return per_pixel * width * height


def shadow_map_bytes(size: int, lights: int, threads: int, points: int) -> int:
    """Device bytes of the shadow maps of ``lights`` lights, ``size`` texels a side
    (0: off): every face (at most ``SHADOW_FACES`` a light), the target a face is drawn
    into with the rasterizer's key slice per thread, and the projected points."""
    if size <= 0:
        return 0
    texels = size * size
    faces = SHADOW_FACES * lights * SHADOW_TEXEL_BYTES * texels
    return faces + (SHADOW_SCRATCH_BYTES + KEY_BYTES * threads) * texels + PROJECTED_POINT_BYTES * points


def probe_bytes(size: int, threads: int, points: int) -> int:
    """Device bytes of a reflection probe of ``size`` texels a face side (0: off): its
    filtered levels (``lighting.probes.level_sizes``) and face cameras, the face's
    G-buffer and colour it is captured into with the rasterizer's key slice per thread,
    and the projected points."""
    if size <= 0:
        return 0
    texels = sum(PROBE_FACES * s * s for s in level_sizes(size)) + PROBE_FACES
    face = (gbuffer_bytes_per_pixel() + PROBE_COLOR_BYTES + KEY_BYTES * threads) * size * size
    return PROBE_TEXEL_BYTES * texels + face + PROJECTED_POINT_BYTES * points


def host_bytes(width: int, height: int, lights: int) -> int:
    """Host bytes of a frame's copies (image, colour, visibility, AOVs)."""
    return (HOST_BYTES_PER_PIXEL + 8 * lights) * width * height


def scene_bytes(scene: Scene, wide_bvh: bool = False) -> int:
    """Device bytes of ``scene``'s upload: its arrays, BVHs (``wide_bvh``: and their 4-wide
    copies, as the CPU tracer builds) and texel mip chains."""
    per_triangle = BVH_BYTES_PER_TRIANGLE + (WIDE_BVH_BYTES_PER_TRIANGLE if wide_bvh else 0)
    arrays = sum(a.nbytes for a in (scene.points, scene.indices, scene.corner_normals, scene.corner_uvs))
    arrays += scene.triangle_material.nbytes + (TRIANGLE_BOUND_BYTES + per_triangle) * scene.triangle_count
    texels = sum(image.pixels.nbytes for image in scene.images)
    return int(arrays + MIP_FACTOR * texels)


def available_bytes(device: wp.context.Device) -> tuple[int | None, int | None]:
    """(device, host) bytes available now; None where it cannot be known.  On the CPU
    both are the host's ``MemAvailable``."""
    host = _host_available()
    if device.is_cuda:
        return int(device.free_memory), host
    return host, host


def _host_available() -> int | None:
    """``MemAvailable`` of ``/proc/meminfo`` (Linux), else the free pages, else None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _size(n: float) -> str:
    """Bytes as a short human figure (``3.5 GB``, ``120.0 MB``)."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{int(n)} B"


def check_memory(
    width: int,
    height: int,
    lights: int,
    threads: int,
    device: wp.context.Device,
    scene: Scene | None = None,
    spp: int = 1,
    fovea_spp: int = 1,
    shadow_maps: int = 0,
    points: int = 0,
    alpha_layer: bool = False,
    probe: int = 0,
    reuse: bool = False,
) -> MemoryEstimate:
    """The estimate for a renderer of this size (with ``scene`` still to upload, or
    None when it is on the device already; ``shadow_maps``: the maps' size, 0 when off,
    for a scene of ``points`` points; ``alpha_layer``: the layer behind blended
    surfaces; ``probe``: the reflection probe's face size, 0 when off; ``reuse``: temporal
    reuse's history); a ``RenderSettingsError`` stating it when it exceeds what ``device``
    (and the host) has available now."""
    upload = scene_bytes(scene, wide_bvh=device.is_cpu) if scene is not None else 0
    maps = shadow_map_bytes(shadow_maps, lights, threads, points) + probe_bytes(probe, threads, points)
    estimate = MemoryEstimate(
        device=frame_bytes(width, height, lights, threads, spp, fovea_spp, alpha_layer, reuse) + maps + upload,
        host=host_bytes(width, height, lights),
        scene=upload,
    )
    on_device, on_host = available_bytes(device)
    needs, has = (estimate.device, on_device) if device.is_cuda else (estimate.total, on_host)
    if has is not None and needs > has:
        raise RenderSettingsError(
            f"a {width}x{height} frame needs about {_size(needs)} on {device.alias} "
            f"({_size(needs - upload)} for the frame and its copies, {_size(upload)} for the scene), more than the "
            f"{_size(has)} available: render a smaller image"
        )
    if device.is_cuda and on_host is not None and estimate.host > on_host:
        raise RenderSettingsError(
            f"a {width}x{height} frame needs about {_size(estimate.host)} of host memory for its copies, "
            f"more than the {_size(on_host)} available: render a smaller image"
        )
    return estimate
