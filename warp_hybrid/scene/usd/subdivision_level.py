"""How often a mesh that authors a subdivision scheme is refined: a fixed number of
levels, or ``AUTO``, chosen per mesh from its size on the screen.

``AUTO`` (the default) refines each such mesh until its edges are about
``TARGET_EDGE_PX`` pixels long where it comes nearest the default camera: the control
cage's mean edge length over the pixel footprint at the distance of its nearest
instance's bounds (``cage_edge_px``; a camera inside the bounds sees it at the near
plane), halved by every level (``auto_level``: at least 1, as the issue on USD as
authored asks, at most ``MAX_AUTO_LEVELS``, and never past the face budget
``subdivision.MAX_REFINED_FACES``).  The screen is the render size the source is opened
for (``DEFAULT_SCREEN`` when none is given: the renderer's default 640x480).

The level is chosen once per mesh, at the first time the source evaluates, with the
default camera of that time (the stage's first camera, or the framing camera of its
bounds): a level that followed the camera from frame to frame would change the
topology (a BVH rebuild instead of a refit), and Hydra too picks the refinement level
once per prim (its complexity setting), not per frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..model import Camera

#: The level policy that follows the screen.
AUTO = "auto"
#: The edge length, in pixels, AUTO refines down to.
TARGET_EDGE_PX = 4.0
#: The most levels AUTO chooses (each quadruples the faces of a quad mesh).
MAX_AUTO_LEVELS = 4
#: The screen AUTO assumes when the source is opened without one (RenderSettings' default).
DEFAULT_SCREEN = (640, 480)

#: A fixed number of levels, or ``AUTO``.
Levels = int | str
#: Levels for one mesh from its control points (N, 3), face counts and face vertex indices.
LevelChooser = Callable[[np.ndarray, np.ndarray, np.ndarray], int]


def check_levels(levels: object) -> Levels:
    """``levels`` if it is a whole number >= 0 or ``AUTO``; else ``ValueError``."""
    if levels == AUTO:
        return AUTO
    if isinstance(levels, bool) or not isinstance(levels, int) or levels < 0:
        raise ValueError(f"subdivision_levels must be a whole number >= 0 or {AUTO!r}, not {levels!r}")
    return levels


def auto_level(edge_px: float) -> int:
    """The levels that bring an edge of ``edge_px`` pixels down to ``TARGET_EDGE_PX``
    (each level halves it), in [1, ``MAX_AUTO_LEVELS``]."""
    if not edge_px > TARGET_EDGE_PX:
        return 1
    if not math.isfinite(edge_px):
        return MAX_AUTO_LEVELS
    return min(MAX_AUTO_LEVELS, max(1, math.ceil(math.log2(edge_px / TARGET_EDGE_PX))))


def cage_edges(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """(E, 2) point indices of every face edge (each face's consecutive corners, closed),
    faces of fewer than 3 corners left out."""
    counts = np.asarray(counts, dtype=np.int64)
    starts = np.cumsum(counts) - counts
    keep = counts >= 3
    counts, starts = counts[keep], starts[keep]
    if not counts.size:
        return np.zeros((0, 2), dtype=np.int64)
    first = np.repeat(starts, counts)
    corner = first + (np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts))
    last = np.repeat(starts + counts - 1, counts)
    following = np.where(corner == last, first, corner + 1)
    indices = np.asarray(indices, dtype=np.int64)
    return np.stack([indices[corner], indices[following]], axis=1)


def cage_edge_px(
    points: np.ndarray, counts: np.ndarray, indices: np.ndarray, matrices: np.ndarray, camera: Camera, width: int
) -> float:
    """The control cage's mean edge length in pixels of a ``width``-pixel-wide image
    through ``camera`` (world space), at its nearest instance: ``matrices`` (K, 4, 4)
    USD row-vector local-to-world transforms; each instance is taken at the distance
    from the camera to its bounds (at least the near plane)."""
    edges = cage_edges(counts, indices)
    if not edges.size or not len(points):
        return 0.0
    local = np.asarray(points, dtype=np.float64)
    m = np.asarray(matrices, dtype=np.float64)
    world = np.einsum("nj,kji->kni", local, m[:, :3, :3]) + m[:, None, 3, :3]
    lengths = np.linalg.norm(world[:, edges[:, 0]] - world[:, edges[:, 1]], axis=-1).mean(axis=1)
    lo, hi = world.min(axis=1), world.max(axis=1)
    eye = camera.position
    distance = np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0), axis=1)
    pixel = 2.0 * np.maximum(distance, camera.near) * camera.tan_half_fov_x / width
    return float((lengths / pixel).max())


def screen_chooser(matrices: np.ndarray, camera: Camera, width: int) -> LevelChooser:
    """The ``AUTO`` level of a mesh placed by ``matrices``, seen by ``camera`` on a
    ``width``-pixel-wide screen."""

    def choose(points: np.ndarray, counts: np.ndarray, indices: np.ndarray) -> int:
        return auto_level(cage_edge_px(points, counts, indices, matrices, camera, width))

    return choose
