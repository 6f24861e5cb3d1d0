"""Atomic file output: write a temporary file next to the target, then rename it over."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from gaze.errors import GazeError

#: Permissions of a new output file (an existing file keeps its own).
NEW_FILE_MODE = 0o644


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` so that readers see the old file or the whole new one, never a part.

    The output folder must exist (``GazeError`` otherwise); on any failure the
    temporary file is removed and the target is left as it was.
    """
    path = Path(path)
    folder = path.parent
    if not folder.is_dir():
        raise GazeError(str(path), f"output folder {folder} does not exist")
    if path.is_dir():
        raise GazeError(str(path), "output path is a folder")
    mode = stat.S_IMODE(path.stat().st_mode) if path.exists() else NEW_FILE_MODE
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise GazeError(str(path), f"cannot write in {folder}: {exc.strerror}") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(text)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise GazeError(str(path), f"cannot write: {exc.strerror or exc}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
