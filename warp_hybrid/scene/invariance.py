"""Whether two renders of one scene agree after a rigid motion or a uniform rescaling
of the whole stage: the rule the invariance tests and ``scripts/hard_cases_table.py``
share (pure numpy, no rendering).

A pixel *agrees* when both renders hit or both miss, and where they hit the view depth
(divided by the stage's scale) is within ``DEPTH_RTOL`` relative, every light's
visibility within ``VISIBILITY_ATOL`` and every 8-bit sRGB channel within
``IMAGE_ATOL``.  A pixel is a *silhouette* pixel when its 3 x 3 neighbourhood in the
reference sees more than one mesh (or a mesh and the background): there a sub-pixel
shift of an edge legitimately changes what the pixel centre sees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEPTH_RTOL = 1.0e-4
VISIBILITY_ATOL = 0.02
IMAGE_ATOL = 3


@dataclass(frozen=True)
class RenderView:
    """What the rule compares of one render: ``depth`` (H, W) view depth (+inf on a
    miss), ``visibility`` (H, W, L), ``image`` (H, W, 3) uint8 and ``mesh`` (H, W) the
    index of the mesh seen (-1 on a miss)."""

    depth: np.ndarray
    visibility: np.ndarray
    image: np.ndarray
    mesh: np.ndarray


@dataclass(frozen=True)
class Agreement:
    """Shares of the pixels that agree in depth, visibility, image and all three; of
    the disagreeing ones, how many lie off silhouettes (``interior``)."""

    depth: float
    visibility: float
    image: float
    all: float
    interior: int
    pixels: int

    def row(self) -> list[str]:
        """Markdown table cells: depth, visibility, image, all (percent), interior pixels."""
        return [f"{100.0 * v:.2f}%" for v in (self.depth, self.visibility, self.image, self.all)] + [str(self.interior)]


def mesh_index(triangle_id: np.ndarray, first_triangles: np.ndarray) -> np.ndarray:
    """The mesh (index into the sorted ``first_triangles`` of ``Scene.meshes``) of every
    pixel's triangle; -1 where ``triangle_id`` is -1."""
    idx = np.searchsorted(np.asarray(first_triangles), triangle_id, side="right") - 1
    return np.where(triangle_id >= 0, idx, -1)


def silhouettes(mesh: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose 3 x 3 neighbourhood sees more than one mesh value."""
    padded = np.pad(mesh, 1, mode="edge")
    h, w = mesh.shape
    out = np.zeros(mesh.shape, dtype=bool)
    for dy in range(3):
        for dx in range(3):
            out |= padded[dy : dy + h, dx : dx + w] != mesh
    return out


def compare(reference: RenderView, other: RenderView, scale: float = 1.0) -> Agreement:
    """How ``other`` (the stage scaled by ``scale``, moved anyhow) agrees with
    ``reference``, pixel by pixel (module docstring)."""
    hit_r = np.isfinite(reference.depth)
    hit_o = np.isfinite(other.depth)
    with np.errstate(invalid="ignore"):
        rel = np.abs(other.depth / scale - reference.depth) / np.where(hit_r, reference.depth, 1.0)
    depth_ok = (hit_r == hit_o) & (~hit_r | (rel <= DEPTH_RTOL))
    vr = np.nan_to_num(reference.visibility, nan=-1.0)
    vo = np.nan_to_num(other.visibility, nan=-1.0)
    vis_ok = (np.abs(vr - vo) <= VISIBILITY_ATOL).all(axis=-1) if vr.shape[-1] else np.ones(hit_r.shape, bool)
    img_ok = (np.abs(reference.image.astype(np.int32) - other.image.astype(np.int32)) <= IMAGE_ATOL).all(axis=-1)
    all_ok = depth_ok & vis_ok & img_ok
    interior = int((~all_ok & ~silhouettes(reference.mesh)).sum())
    n = all_ok.size
    return Agreement(
        depth=float(depth_ok.mean()),
        visibility=float(vis_ok.mean()),
        image=float(img_ok.mean()),
        all=float(all_ok.mean()),
        interior=interior,
        pixels=n,
    )
