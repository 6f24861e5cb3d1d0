"""Texture images: decode files with OpenCV into linear (H, W, 4) float32, and keep
one ``TextureImage`` per (file, colour space) plus deduplicated ``TextureBinding``s.

Decoding (``images.decode_raw``: OpenCV, Pillow for TGA and CMYK JPEGs): 8/16-bit
integer and float images (PNG, JPEG, TGA, BMP, TIFF, Radiance ``.hdr``, OpenEXR), 1-4
channels; BGR(A) becomes RGB(A); 1 channel is grey (rgb = value, alpha = 1); 2
channels are grey + alpha.  Integers are normalised to [0, 1].  sRGB-encoded images
are decoded to linear (alpha stays linear).  Row 0 of the stored image is the top of
the picture.  ``auto`` colour space: ``images.auto_is_srgb`` (sRGB for 8/16-bit
images with 3 or 4 channels and for every JPEG, raw otherwise).

A file that is missing or cannot be decoded is replaced by a 64x64 magenta/black
checker (8x8-texel squares) and a warning naming the file and the prim that uses it;
a normal map's (``fallback=FLAT_NORMAL_NAME``) by a flat normal map instead: one texel
(0, 0, 1), its bindings reset to scale 1, bias 0 and no uv transform, so it samples
exactly (0, 0, 1) and leaves the surface's normals as they are.
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")  # must be set before cv2 reads an EXR

import cv2  # noqa: E402

from ..model import TextureBinding, TextureImage, Wrap  # noqa: E402
from .images import auto_is_srgb, decode_raw  # noqa: E402
from .validate import Diagnostics  # noqa: E402

CHECKER_NAME = "<missing texture: magenta/black checker>"
FLAT_NORMAL_NAME = "<missing normal map: flat normal>"
_IDENTITY_UV = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
# The (wrap_s, wrap_t, scale, bias, uv_transform) of every binding of the flat normal
# fallback: it is sampled as is, whatever the lost file's node said.
_FLAT_BINDING = (Wrap.REPEAT, Wrap.REPEAT, (1.0, 1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 0.0), _IDENTITY_UV)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """The sRGB electro-optical transfer function (IEC 61966-2-1), elementwise."""
    x = np.asarray(x, dtype=np.float32)
    return np.where(x <= 0.04045, x / 12.92, ((np.maximum(x, 0.0) + 0.055) / 1.055) ** 2.4).astype(np.float32)


_SRGB_LUT8 = srgb_to_linear(np.arange(256, dtype=np.float32) / 255.0)


def checker_pixels(size: int = 64, square: int = 8) -> np.ndarray:
    """The fallback image for missing textures: magenta/black squares, opaque."""
    ij = np.indices((size, size)) // square
    on = ((ij[0] + ij[1]) % 2 == 0)[..., None]
    magenta = np.array([1.0, 0.0, 1.0, 1.0], dtype=np.float32)
    black = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float32)
    return np.where(on, magenta, black).astype(np.float32)


def flat_normal_pixels() -> np.ndarray:
    """The fallback image for missing normal maps: one texel, the normal (0, 0, 1)."""
    return np.array([[[0.0, 0.0, 1.0, 1.0]]], dtype=np.float32)


# Fallback images by name: how to make the pixels, what the warning calls them.
_FALLBACKS = {
    CHECKER_NAME: (checker_pixels, "a magenta/black checker"),
    FLAT_NORMAL_NAME: (flat_normal_pixels, "a flat normal map (the surface's own normals)"),
}


def read_asset_bytes(resolved_path: str) -> bytes:
    """The bytes of a resolved asset: a plain file, or a file inside a ``.usdz``
    package (``pkg.usdz[inner/path.png]``), read through pxr's asset resolver."""
    if resolved_path.endswith("]") and "[" in resolved_path:
        from pxr import Ar

        asset = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved_path))
        if asset is None:
            raise OSError(f"cannot open {resolved_path}")
        return bytes(asset.GetBuffer())
    with open(resolved_path, "rb") as f:
        return f.read()


