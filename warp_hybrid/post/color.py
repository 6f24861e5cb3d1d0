"""Colour conversions shared by the loader (texture decode) and the output stage.

The sRGB transfer functions (IEC 61966-2-1) as host numpy functions, the kernels'
exact 8-bit encoder (a table lookup, no ``pow``), and the host Rec. 709 luminance
(weights ``core.constants.LUMA_709``).  Colours are linear everywhere inside the
renderer; sRGB only appears in 8-bit images (textures in, PNGs out).

Encode (OETF), linear ``x`` in [0, 1] -> sRGB ``s``:
``s = 12.92 x`` for ``x <= 0.0031308``, else ``s = 1.055 x^(1/2.4) - 0.055``.
Decode (EOTF), ``x = s / 12.92`` for ``s <= 0.04045``, else ``((s + 0.055) / 1.055)^2.4``.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..core.constants import LUMA_709
from ..core.native_rows import LAMBDA_HEADER_CPP


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear values -> sRGB-encoded values (float, same shape); input clipped to [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    out = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return out.astype(np.float32)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] -> linear values (float32, same shape).

    Accepts floats in [0, 1] or uint8/uint16 arrays (scaled by their maximum)."""
    s = np.asarray(encoded)
    if s.dtype == np.uint8:
        s = s.astype(np.float64) / 255.0
    elif s.dtype == np.uint16:
        s = s.astype(np.float64) / 65535.0
    s = np.clip(s.astype(np.float64), 0.0, 1.0)
    out = np.where(s <= 0.04045, s / 12.92, np.power((s + 0.055) / 1.055, 2.4))
    return out.astype(np.float32)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (..., 3) -> (...)."""
    return np.asarray(rgb, dtype=np.float64)[..., :3] @ np.asarray(LUMA_709)


SRGB_LUT_SIZE = 4096  # cells of 1/4096 < the smallest step between 8-bit codes (1 / (12.92 * 255))


def srgb_thresholds() -> np.ndarray:
    """(255,) float32 linear values where the 8-bit sRGB code steps up: code ``k + 1``
    starts at ``srgb_decode((k + 0.5) / 255)``, i.e. exactly where
    ``round(255 * srgb_encode(x))`` changes."""
    return srgb_decode((np.arange(255, dtype=np.float64) + 0.5) / 255.0)


@wp.struct
class Srgb8Encoder:
    """The table of the kernels' exact 8-bit sRGB encoder (see ``srgb_quantize``): for
    each of ``SRGB_LUT_SIZE`` cells of [0, 1], plus one for x = 1, the code at the
    cell's start and the threshold of the next code (+inf after 255)."""

    cells: wp.array(dtype=wp.vec2)


def make_srgb8_encoder(device: wp.context.Device | str) -> Srgb8Encoder:
    """Upload the encoder table (see ``Srgb8Encoder``)."""
    thresholds = np.append(srgb_thresholds(), np.float32(np.inf))
    starts = (np.arange(SRGB_LUT_SIZE + 1) / SRGB_LUT_SIZE).astype(np.float32)
    codes = np.searchsorted(thresholds[:-1], starts, side="right")
    enc = Srgb8Encoder()
    enc.cells = wp.array(np.stack([codes.astype(np.float32), thresholds[codes]], axis=-1), dtype=wp.vec2, device=device)
    return enc


#: C++ statements: the 8-bit code ``code`` (int) of linear float ``x`` from the encoder's
#: cells ``cells`` (``const wp::vec2*``): see ``srgb_quantize``.  (After
#: ``LAMBDA_HEADER_CPP``: the cell's two floats by ``wh_load2``, on the CPU one 64-bit load,
#: which a loop across values gathers as one 64-bit lane a value, not two 32-bit ones.)
SRGB_QUANTIZE_CPP = f"""
const float xc = x > 0.0f ? (x < 1.0f ? x : 1.0f) : 0.0f;
float cell_code, cell_threshold;
wh_load2((const float*)(cells + (int)(xc * {float(SRGB_LUT_SIZE)!r}f)), cell_code, cell_threshold);
const int code = (int)cell_code + (xc >= cell_threshold ? 1 : 0);
"""


@wp.func_native(LAMBDA_HEADER_CPP + "const wp::vec2* cells = enc.cells.data;" + SRGB_QUANTIZE_CPP + "return code;")
def srgb_quantize(x: float, enc: Srgb8Encoder) -> int:
    """The 8-bit sRGB code of linear ``x``, exactly ``round(255 * srgb_encode(x))``
    without a ``pow`` or a branch: clamp to [0, 1] (NaN -> 0), take the code at the
    start of x's table cell, plus one if x is past the single step a cell can contain
    (cells are narrower than any step; the +inf threshold stops code 255).  Written once
    as ``SRGB_QUANTIZE_CPP``, which the tone map's row loop uses too."""
    ...
