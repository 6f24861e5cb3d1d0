"""Image file decoding below the colour pipeline: bytes -> an OpenCV-layout array, and
the rule for what ``sourceColorSpace = auto`` means.

OpenCV (``cv2.imdecode``) reads most formats; Pillow reads what it cannot (TGA, and
any other format Pillow knows) and the CMYK/YCCK JPEGs, whose Adobe inversion and
colour transform Pillow applies (converted to RGB).  Either way the result has
OpenCV's layout, BGR(A) channel order, 8/16-bit integers or float32, so the caller
(``textures.decode_image``) converts one kind of array.

``auto`` (UsdUVTexture) is sRGB for integer images (8 or 16 bits) with 3 or 4
channels and for every JPEG (one-channel ones included: JPEG stores perceptual
values), raw for float images (EXR, HDR) and for one- or two-channel non-JPEG images
(data maps such as roughness).
"""

from __future__ import annotations

import io

import cv2
import numpy as np
from PIL import Image, UnidentifiedImageError

_JPEG_MAGIC = b"\xff\xd8\xff"
_PILLOW_KEPT_MODES = ("RGB", "RGBA", "L", "LA", "I;16", "F")


def is_jpeg(data: bytes) -> bool:
    """True when ``data`` starts like a JPEG file."""
    return data[:3] == _JPEG_MAGIC


def _pillow_image(data: bytes) -> Image.Image:
    try:
        return Image.open(io.BytesIO(data))
    except (UnidentifiedImageError, OSError) as exc:
        raise ValueError(f"neither OpenCV nor Pillow can decode this image ({exc})") from None


def _pillow_array(image: Image.Image) -> np.ndarray:
    """Pillow's pixels in OpenCV's layout: palette and CMYK/YCCK images to RGB(A),
    then the channels in BGR(A) order."""
    if image.mode not in _PILLOW_KEPT_MODES:
        image = image.convert("RGBA" if image.mode in ("P", "PA", "RGBa", "La") else "RGB")
    try:
        pixels = np.asarray(image)
    except OSError as exc:
        raise ValueError(f"Pillow cannot decode this image ({exc})") from None
    if pixels.ndim == 3 and pixels.shape[2] >= 3:
        pixels = pixels[..., [2, 1, 0, 3][: pixels.shape[2]]]
    return np.ascontiguousarray(pixels, dtype=pixels.dtype.newbyteorder("="))


def decode_raw(data: bytes) -> tuple[np.ndarray, bool]:
    """Decode ``data`` into an OpenCV-layout array (H, W) or (H, W, C) and whether it is
    a JPEG.  Raises ``ValueError`` when neither library can decode it."""
    jpeg = is_jpeg(data)
    if jpeg and _pillow_image(data).mode in ("CMYK", "YCCK"):
        return _pillow_array(_pillow_image(data)), True
    raw = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED | cv2.IMREAD_ANYDEPTH)
    if raw is None or raw.size == 0:
        raw = _pillow_array(_pillow_image(data))
    if raw.size == 0:
        raise ValueError("the image is empty")
    return raw, jpeg


def auto_is_srgb(dtype: np.dtype, channels: int, jpeg: bool) -> bool:
    """Whether ``sourceColorSpace = auto`` decodes an image as sRGB (module docstring)."""
    if not np.issubdtype(dtype, np.integer):
        return False
    return jpeg or channels >= 3
