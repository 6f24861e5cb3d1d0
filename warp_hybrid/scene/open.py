"""Open any supported scene file as a ``UsdSceneSource``.

USD files (``usd.stage.USD_SUFFIXES``) open directly; mesh files trimesh reads
(``authoring.convert.MESH_SUFFIXES``) are converted into an in-memory USD stage by
``authoring.convert.mesh_file_to_stage`` and then go through the same USD loader.
trimesh is imported only when a file is not USD.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import SceneError
from .usd.loader import UsdSceneSource
from .usd.stage import USD_SUFFIXES
from .usd.subdivision_level import AUTO, DEFAULT_SCREEN, Levels


def open_scene_source(
    path: str | os.PathLike,
    strict: bool = False,
    subdivision_levels: Levels = AUTO,
    screen: tuple[int, int] = DEFAULT_SCREEN,
) -> UsdSceneSource:
    """A scene source for ``path``, chosen by its extension (case-insensitive);
    ``strict``, ``subdivision_levels`` and ``screen`` (the render size) as for
    ``UsdSceneSource``.

    Raises ``SceneError`` naming the file when it is missing, of an unsupported type,
    or cannot be loaded.
    """
    p = os.fspath(path)
    suffix = Path(p).suffix.lower()
    if suffix in USD_SUFFIXES:
        return UsdSceneSource(p, strict=strict, subdivision_levels=subdivision_levels, screen=screen)
    try:
        from .authoring.convert import MESH_SUFFIXES, mesh_file_to_stage
    except ImportError as exc:
        raise SceneError(
            p, f"mesh files need warp_hybrid.scene.authoring.convert, which is unavailable ({exc})"
        ) from exc
    if suffix in MESH_SUFFIXES:
        if not os.path.isfile(p):
            raise SceneError(p, "file not found")
        stage = mesh_file_to_stage(p)
        return UsdSceneSource(p, stage=stage, strict=strict, subdivision_levels=subdivision_levels, screen=screen)
    supported = ", ".join(USD_SUFFIXES + MESH_SUFFIXES)
    raise SceneError(p, f"unsupported file type {suffix or '(no extension)'!r}; supported: {supported}")