def decode_image(data: bytes, color_space: str = "auto") -> tuple[np.ndarray, str]:
    """Decode encoded image ``data`` to linear RGBA float32 (H, W, 4), row 0 on top.

    ``color_space`` is ``sRGB``, ``raw`` or ``auto``; returns the pixels and the
    colour space actually applied (``sRGB`` or ``raw``).  Raises ``ValueError`` when
    neither OpenCV nor Pillow can decode the data.
    """
    raw, jpeg = decode_raw(data)
    if raw.ndim == 2:
        raw = raw[:, :, None]
    channels = raw.shape[2]
    srgb = color_space == "sRGB" or (color_space == "auto" and auto_is_srgb(raw.dtype, channels, jpeg))
    if channels == 2:  # grey + alpha: OpenCV has no conversion for it
        rgba = np.ascontiguousarray(raw[..., [0, 0, 0, 1]])
    else:
        code = {1: cv2.COLOR_GRAY2RGBA, 3: cv2.COLOR_BGR2RGBA, 4: cv2.COLOR_BGRA2RGBA}[channels]
        if raw.dtype not in (np.uint8, np.uint16, np.float32):
            raw = raw.astype(np.float32)
        rgba = cv2.cvtColor(np.ascontiguousarray(raw), code)  # integer alpha = max value, float alpha = 1
    if rgba.dtype == np.uint8:
        ramp = np.arange(256, dtype=np.float32) / 255.0
        lut = np.stack([_SRGB_LUT8 if srgb else ramp] * 3 + [ramp], axis=-1).reshape(256, 1, 4)
        return cv2.LUT(rgba, lut), ("sRGB" if srgb else "raw")
    out = rgba.astype(np.float32)
    if rgba.dtype == np.uint16:
        out *= np.float32(1.0 / 65535.0)
    if srgb:
        out[..., :3] = srgb_to_linear(out[..., :3])
    return out, ("sRGB" if srgb else "raw")


def load_image(resolved_path: str, color_space: str, broadcast: int = -1) -> tuple[np.ndarray, str]:
    """Read and decode one texture file (see ``decode_image``); ``broadcast`` >= 0
    copies that channel into r, g and b."""
    pixels, applied = decode_image(read_asset_bytes(resolved_path), color_space)
    if broadcast >= 0:
        pixels = np.ascontiguousarray(pixels[..., [broadcast, broadcast, broadcast, 3]])
    return pixels, applied


@dataclass
class _Job:
    """An image index handed out whose pixels are still being decoded."""

    index: int
    path: str
    broadcast: int
    owner: str
    future: Future | None
    problem: str = ""
    fallback: str = CHECKER_NAME


