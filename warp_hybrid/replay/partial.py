"""A file written over a whole session under a temporary name, renamed into place on close.

The replay's video and statistics are written frame by frame for minutes, so they
cannot be produced by one call of ``gaze.atomic.replace_atomically``: the writer fills
``PartialFile.temp`` (a unique ``.<name>.<random><suffix>`` beside the target) and
``commit`` hands the finished file to ``replace_atomically``, which gives it the
repository's permissions rule (a new file: 0o666 less the umask, 0o644 under the usual
0o022; an existing target keeps its own) and renames it over the target.  Until then
the target is untouched; ``discard`` removes the temporary file.
"""

from __future__ import annotations

import os
from pathlib import Path

from gaze.atomic import replace_atomically, temp_beside
from gaze.errors import GazeError

from ..errors import WarpHybridError


class PartialFile:
    """The temporary file behind the output ``path`` (missing folders are created).

    Raises ``WarpHybridError`` naming ``path`` when its folder cannot be created or
    written, or when ``path`` is a folder.
    """

    def __init__(self, path: str | os.PathLike[str], suffix: str) -> None:
        self.path = Path(path)
        self.suffix = suffix
        try:
            self.temp = temp_beside(self.path, suffix)
        except GazeError as exc:
            raise WarpHybridError(str(exc)) from None

    def commit(self) -> None:
        """Rename the finished temporary file over ``path`` with the ordinary permissions
        (through ``replace_atomically``); a file-system error removes it and raises
        ``WarpHybridError`` naming ``path``."""
        try:
            replace_atomically(self.path, lambda tmp: os.replace(self.temp, tmp), temp_suffix=self.suffix)
        except GazeError as exc:
            self.discard()
            raise WarpHybridError(str(exc)) from None

    def discard(self) -> None:
        """Remove the temporary file (the target is left as it was)."""
        self.temp.unlink(missing_ok=True)
