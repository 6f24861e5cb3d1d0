"""The invariance table of the README's "Hard cases" section: every scene rendered
untransformed and under a root transform of the whole stage (translated by 1e3, 1e4,
1e5; scaled by 1e-3, 1e-2, 1e2, 1e3; cameras and lights included), and the share of
pixels whose depth, light visibility and image agree (``warp_hybrid.scene.invariance``).

    .venv/bin/python scripts/hard_cases_table.py [--size 160x120] [--scenes cornell_glass hard_cases]
                                                 [--device cpu] [--json out/hard_cases.json]

Prints a markdown table (one row per scene and transform).  Full ray tracing from the
scene's first camera, raster primaries, no anti-aliasing, automatic exposure.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from warp_hybrid import open_scene_source  # noqa: E402
from warp_hybrid.renderer import Renderer, RenderSettings  # noqa: E402
from warp_hybrid.scene.authoring.transformed import write_transformed_stage  # noqa: E402
from warp_hybrid.scene.invariance import RenderView, compare, mesh_index  # noqa: E402

SCENES = ("cornell_glass", "hard_cases", "metal_env")
TRANSFORMS: tuple[tuple[str, tuple[float, float, float], float], ...] = (
    ("translate 1e3", (1.0e3, 0.0, 0.0), 1.0),
    ("translate 1e4", (0.0, 1.0e4, 1.0e4), 1.0),
    ("translate 1e5", (1.0e5, 1.0e5, -1.0e5), 1.0),
    ("scale 1e-3", (0.0, 0.0, 0.0), 1.0e-3),
    ("scale 1e-2", (0.0, 0.0, 0.0), 1.0e-2),
    ("scale 1e2", (0.0, 0.0, 0.0), 1.0e2),
    ("scale 1e3", (0.0, 0.0, 0.0), 1.0e3),
)


def render_view(path: str | Path, width: int, height: int, device: str) -> RenderView:
    """Render ``path`` from its first camera (full mode) and keep what the rule compares."""
    scene = open_scene_source(path).scene_at(None)
    settings = RenderSettings(width=width, height=height, device=device, mode="full", antialias=False)
    with Renderer(scene, settings) as renderer:
        frame = renderer.render(scene.cameras[0])
        aovs = frame.aovs()
        tri = frame.gbuffer.triangle_id.numpy().reshape(height, width)
    first = [m.first_triangle for m in scene.meshes]
    return RenderView(aovs["depth"], aovs["visibility"], frame.image, mesh_index(tri, first))


def table(scenes: list[str], width: int, height: int, device: str) -> tuple[str, list[dict]]:
    """The markdown table and its rows as dicts."""
    lines = [
        "| scene | transform | depth agree | visibility agree | image agree | all agree | off-silhouette |",
        "|---|---|---|---|---|---|---|",
    ]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in scenes:
            source = ROOT / "scenes" / f"{name}.usda"
            reference = render_view(source, width, height, device)
            for label, translate, scale in TRANSFORMS:
                out = Path(tmp) / f"{name}_{label.replace(' ', '_')}.usda"
                moved = write_transformed_stage(source, out, translate, scale)
                a = compare(reference, render_view(moved, width, height, device), scale)
                lines.append("| " + " | ".join([name, label] + a.row()) + " |")
                rows.append({"scene": name, "transform": label, **a.__dict__})
                print(lines[-1], flush=True)
    return "\n".join(lines), rows


def main() -> None:
    """Parse the arguments, build the table, print it (and write the JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="160x120", help="WxH (default 160x120)")
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), help="shipped scene names")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--json", type=Path, help="also write the rows as JSON")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    text, rows = table(args.scenes, width, height, args.device)
    print()
    print(text)
    print(f"\n{width}x{height}, full ray tracing, device {args.device}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
