"""Writing results: PNG images, AOV arrays and statistics, always atomically, a run's
outputs as one set.

Every file goes through ``gaze.atomic``, the one atomic writer (its rules: paths
checked before any work, missing folders created, a set renamed into place only once
every file of it is written, new files with the umask's permissions, an overwritten
file keeping its own); here its ``GazeError`` becomes a ``WarpHybridError`` naming the
file.  ``check_outputs`` is the check a command runs before loading anything;
``Outputs`` writes a run's files together (all or none).
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Self

import cv2
import numpy as np

from gaze.atomic import OutputSet, check_output
from gaze.errors import GazeError

from .errors import WarpHybridError

#: The extension of every image output (others would silently change meaning).
IMAGE_SUFFIX = ".png"
#: What ``write_aovs`` writes in its folder: ``<name>.npy`` per AOV of ``Frame.aovs``.
AOV_SUFFIX = ".npy"


@contextmanager
def _as_ours() -> Iterator[None]:
    """Turn the writer's ``GazeError`` into a ``WarpHybridError`` with the same message."""
    try:
        yield
    except GazeError as exc:
        raise WarpHybridError(str(exc)) from None


def check_image_path(path: str | os.PathLike) -> None:
    """Refuse an image output that is not a .png file."""
    if Path(path).suffix.lower() != IMAGE_SUFFIX:
        raise WarpHybridError(f"{path}: output image must be a {IMAGE_SUFFIX} file")


def check_outputs(
    files: Mapping[str, str | os.PathLike | None], folders: Mapping[str, str | os.PathLike | None] | None = None
) -> None:
    """Check a run's outputs before any work: each of ``files`` (option -> path, None
    when not given) can be written (``gaze.atomic.check_output``), each of ``folders``
    can hold files, and no two outputs are the same path.  Raises ``WarpHybridError``
    naming the path (and the option, when two collide)."""
    seen: dict[Path, str] = {}
    given = [(opt, Path(p), False) for opt, p in files.items() if p is not None]
    given += [(opt, Path(p), True) for opt, p in (folders or {}).items() if p is not None]
    for option, path, is_folder in given:
        key = path.resolve()
        if key in seen:
            raise WarpHybridError(f"{path}: given to both {seen[key]} and {option}")
        seen[key] = option
        with _as_ours():
            if is_folder:
                if path.exists() and not path.is_dir():
                    raise GazeError(str(path), f"{option} must be a folder, but it is a file")
                check_output(path / f"probe{AOV_SUFFIX}")
            else:
                check_output(path)


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 RGB image (row 0 = top)."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) uint8 image, got {image.shape} {image.dtype}")
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(image[..., ::-1]))
    if not ok:
        raise WarpHybridError("OpenCV could not encode the PNG image")
    return buf.tobytes()


def encode_npy(array: np.ndarray) -> bytes:
    """.npy bytes of one array (no pickles)."""
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


def encode_json(payload: Mapping[str, Any]) -> bytes:
    """Indented JSON bytes of ``payload`` (non-finite floats become null)."""

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

    return (json.dumps(clean(dict(payload)), indent=2, sort_keys=False) + "\n").encode("utf-8")


class Outputs:
    """A run's output files, written as one set (``gaze.atomic.OutputSet``): each
    ``add_*`` encodes and writes its file under a temporary name; leaving the ``with``
    block renames them all, an error inside it leaves none."""

    def __init__(self) -> None:
        self._set = OutputSet()

    def add_bytes(self, path: str | os.PathLike, data: bytes) -> Path:
        """Add one file holding ``data``; returns its path."""
        with _as_ours():
            self._set.add(path, lambda tmp: tmp.write_bytes(data))
        return Path(path)

    def add_png(self, path: str | os.PathLike, image: np.ndarray) -> Path:
        """Add an (H, W, 3) uint8 sRGB image as PNG (the path must end in .png)."""
        check_image_path(path)
        return self.add_bytes(path, encode_png(image))

    def add_aovs(self, directory: str | os.PathLike, aovs: Mapping[str, np.ndarray]) -> list[Path]:
        """Add each AOV as ``<directory>/<name>.npy``; returns the paths."""
        return [self.add_bytes(Path(directory) / f"{name}{AOV_SUFFIX}", encode_npy(a)) for name, a in aovs.items()]

    def add_json(self, path: str | os.PathLike, payload: Mapping[str, Any]) -> Path:
        """Add ``payload`` as indented JSON (non-finite floats become null)."""
        return self.add_bytes(path, encode_json(payload))

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        with _as_ours():
            self._set.__exit__(*exc)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (a set of one file); a file-system error
    is a ``WarpHybridError`` naming the file."""
    with Outputs() as out:
        out.add_bytes(path, data)


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an (H, W, 3) uint8 sRGB image as PNG, atomically.  The extension must be
    .png (other formats would silently change meaning)."""
    with Outputs() as out:
        out.add_png(path, image)


def write_npy(path: str | os.PathLike, array: np.ndarray) -> None:
    """Write one array as .npy, atomically."""
    atomic_write_bytes(path, encode_npy(array))


def write_aovs(directory: str | os.PathLike, aovs: Mapping[str, np.ndarray]) -> list[Path]:
    """Write each AOV as ``<directory>/<name>.npy`` (all or none); returns the paths."""
    with Outputs() as out:
        return out.add_aovs(directory, aovs)


def write_json(path: str | os.PathLike, payload: Mapping[str, Any]) -> None:
    """Write ``payload`` as indented JSON, atomically (non-finite floats become null)."""
    atomic_write_bytes(path, encode_json(payload))
