"""Atomic file output, the one writer of the repository: temporary files next to their
targets, renamed over them.

Every output of both packages goes through here (the renderer's outputs too, turning
``GazeError`` into their own errors: this package imports nothing of the renderer's).
The rules, in one place:

* **Checked before any work**: ``check_output`` refuses a path that is a folder, whose
  folder is a file, or whose nearest existing folder cannot be written (probed by
  creating and removing a temporary file there, so a read-only file system or a
  permission is found whoever runs it, root included).
* **Missing folders are created**, when the output is written (never by the check).
* **A set of outputs is written as one** (``OutputSet``): every file is written to its
  temporary name first and only then are they all renamed, so a failure leaves none of
  them (readers see the old file or the whole new one, never a part).
* **Permissions**: a new file gets what ``open`` would give it (0o666 less the process
  umask: 0o644 under the usual 0o022); an overwritten file keeps its own mode.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Self

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


def _target_mode(path: Path) -> int:
    """The mode ``path`` gets: its own when it exists, else what ``open`` gives a new
    file under the current umask (``mkstemp`` itself makes 0o600)."""
    return stat.S_IMODE(path.stat().st_mode) if path.exists() else 0o666 & ~_umask()


def _nearest_folder(folder: Path) -> Path:
    """``folder`` or its nearest existing ancestor; ``GazeError`` when that is not a folder."""
    probe = folder
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise GazeError(str(probe), "is a file, not a folder")
    return probe


def check_output(path: str | os.PathLike[str]) -> Path:
    """``path`` as a Path when an output can be written there, else a ``GazeError``
    naming it: it is a folder, a part of its folder is a file, or the nearest existing
    folder is not writable.  Nothing is left behind (the probe file is removed)."""
    path = Path(path)
    if path.is_dir():
        raise GazeError(str(path), "output path is a folder")
    if path.exists() and not path.is_file():
        raise GazeError(str(path), "output path exists and is not a regular file")
    try:
        existing = _nearest_folder(path.parent)
    except GazeError as exc:
        raise GazeError(str(path), f"cannot create output folder: {exc}") from None
    try:
        fd, name = tempfile.mkstemp(prefix=".write-check.", dir=existing)
    except OSError as exc:
        raise GazeError(str(path), f"cannot write in {existing}: {exc.strerror or exc}") from None
    os.close(fd)
    os.unlink(name)
    return path


def temp_beside(path: str | os.PathLike[str], suffix: str = ".tmp") -> Path:
    """A new empty temporary file ``.<name>.<random><suffix>`` in ``path``'s folder,
    creating missing folders; ``GazeError`` naming ``path`` when that fails."""
    path = Path(path)
    if path.is_dir():
        raise GazeError(str(path), "output path is a folder")
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GazeError(str(path), f"cannot create output folder {folder}: {exc.strerror or exc}") from None
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=folder)
    except OSError as exc:
        raise GazeError(str(path), f"cannot write in {folder}: {exc.strerror or exc}") from None
    os.close(fd)
    return Path(name)


class OutputSet:
    """Files written as one: ``add`` writes each to its temporary name, leaving the
    closing ``with`` (or ``commit``) to rename them all; an error before then removes
    every temporary file, so a failed run leaves none of its outputs.

    File-system errors become ``GazeError`` naming the target; anything a ``fill``
    raises otherwise propagates (after the clean-up).
    """

    def __init__(self) -> None:
        self._staged: list[tuple[Path, Path]] = []

    def add(self, path: str | os.PathLike[str], fill: Callable[[Path], None], temp_suffix: str = ".tmp") -> None:
        """Write ``path``'s content with ``fill(temporary_path)`` now; rename it later.
        ``temp_suffix`` ends the temporary name (a writer that picks its format by
        extension, such as pxr's ``Export``, needs the real one)."""
        path = Path(path)
        tmp = temp_beside(path, temp_suffix)
        self._staged.append((tmp, path))
        try:
            fill(tmp)
        except OSError as exc:
            self.discard()
            raise GazeError(str(path), f"cannot write: {exc.strerror or exc}") from None
        except BaseException:
            self.discard()
            raise

    def commit(self) -> None:
        """Give each file its mode and rename it over its target (``GazeError`` naming
        the target when that fails; the files not yet renamed are removed)."""
        staged, self._staged = self._staged, []
        for k, (tmp, path) in enumerate(staged):
            try:
                os.chmod(tmp, _target_mode(path))
                os.replace(tmp, path)
            except OSError as exc:
                for left, _ in staged[k:]:
                    left.unlink(missing_ok=True)
                raise GazeError(str(path), f"cannot write: {exc.strerror or exc}") from None

    def discard(self) -> None:
        """Remove every temporary file (the targets are left as they were)."""
        staged, self._staged = self._staged, []
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        if kind is None:
            self.commit()
        else:
            self.discard()


def replace_atomically(
    path: str | os.PathLike[str], fill: Callable[[Path], None], *, temp_suffix: str = ".tmp"
) -> None:
    """Write one file atomically: ``fill(temporary_path)`` writes it, then it is renamed
    over ``path`` (an ``OutputSet`` of one; see the module rules)."""
    with OutputSet() as outputs:
        outputs.add(path, fill, temp_suffix)


def write_atomic(path: str | os.PathLike[str], data: bytes | str) -> None:
    """Write ``data`` (bytes, or text stored as UTF-8 with its newlines unchanged) to
    ``path`` atomically; see ``replace_atomically``."""
    payload = data.encode("utf-8") if isinstance(data, str) else data
    replace_atomically(path, lambda tmp: tmp.write_bytes(payload))
