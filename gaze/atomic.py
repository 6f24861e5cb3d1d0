"""Atomic file output: write a temporary file next to the target, then rename it over.

The one atomic writer of the repository: the renderer's outputs use it too, turning
``GazeError`` into their own errors (this package imports nothing of the renderer's).
Readers see the old file or the whole new one, never a part; on any failure the
temporary file is removed and the target is left as it was.  A new file gets the
permissions ``open`` would give it (0o666 less the process umask: 0o644 under the usual
0o022); an existing file keeps its own.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from gaze.errors import GazeError


def _umask() -> int:
    """The process umask.  Linux reports it in ``/proc/self/status`` (a plain read);
    elsewhere it can only be read by setting it, so it is set to a strict 0o077 for
    the instant before it is restored."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o077)
    os.umask(mask)
    return mask


def _new_file_mode() -> int:
    """Permissions of a new output file: what ``open`` gives one under the current umask
    (``mkstemp`` itself makes 0o600)."""
    return 0o666 & ~_umask()


def replace_atomically(
    path: str | os.PathLike[str],
    fill: Callable[[Path], None],
    *,
    make_parents: bool = False,
    temp_suffix: str = ".tmp",
) -> None:
    """Create a temporary file next to ``path``, let ``fill(temporary_path)`` write it,
    then rename it over ``path``.

    ``temp_suffix`` ends the temporary name (a writer that picks its format by extension,
    such as pxr's ``Export``, needs the real one).  The output folder must exist unless
    ``make_parents`` creates it.  File-system errors become ``GazeError`` naming ``path``;
    anything ``fill`` raises otherwise propagates after the temporary file is removed.
    """
    path = Path(path)
    folder = path.parent
    if make_parents:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise GazeError(str(path), f"cannot create output folder {folder}: {exc.strerror or exc}") from None
    elif not folder.is_dir():
        raise GazeError(str(path), f"output folder {folder} does not exist")
    if path.is_dir():
        raise GazeError(str(path), "output path is a folder")
    mode = stat.S_IMODE(path.stat().st_mode) if path.exists() else _new_file_mode()
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=temp_suffix, dir=folder)
    except OSError as exc:
        raise GazeError(str(path), f"cannot write in {folder}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(name)
    try:
        fill(tmp)
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise GazeError(str(path), f"cannot write: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomic(path: str | os.PathLike[str], data: bytes | str, *, make_parents: bool = False) -> None:
    """Write ``data`` (bytes, or text stored as UTF-8 with its newlines unchanged) to
    ``path`` atomically; see ``replace_atomically``."""
    payload = data.encode("utf-8") if isinstance(data, str) else data
    replace_atomically(path, lambda tmp: tmp.write_bytes(payload), make_parents=make_parents)
