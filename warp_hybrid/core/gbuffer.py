"""The G-buffer: per-pixel attributes of the nearest visible surface, from one table.

``CHANNELS`` is the one list of what a G-buffer pixel holds (Falcor's
``kGBufferChannels``).  Everything else is generated from it: allocation, ``clear``
(which writes the *background record*, so passes leave background pixels alone), the
host AOVs, and the two kernel-side structs, ``GBufferArrays`` (2-D ``[row, column]``
views, what the stages after the primary pass read) and ``GBufferRows`` (flat
row-major views, one index per store, what the primary passes write).

The *hit record* of a pixel is (triangle_id, depth, barycentric): which triangle is
nearest, how deep, where on it.  Both primary-visibility paths write it; the shared
surface pass evaluates every other channel from it.  Arrays are indexed
``[row, column]`` with row 0 at the top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from .native_rows import SURFACE_CHUNK_CPU


@wp.struct
class Optics:
    """How a surface treats light beyond its colours.  ``reflectivity``: luminance of the
    Fresnel reflectance at normal incidence (of F0); ``ior``: index of refraction;
    ``opacity``: 1 opaque, 0 clear; ``roughness``: UsdPreviewSurface roughness."""

    reflectivity: float
    ior: float
    opacity: float
    roughness: float


@dataclass(frozen=True)
class Channel:
    """One G-buffer channel: its name, Warp dtype, the value background pixels hold,
    and, for channels in the AOV contract, the value the AOV shows on background."""

    name: str
    dtype: Any
    background: float
    doc: str
    aov_background: float | None = None


CHANNELS: tuple[Channel, ...] = (
    Channel("triangle_id", wp.int32, -1, "nearest triangle (hit record; -1 background)"),
    Channel("depth", wp.float32, math.inf, "view depth along the camera's forward axis (hit record)", math.inf),
    Channel("barycentric", wp.vec2, 0.0, "Warp's (u, v) of the hit on triangle_id (hit record)"),
    Channel("position", wp.vec3, 0.0, "hit point in the scene's local frame (world = it + Scene.origin)", math.nan),
    Channel("normal", wp.vec3, 0.0, "unit shading normal, facing the camera", math.nan),
    Channel(
        "geometric_normal",
        wp.vec3,
        0.0,
        "unit face normal, facing the camera (ray offsets, shadow-map lookups; left out by a raster frame without"
        " shadow maps, which reads it nowhere: GBuffer.geometric_normals)",
    ),
    Channel("albedo", wp.vec3, 0.0, "diffuse colour: linear, textures applied, times (1 - metallic)", 0.0),
    Channel("specular", wp.vec3, 0.0, "specular F0 colour"),
    Channel("emission", wp.vec3, 0.0, "emitted radiance"),
    Channel("optics", Optics, 0.0, "reflectivity, ior, opacity, roughness (``Optics``)"),
    Channel("material_id", wp.int32, -1, "index into the material table (-1 background)"),
)


#: Each channel's background value by name (what a pixel that sees no surface holds).
BACKGROUND: dict[str, float] = {c.name: c.background for c in CHANNELS}


def _kernel_struct(name: str, ndim: int, doc: str) -> type:
    """A Warp struct with one ``ndim``-dimensional array per channel."""
    fields = {c.name: wp.array(dtype=c.dtype, ndim=ndim) for c in CHANNELS}
    return wp.struct(type(name, (), {"__annotations__": fields, "__doc__": doc, "__module__": __name__}))


GBufferArrays = _kernel_struct("GBufferArrays", 2, "Every channel as a 2-D [row, column] array.")
GBufferRows = _kernel_struct("GBufferRows", 1, "Every channel as a flat row-major view: pixel (x, y) at y * width + x.")


class GBuffer:
    """Device arrays of every channel, each (height, width); ``gbuffer.<channel>``.

    ``background_blocks`` ((height, ceil(width / SURFACE_CHUNK_CPU)) int32): per row, whether each
    block of ``SURFACE_CHUNK_CPU`` pixels (from column 0) holds the background record, 1 where the
    surface pass's row loop wrote it there, 0 where it wrote a surface or does not know
    (``clear``); a block that sees no surface again is left as it is.  Likewise
    ``emission_background``: whether the emission channel holds the background's zero in
    every pixel (``surface_writes_emission``).  ``geometric_normals``: whether the
    ``geometric_normal`` channel holds every pixel's (a surface pass told not to write it
    leaves it as it was: ``surface_draws_geometric_normals``).  The channels are the
    primary passes' to write: anything else that writes one must ``clear``."""

    def __init__(self, width: int, height: int, device: wp.context.Device | str) -> None:
        """Allocate a G-buffer of ``width`` x ``height`` on ``device``, cleared."""
        self.width = int(width)
        self.height = int(height)
        self.device = wp.get_device(device)
        shape = (self.height, self.width)
        self._arrays = {c.name: wp.empty(shape, dtype=c.dtype, device=self.device) for c in CHANNELS}
        self.background_blocks = wp.zeros(
            (self.height, -(-self.width // SURFACE_CHUNK_CPU)), dtype=wp.int32, device=self.device
        )
        self.emission_background = False
        self.geometric_normals = True
        self._rows = GBufferRows()
        self._kernel_arrays = GBufferArrays()
        for name, array in self._arrays.items():
            setattr(self._rows, name, array.reshape((-1,)))
            setattr(self._kernel_arrays, name, array)
        self.clear()

    def __getattr__(self, name: str) -> wp.array:
        arrays = self.__dict__.get("_arrays", {})
        if name in arrays:
            return arrays[name]
        raise AttributeError(f"GBuffer has no channel {name!r}")

    def arrays(self) -> dict[str, wp.array]:
        """Every channel's array by name, in table order."""
        return dict(self._arrays)

    def clear(self) -> None:
        """Write the background record into every pixel (each channel's ``background``).
        A new buffer starts so; the primary passes write every pixel of every frame
        (the background's values where no surface is hit), so frames need no clear.
        ``background_blocks`` is zeroed (unknown)."""
        self.background_blocks.zero_()
        self.emission_background = True
        self.geometric_normals = True
        for c in CHANNELS:
            array = self._arrays[c.name]
            if c.background == 0.0:
                array.zero_()
            else:
                array.fill_(c.background)

    def surface_draws_geometric_normals(self, drawn: bool, every_row: bool) -> None:
        """Record what the surface pass about to run leaves in the ``geometric_normal``
        channel: a pass that does not write it (``drawn`` False) leaves the channel stale;
        one that writes it over every row (``every_row``) leaves every pixel's."""
        if not drawn:
            self.geometric_normals = False
        elif every_row:
            self.geometric_normals = True

    def require_geometric_normals(self, reader: str) -> None:
        """Raise ``ValueError`` naming ``reader`` where the ``geometric_normal`` channel does
        not hold every pixel's (``geometric_normals``)."""
        if not self.geometric_normals:
            raise ValueError(
                f"{reader} reads the G-buffer's geometric normals, which the frame that drew it left out "
                "(a raster frame without shadow maps reads them nowhere): render with shadow_maps=True, "
                "or set PrimaryVisibility.geometric_normals"
            )

    def surface_writes_emission(self, emissive: bool, every_row: bool) -> bool:
        """Whether the surface pass about to run must write the emission channel, for a
        scene with (``emissive``) or without an emissive material, over every row
        (``every_row``) or some: always for an emissive scene; for one without (whose
        every pixel emits the background's zero) only until the channel holds zero
        everywhere, which a pass over every row leaves.  Records what the pass leaves,
        so call it once per pass."""
        write = emissive or not self.emission_background
        if write:
            self.emission_background = not emissive and every_row
        return write

    def rows(self) -> GBufferRows:
        """The flat kernel-side views (what the primary passes write): one struct, built
        with the buffer (its arrays never change), so a launch packs it without
        rebuilding it."""
        return self._rows

    def kernel_arrays(self) -> GBufferArrays:
        """The 2-D kernel-side views (what the later stages read), likewise built once."""
        return self._kernel_arrays

    def channel_numpy(self, name: str) -> np.ndarray:
        """A host copy of one channel as plain numbers: (H, W) or (H, W, k); struct
        channels become one float32 column per field, in field order."""
        values = self._arrays[name].numpy()
        if values.dtype.names:
            return np.stack([values[f] for f in values.dtype.names], axis=-1).astype(np.float32)
        return values

    def hit_mask(self) -> np.ndarray:
        """(H, W) bool: True where a surface was hit."""
        return self.triangle_id.numpy() >= 0

    def aovs(self) -> dict[str, np.ndarray]:
        """Host copies of the channels in the AOV contract, float32, background pixels
        set to each channel's ``aov_background``."""
        hit = self.hit_mask()
        out = {}
        for c in CHANNELS:
            if c.aov_background is None:
                continue
            values = self.channel_numpy(c.name).astype(np.float32)
            values[~hit] = c.aov_background
            out[c.name] = values
        return out
