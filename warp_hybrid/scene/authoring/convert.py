"""Mesh files (OBJ, PLY, STL, glTF, GLB, OFF: ``MESH_SUFFIXES``) to USD through trimesh:
``warp-hybrid convert``, and in-memory stages for ``open_scene_source``.

The file is loaded as a trimesh scene (``force='scene'``), so a glTF keeps its node
transforms (baked into the points, as in the shared scenes) and all its meshes.  Each
mesh becomes a triangle ``UsdGeom.Mesh`` with per-vertex normals (computed by trimesh
when the file has none) and ``st`` uvs; materials become ``UsdPreviewSurface``:

* glTF PBR: baseColorFactor -> diffuseColor (and the texture's RGBA ``scale``),
  metallic/roughness factors (glTF defaults 1 when absent), emissiveFactor, alphaMode
  (BLEND -> opacity with ``opacityMode = presence``: alpha blending, MASK ->
  opacityThreshold), doubleSided;
* OBJ/MTL: Kd -> diffuseColor, Ns -> roughness = (2 / (Ns + 2)) ** 0.25, metallic 0;
* base colour textures are re-encoded as PNG files (the image trimesh decoded, so
  embedded GLB images work too) and referenced by path;
* meshes with per-vertex or per-face colours and no material get ``displayColor``.

Maps USD cannot express through UsdPreviewSurface here (normal, occlusion,
metallic-roughness and emissive textures) are dropped with a warning.  A camera framing
the bounds (``/World/Cameras/Main``), a DistantLight and a constant DomeLight are added
so the result renders as is.  Conversion writes atomically (temporary file + rename).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import trimesh
from pxr import Tf, Usd
from trimesh.visual.material import PBRMaterial, SimpleMaterial

from ...errors import SceneError
from ...output import atomic_write_bytes
from . import writer as uw

#: The mesh file types trimesh reads for us (the one list: ``open_scene_source`` uses it too).
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".gltf", ".glb", ".off")
FRAMING_HFOV_DEG = 50.0
FRAMING_RESOLUTION = (640, 480)
_DROPPED_MAPS = ("normalTexture", "occlusionTexture", "metallicRoughnessTexture", "emissiveTexture")


@dataclass
class _Textures:
    """Where texture images go and how the stage refers to them.

    ``folder`` receives the PNG files; ``relative_to`` is the folder of the USD file
    (asset paths are written relative to it), or None for absolute paths.
    """

    folder: Path
    relative_to: Path | None
    prefix: str
    pending: dict[Path, bytes] = field(default_factory=dict)

    def add(self, image: object, material_name: str) -> tuple[str, bool]:
        """Queue ``image`` (a PIL image from trimesh) as a PNG; return its asset path and
        whether it has an alpha channel."""
        has_alpha = getattr(image, "mode", "") in ("RGBA", "LA", "PA") or "transparency" in getattr(image, "info", {})
        rgba = np.asarray(image.convert("RGBA" if has_alpha else "RGB"))  # type: ignore[attr-defined]
        code = cv2.COLOR_RGBA2BGRA if has_alpha else cv2.COLOR_RGB2BGR
        ok, png = cv2.imencode(".png", cv2.cvtColor(np.ascontiguousarray(rgba), code))
        if not ok:
            raise ValueError(f"cannot encode the texture of material {material_name!r} as PNG")
        data = png.tobytes()
        digest = hashlib.sha1(data).hexdigest()[:10]
        path = self.folder / f"{self.prefix}_{material_name}_{digest}.png"
        self.pending[path] = data
        if self.relative_to is None:
            return path.resolve().as_posix(), has_alpha
        return Path(os.path.relpath(path, self.relative_to)).as_posix(), has_alpha

    def write(self) -> None:
        """Write every queued image (atomically, skipping identical existing files)."""
        for path, data in self.pending.items():
            if not (path.is_file() and path.read_bytes() == data):
                atomic_write_bytes(path, data)


def _default_texture_dir() -> Path:
    """Cache folder for textures of in-memory conversions (content-addressed names)."""
    return Path(tempfile.gettempdir()) / "warp_hybrid_textures"


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """Decode 8-bit sRGB colours to linear floats."""
    x = np.asarray(c, dtype=np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _load_trimesh_scene(src: Path) -> trimesh.Scene:
    """``trimesh.load(src, force='scene')`` with file errors turned into SceneError."""
    if src.suffix.lower() not in MESH_SUFFIXES:
        supported = ", ".join(e[1:] for e in MESH_SUFFIXES)
        raise SceneError(str(src), f"unsupported mesh format {src.suffix!r} (supported: {supported})")
    if not src.is_file():
        raise SceneError(str(src), "file not found")
    try:
        return trimesh.load(str(src), force="scene", process=False)
    except Exception as exc:  # trimesh raises many types for broken files
        raise SceneError(str(src), f"cannot read mesh file: {type(exc).__name__}: {exc}") from exc


def _material_kwargs(
    src: Path, material: object, uv: np.ndarray | None, textures: _Textures, name: str
) -> tuple[dict, bool]:
    """``define_material`` keyword arguments for a trimesh material, and doubleSided."""
    kwargs: dict = {}
    double_sided = False
    if isinstance(material, PBRMaterial):
        base = material.baseColorFactor
        factor = np.asarray(base if base is not None else [255] * 4, float) / 255.0
        image = material.baseColorTexture
        kwargs["metallic"] = float(material.metallicFactor) if material.metallicFactor is not None else 1.0
        kwargs["roughness"] = float(material.roughnessFactor) if material.roughnessFactor is not None else 1.0
        emissive = material.emissiveFactor
        if emissive is not None and np.any(np.asarray(emissive) > 0):
            kwargs["emissive"] = tuple(float(e) for e in emissive)
        alpha_mode = (material.alphaMode or "OPAQUE").upper()
        double_sided = bool(material.doubleSided)
        dropped = [m for m in _DROPPED_MAPS if getattr(material, m, None) is not None]
        if dropped:
            warnings.warn(f"{src}: material {name!r}: {', '.join(dropped)} not converted", stacklevel=3)
    elif isinstance(material, SimpleMaterial):
        factor = np.asarray(material.diffuse, float) / 255.0
        image = material.image
        kwargs["metallic"] = 0.0
        kwargs["roughness"] = float((2.0 / (float(material.glossiness or 0.0) + 2.0)) ** 0.25)
        alpha_mode = "BLEND" if factor[3] < 1.0 else "OPAQUE"
    else:
        warnings.warn(f"{src}: material {name!r} of type {type(material).__name__} replaced by grey", stacklevel=3)
        return {}, False
    kwargs["diffuse"] = tuple(float(c) for c in factor[:3])
    has_alpha = False
    if image is not None and uv is None:
        warnings.warn(f"{src}: material {name!r} has a texture but the mesh has no uvs; texture dropped", stacklevel=3)
    elif image is not None:
        kwargs["diffuse_texture"], has_alpha = textures.add(image, name)
        if np.any(factor != 1.0):
            kwargs["texture_scale"] = tuple(float(c) for c in factor)
    if alpha_mode in ("BLEND", "MASK"):
        kwargs["opacity"] = float(factor[3])
        kwargs["opacity_mode"] = "presence"  # coverage (glTF's alpha), not glass
        kwargs["opacity_from_texture"] = has_alpha
        if alpha_mode == "MASK":
            cutoff = getattr(material, "alphaCutoff", None)
            kwargs["opacity_threshold"] = float(cutoff) if cutoff is not None else 0.5
    return kwargs, double_sided


def _unique(name: str, taken: set[str]) -> str:
    """A valid USD identifier from ``name``, made unique within ``taken``."""
    base = Tf.MakeValidIdentifier(name or "mesh")
    out, k = base, 1
    while out in taken:
        out, k = f"{base}_{k}", k + 1
    taken.add(out)
    return out


def _add_framing(stage: Usd.Stage, lo: np.ndarray, hi: np.ndarray) -> None:
    """A camera at a three-quarter view that frames the bounds, a sun and a sky."""
    center = (lo + hi) / 2.0
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-6)
    w, h = FRAMING_RESOLUTION
    half_v = np.arctan(np.tan(np.radians(FRAMING_HFOV_DEG) / 2.0) * h / w)
    distance = 1.05 * radius / np.sin(half_v)
    view = np.array([0.5, 0.4, 1.0]) / np.linalg.norm([0.5, 0.4, 1.0])
    uw.define_camera(
        stage,
        "/World/Cameras/Main",
        center + distance * view,
        center,
        FRAMING_HFOV_DEG,
        FRAMING_RESOLUTION,
        clipping=(distance * 1e-3, (distance + radius) * 4.0),
    )
    uw.define_distant_light(stage, "/World/Lights/Sun", (-0.4, -1.0, -0.6), intensity=2.0, color=(1.0, 0.97, 0.92))
    uw.define_dome_light(stage, "/World/Lights/Sky", intensity=0.5, color=(0.8, 0.85, 1.0))


def _build_stage(src: Path, textures: _Textures) -> Usd.Stage:
    """Build the in-memory stage for ``src``; texture files are only queued."""
    scene = _load_trimesh_scene(src)
    stage = uw.new_stage(doc=f"Converted from {src.name} by warp-hybrid convert")
    mesh_names: set[str] = set()
    mat_names: set[str] = set()
    materials: dict[int, tuple[object, bool]] = {}
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for node in sorted(scene.graph.nodes_geometry):
        transform, geom_name = scene.graph[node]
        mesh = scene.geometry[geom_name]
        if not isinstance(mesh, trimesh.Trimesh):
            kind = type(mesh).__name__
            warnings.warn(f"{src}: node {node!r} holds a {kind}, not a triangle mesh; skipped", stacklevel=2)
            continue
        if len(mesh.faces) == 0:
            continue
        prim_path = f"/World/Geom/{_unique(str(node), mesh_names)}"
        m = np.asarray(transform, dtype=np.float64)
        verts = np.asarray(mesh.vertices, dtype=np.float64)
        if not np.isfinite(verts).all():
            raise SceneError(str(src), "non-finite vertex positions", prim=str(node))
        points = verts @ m[:3, :3].T + m[:3, 3]
        normals = np.asarray(mesh.vertex_normals, dtype=np.float64) @ np.linalg.inv(m[:3, :3])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if np.linalg.det(m[:3, :3]) < 0.0:
            faces = faces[:, [0, 2, 1]]
        visual = mesh.visual
        uv = getattr(visual, "uv", None)
        uv = np.asarray(uv, dtype=np.float64) if uv is not None and len(uv) == len(verts) else None
        material = getattr(visual, "material", None)
        colors = None
        if material is None and getattr(visual, "kind", None) == "vertex":
            colors = _srgb_to_linear(visual.vertex_colors[:, :3])
        elif material is None and getattr(visual, "kind", None) == "face":
            colors = _srgb_to_linear(visual.face_colors[:, :3])
        double_sided = False
        bound = None
        if material is not None:
            if id(material) not in materials:
                name = _unique(getattr(material, "name", None) or "Material", mat_names)
                kwargs, sided = _material_kwargs(src, material, uv, textures, name)
                materials[id(material)] = (uw.define_material(stage, f"/World/Looks/{name}", **kwargs), sided)
            bound, double_sided = materials[id(material)]
        elif colors is None:
            if -1 not in materials:
                materials[-1] = (uw.define_material(stage, "/World/Looks/Default", roughness=0.6), False)
            bound = materials[-1][0]
        usd_mesh = uw.define_mesh(
            stage, prim_path, points, faces, normals, uv, double_sided=double_sided, display_color=colors
        )
        if bound is not None:
            uw.bind_material(usd_mesh, bound)
        lo, hi = np.minimum(lo, points.min(axis=0)), np.maximum(hi, points.max(axis=0))
    if not mesh_names:
        raise SceneError(str(src), "contains no triangles")
    _add_framing(stage, lo, hi)
    return stage


def mesh_file_to_stage(path: str | os.PathLike[str], texture_dir: str | os.PathLike[str] | None = None) -> Usd.Stage:
    """Load a mesh file into an in-memory USD stage (see the module docstring).

    Base colour textures are written as PNG files into ``texture_dir`` (default: a
    cache folder ``warp_hybrid_textures`` in the system temp dir, content-addressed
    names) and referenced by absolute path.  Raises SceneError naming the file when it
    is missing, unreadable, of an unsupported type or holds no triangles.
    """
    src = Path(path)
    textures = _Textures(Path(texture_dir) if texture_dir is not None else _default_texture_dir(), None, src.stem)
    stage = _build_stage(src, textures)
    textures.write()
    return stage


def convert_mesh_file(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
    """Convert mesh file ``src`` to ``dst`` (.usda or .usdc, by extension).

    Textures go to ``textures/`` next to ``dst`` and are referenced relatively; the USD
    file is written atomically (temporary file in the same folder, then rename), so a
    failed conversion never leaves a partial ``dst``.  Errors are SceneError naming the
    file at fault.
    """
    out = uw.check_usd_path(dst)
    source = Path(src)
    textures = _Textures(out.parent / "textures", out.parent, out.stem)
    stage = _build_stage(source, textures)
    textures.write()
    uw.save_stage(stage, out)
