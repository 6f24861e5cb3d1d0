"""Errors the renderer raises for bad input; each names the file (and prim) at fault."""

from __future__ import annotations


class WarpHybridError(Exception):
    """Base class for every error this package raises on purpose."""


class SceneError(WarpHybridError):
    """A scene file cannot be loaded or holds invalid data.

    The message always starts with the file path, then the prim path when one is at
    fault, then the problem.
    """

    def __init__(self, path: str, problem: str, prim: str | None = None) -> None:
        self.path = str(path)
        self.prim = prim
        self.problem = problem
        where = f"{self.path}: {prim}: " if prim else f"{self.path}: "
        super().__init__(where + problem)


class RenderSettingsError(WarpHybridError):
    """Settings that cannot be honoured (bad size, unknown camera, bad device...)."""


class ArgumentTypeError(RenderSettingsError, TypeError):
    """A library argument of the wrong type; the message names the argument (a
    ``TypeError`` too, so callers that catch that still do)."""
