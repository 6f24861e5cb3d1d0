"""``warp-hybrid info``: a JSON-ready summary of a loaded scene and its text form."""

from __future__ import annotations

from ...core.features import analyse_features
from ..model import Scene
from .loader import UsdSceneSource


def scene_info(scene: Scene, source: UsdSceneSource | None = None) -> dict:
    """Counts, lights (kind + name; the dome as kind ``dome``), cameras, time range,
    units, bounds, the effects the scene needs and the loader's warnings.  Only plain
    Python types, so ``json.dumps`` takes it as is.  ``source`` adds the layers pxr
    composed."""
    lo, hi = (b + scene.origin for b in scene.bounds)  # world bounds (the points are local)
    lights = [{"kind": light.kind.name.lower(), "name": light.name} for light in scene.lights]
    if scene.environment is not None:
        lights.append({"kind": "dome", "name": scene.environment.name})
    info = {
        "path": scene.path,
        "triangles": scene.triangle_count,
        "points": int(len(scene.points)),
        "meshes": len(scene.meshes),
        "animated_meshes": sum(1 for m in scene.meshes if m.animated),
        "materials": len(scene.materials),
        "textures": len(scene.images),
        "lights": lights,
        "cameras": [c.name for c in scene.cameras],
        "time": scene.time,
        "time_range": list(scene.time_range) if scene.time_range is not None else None,
        "time_codes_per_second": scene.time_codes_per_second,
        "meters_per_unit": scene.meters_per_unit,
        "up_axis": scene.up_axis,
        "bounds": [[float(v) for v in lo], [float(v) for v in hi]],
        "effects": analyse_features(scene).names(),
        "warnings": list(scene.warnings),
    }
    if source is not None:
        info["layers"] = [layer.identifier for layer in source.stage.GetUsedLayers() if not layer.anonymous]
    return info


def format_info(info: dict) -> str:
    """The text ``warp-hybrid info`` prints for a ``scene_info`` dict."""
    lo, hi = info["bounds"]
    tr = info["time_range"]
    lines = [
        info["path"],
        f"  triangles   {info['triangles']:,} ({info['points']:,} points)",
        f"  meshes      {info['meshes']} ({info['animated_meshes']} animated)",
        f"  materials   {info['materials']}, textures {info['textures']}",
        f"  lights      {len(info['lights'])}"
        + "".join(f"\n    {li['kind']:8s} {li['name']}" for li in info["lights"]),
        f"  cameras     {len(info['cameras'])}" + "".join(f"\n    {c}" for c in info["cameras"]),
        f"  time range  {tr[0]:g} .. {tr[1]:g} at {info['time_codes_per_second']:g} codes/s"
        if tr
        else "  time range  none (static)",
        f"  units       {info['meters_per_unit']:g} m per unit, up axis {info['up_axis']}",
        "  bounds      (" + ", ".join(f"{v:.4g}" for v in lo) + ") .. (" + ", ".join(f"{v:.4g}" for v in hi) + ")",
        f"  effects     {', '.join(info['effects']) or 'none'}",
    ]
    if info.get("layers"):
        lines.append(f"  layers      {len(info['layers'])}" + "".join(f"\n    {layer}" for layer in info["layers"]))
    lines.append(f"  warnings    {len(info['warnings'])}" + "".join(f"\n    {w}" for w in info["warnings"]))
    return "\n".join(lines)