class ImageLibrary:
    """The images and texture bindings of one scene, shared and deduplicated.

    Images are keyed by (resolved file, colour space applied, channel broadcast), so
    ``auto`` shares the image of the space it resolves to; bindings by all their
    fields, so materials that use the same texture node share one binding.

    Files decode on worker threads (OpenCV releases the GIL) while the caller goes on
    reading geometry: ``image`` hands out an index at once, ``finish`` waits for the
    pixels and settles the table (merging duplicates, checker for failures).
    """

    def __init__(self, diag: Diagnostics, workers: int | None = None) -> None:
        """Warnings about unreadable files go to ``diag``; ``workers`` decode threads
        (default: one per core, at most 4)."""
        self.diag = diag
        self.images: list[TextureImage] = []
        self.textures: list[TextureBinding] = []
        self._workers = workers or min(4, os.cpu_count() or 1)
        self._pool: ThreadPoolExecutor | None = None
        self._jobs: list[_Job] = []
        self._image_keys: dict[tuple[str, str, int, str], int] = {}
        self._decoded: dict[tuple[str, str, int], int] = {}
        self._fallback_index: dict[str, int] = {}
        self._binding_keys: dict[tuple, int] = {}

    def image(
        self,
        resolved_path: str,
        authored_path: str,
        color_space: str,
        owner: str,
        broadcast: int = -1,
        fallback: str = CHECKER_NAME,
    ) -> int:
        """Index of the image for ``resolved_path`` (empty when pxr could not resolve
        ``authored_path``) decoded in ``color_space``; valid once ``finish`` ran.

        ``broadcast`` >= 0 copies that channel into r, g and b (a colour input fed by
        a single-channel output).  A missing or undecodable file warns (at ``finish``),
        naming the file and ``owner`` (the material or light prim), and yields the
        ``fallback`` image: the checker (``CHECKER_NAME``) or, for normal maps, the
        flat normal (``FLAT_NORMAL_NAME``).
        """
        # An unresolved file is keyed by its authored name, so each missing file is reported by name.
        key = (resolved_path or f"<unresolved {authored_path}>", color_space, broadcast, fallback)
        if key in self._image_keys:
            return self._image_keys[key]
        index = len(self.images)
        self.images.append(TextureImage(f"<loading {resolved_path or authored_path}>", np.zeros((1, 1, 4), np.float32)))
        if resolved_path:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=self._workers, thread_name_prefix="texture")
            job = _Job(
                index,
                resolved_path,
                broadcast,
                owner,
                self._pool.submit(load_image, resolved_path, color_space, broadcast),
                fallback=fallback,
            )
        else:
            job = _Job(index, "", broadcast, owner, None, f"texture file {authored_path!r} not found", fallback)
        self._jobs.append(job)
        self._image_keys[key] = index
        return index

    def finish(self) -> None:
        """Wait for pending decodes and settle the table: failures become their
        fallback image (with a warning; the bindings of a flat normal sample it as is),
        images equal to one already loaded are merged, and every index handed out is
        remapped to its final place."""
        if not self._jobs:
            return
        jobs, self._jobs = self._jobs, []
        first = jobs[0].index  # pending images are the tail of the table
        kept = self.images[:first]
        remap: dict[int, int] = {}
        for job in jobs:
            result = None
            if job.future is not None:
                try:
                    result = job.future.result()
                except (OSError, ValueError, cv2.error) as exc:
                    job.problem = f"texture {job.path!r} cannot be read ({exc})"
            if result is None:
                make, description = _FALLBACKS[job.fallback]
                self.diag.warn(f"{job.problem}; using {description}", job.owner)
                if job.fallback not in self._fallback_index:
                    kept.append(TextureImage(job.fallback, make()))
                    self._fallback_index[job.fallback] = len(kept) - 1
                remap[job.index] = self._fallback_index[job.fallback]
                continue
            pixels, applied = result
            decoded_key = (job.path, applied, job.broadcast)
            if decoded_key not in self._decoded:
                name = job.path if job.broadcast < 0 else f"{job.path}[{'rgba'[job.broadcast]}]"
                kept.append(TextureImage(name, pixels))
                self._decoded[decoded_key] = len(kept) - 1
            remap[job.index] = self._decoded[decoded_key]
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        self.images = kept
        self._image_keys = {k: remap.get(v, v) for k, v in self._image_keys.items()}
        for t in self.textures:
            t.image = remap.get(t.image, t.image)
            if self._is_flat_normal(t.image):
                t.wrap_s, t.wrap_t, t.scale, t.bias, t.uv_transform = _FLAT_BINDING
        self._binding_keys = {}
        for i, t in enumerate(self.textures):
            self._binding_keys.setdefault((t.image, int(t.wrap_s), int(t.wrap_t), t.scale, t.bias, t.uv_transform), i)

    def _is_flat_normal(self, image: int) -> bool:
        return image == self._fallback_index.get(FLAT_NORMAL_NAME, -1)

    def binding(
        self,
        image: int,
        wrap_s: Wrap = Wrap.REPEAT,
        wrap_t: Wrap = Wrap.REPEAT,
        scale: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
        bias: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        uv_transform: tuple[float, float, float, float, float, float] = _IDENTITY_UV,
    ) -> int:
        """Index of the ``TextureBinding`` with these fields (created once); a binding
        of the flat normal fallback takes ``_FLAT_BINDING``'s fields instead."""
        if self._is_flat_normal(image):
            wrap_s, wrap_t, scale, bias, uv_transform = _FLAT_BINDING
        key = (image, int(wrap_s), int(wrap_t), tuple(scale), tuple(bias), tuple(uv_transform))
        if key not in self._binding_keys:
            binding = TextureBinding(image, Wrap(wrap_s), Wrap(wrap_t), tuple(scale), tuple(bias), tuple(uv_transform))
            self.textures.append(binding)
            self._binding_keys[key] = len(self.textures) - 1
        return self._binding_keys[key]
