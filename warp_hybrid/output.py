"""Writing results: PNG images, AOV arrays and statistics, always atomically.

Every file is written to a temporary name in its destination folder and renamed into
place, so an error (or a kill) never leaves a half-written output behind; missing
folders are created, and a new file gets the ordinary umask permissions
(``gaze.atomic``, the one atomic writer).
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from gaze.atomic import write_atomic
from gaze.errors import GazeError

from .errors import WarpHybridError


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and an atomic rename, creating
    missing folders; a file-system error is a ``WarpHybridError`` naming the file."""
    try:
        write_atomic(path, data, make_parents=True)
    except GazeError as exc:
        raise WarpHybridError(str(exc)) from None


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 RGB image (row 0 = top)."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) uint8 image, got {image.shape} {image.dtype}")
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(image[..., ::-1]))
    if not ok:
        raise WarpHybridError("OpenCV could not encode the PNG image")
    return buf.tobytes()


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an (H, W, 3) uint8 sRGB image as PNG, atomically.  The extension must be
    .png (other formats would silently change meaning)."""
    if Path(path).suffix.lower() != ".png":
        raise WarpHybridError(f"{path}: output image must be a .png file")
    atomic_write_bytes(path, encode_png(image))


def write_npy(path: str | os.PathLike, array: np.ndarray) -> None:
    """Write one array as .npy, atomically."""
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    atomic_write_bytes(path, buf.getvalue())


def write_aovs(directory: str | os.PathLike, aovs: Mapping[str, np.ndarray]) -> list[Path]:
    """Write each AOV as ``<directory>/<name>.npy`` (atomically per file); returns paths."""
    directory = Path(directory)
    written = []
    for name, array in aovs.items():
        target = directory / f"{name}.npy"
        write_npy(target, array)
        written.append(target)
    return written


def write_json(path: str | os.PathLike, payload: Mapping[str, Any]) -> None:
    """Write ``payload`` as indented JSON, atomically (non-finite floats become null)."""

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not np.isfinite(v):
            return None
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):
            return clean(v.item())
        return v

    text = json.dumps(clean(dict(payload)), indent=2, sort_keys=False) + "\n"
    atomic_write_bytes(path, text.encode("utf-8"))
