"""Command line: ``warp-hybrid render|info|convert|gaze`` (also ``python -m warp_hybrid``).

Every error the package raises on purpose (bad file, bad setting) is printed as one
line naming the file and the problem, with exit status 2; outputs are written
atomically, so a failed run leaves no partial file behind.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

import numpy as np

from .errors import RenderSettingsError, WarpHybridError
from .focus import SHAPES
from .post.postprocess import TONEMAPS
from .renderer import MODES, PRIMARY_PATHS, RenderSettings
from .scene.model import Scene


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``WIDTHxHEIGHT`` (e.g. ``640x480``)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"size must look like 640x480, got {text!r}") from exc
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"size must be positive, got {text!r}")
    return w, h


def parse_exposure(text: str) -> float | None:
    """``auto`` or a number of stops."""
    if text == "auto":
        return None
    try:
        return float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"exposure must be 'auto' or a number of stops, got {text!r}") from exc


def resolve_gaze(text: str, scene: Scene) -> tuple[float, float]:
    """The gaze point for a frame: ``X,Y`` as given, or a gaze source spec sampled at
    the scene's time in seconds from the start of its time range."""
    parts = text.split(",")
    if ":" not in text and len(parts) == 2:
        try:
            x, y = float(parts[0]), float(parts[1])
        except ValueError as exc:
            raise RenderSettingsError(f"--gaze must be X,Y or a gaze source spec, got {text!r}") from exc
        if not (np.isfinite(x) and np.isfinite(y)):
            raise RenderSettingsError(f"--gaze must be finite, got {text!r}")
        return x, y
    from gaze.factory import open_source

    start = scene.time_range[0] if scene.time_range else 0.0
    seconds = (scene.time - start) / scene.time_codes_per_second
    with open_source(text) as source:
        sample = source.sample(seconds)
    return float(sample.x), float(sample.y)


def _add_render_parser(sub: argparse._SubParsersAction) -> None:
    defaults = RenderSettings()  # the one source of the defaults (the help texts show them)
    p = sub.add_parser("render", help="render a scene to a PNG (and optionally AOVs and statistics)")
    p.add_argument("scene", help="USD file (.usd/.usda/.usdc/.usdz) or a mesh file trimesh reads")
    p.add_argument("-o", "--output", required=True, help="output PNG path")
    p.add_argument(
        "--size",
        type=parse_size,
        default=(defaults.width, defaults.height),
        help=f"WIDTHxHEIGHT (default {defaults.width}x{defaults.height})",
    )
    p.add_argument("--camera", default=None, help="camera prim path (default: the first camera)")
    p.add_argument("--time", type=float, default=None, help="USD time code (default: the stage's start)")
    p.add_argument("--device", default=defaults.device, help=f"Warp device: cpu or cuda:0 (default {defaults.device})")
    p.add_argument("--aov-dir", default=None, help="write depth/position/normal/albedo/color .npy files here")
    p.add_argument("--stats-json", default=None, help="write per-stage timings and counts as JSON here")
    p.add_argument("--primary", choices=PRIMARY_PATHS, default=defaults.primary, help="primary visibility path")
    p.add_argument(
        "--mode",
        choices=MODES,
        default=defaults.mode,
        help="raster: deferred shading only; full: every pixel ray traced; hybrid (default): ray traced in the focus window",
    )
    p.add_argument(
        "--gaze",
        default="0.5,0.5",
        help="where the viewer looks: X,Y normalised (origin top-left), or a gaze source spec "
        "(e.g. trace:PATH) sampled at the frame's time (default 0.5,0.5)",
    )
    p.add_argument(
        "--window",
        type=float,
        default=defaults.window_fraction,
        help=f"focus window area as a fraction of the screen (0..1, default {defaults.window_fraction:g})",
    )
    p.add_argument(
        "--window-shape",
        choices=SHAPES,
        default=defaults.window_shape,
        help=f"focus window shape (default {defaults.window_shape})",
    )
    p.add_argument(
        "--feather",
        type=float,
        default=defaults.feather_px,
        help=f"blend band inside the window edge, pixels (default {defaults.feather_px:g})",
    )
    p.add_argument(
        "--max-depth",
        type=int,
        default=defaults.max_depth,
        help=f"secondary bounces per pixel (default {defaults.max_depth})",
    )
    p.add_argument(
        "--shadow-samples",
        type=int,
        default=defaults.shadow_samples,
        help="1: hard shadows; N: N samples over area/sphere lights",
    )
    p.add_argument(
        "--exposure", type=parse_exposure, default=defaults.exposure_ev, help="'auto' (default) or stops (EV)"
    )
    p.add_argument("--tonemap", choices=TONEMAPS, default=defaults.tonemap, help="tone mapping operator")
    p.add_argument("--no-aa", dest="antialias", action="store_false", help="turn the FXAA post pass off")
    p.add_argument(
        "--threads", type=int, default=defaults.threads, help="host threads per pass (default: one per core)"
    )


def _cmd_render(args: argparse.Namespace) -> int:
    from .output import write_aovs, write_json, write_png
    from .renderer import Renderer
    from .runtime import init_warp
    from .scene.open import open_scene_source
    from .scene.usd.camera import select_camera

    init_warp()
    t0 = time.perf_counter()
    source = open_scene_source(args.scene)
    scene = source.scene_at(args.time)
    load_ms = (time.perf_counter() - t0) * 1000.0
    camera = select_camera(scene.cameras, args.camera, source=str(args.scene))
    settings = RenderSettings(
        width=args.size[0],
        height=args.size[1],
        device=args.device,
        mode=args.mode,
        primary=args.primary,
        window_fraction=args.window,
        window_shape=args.window_shape,
        feather_px=args.feather,
        max_depth=args.max_depth,
        shadow_samples=args.shadow_samples,
        exposure_ev=args.exposure,
        tonemap=args.tonemap,
        antialias=args.antialias,
        threads=args.threads,
    )
    gaze = resolve_gaze(args.gaze, scene)
    with Renderer(scene, settings) as renderer:
        renderer.warm_up(camera)
        frame = renderer.render(camera, renderer.default_window(gaze))
    frame.stats["setup_ms"] = {"load": load_ms, **frame.stats["setup_ms"]}
    write_png(args.output, frame.image)
    if args.aov_dir:
        write_aovs(args.aov_dir, frame.aovs())
    if args.stats_json:
        write_json(args.stats_json, frame.stats)
    for w in scene.warnings:
        print(f"warning: {w}", file=sys.stderr)
    stages = ", ".join(f"{k} {v:.1f}" for k, v in frame.stats["stages_ms"].items())
    print(
        f"{args.output}: {settings.width}x{settings.height}, {scene.triangle_count} triangles, frame {frame.stats['frame_ms']:.1f} ms ({stages})"
    )
    return 0


def _add_info_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="summarise a scene: counts, lights, cameras, time range, effects needed")
    p.add_argument("scene")
    p.add_argument("--time", type=float, default=None)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")


def _cmd_info(args: argparse.Namespace) -> int:
    import json

    from .scene.open import open_scene_source
    from .scene.usd.info import format_info, scene_info

    source = open_scene_source(args.scene)
    scene = source.scene_at(args.time)
    info = scene_info(scene, source)
    print(json.dumps(info, indent=2) if args.json else format_info(info))
    return 0


def _add_convert_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="convert OBJ/PLY/STL/glTF/GLB (through trimesh) to .usda or .usdc")
    p.add_argument("input")
    p.add_argument("output", help="destination .usd, .usda or .usdc")


def _cmd_convert(args: argparse.Namespace) -> int:
    from .scene.authoring.convert import convert_mesh_file

    convert_mesh_file(args.input, args.output)
    print(f"{args.output}: written")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (render, info, convert, gaze)."""
    from gaze.cli import add_gaze_parser

    parser = argparse.ArgumentParser(prog="warp-hybrid", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    _add_render_parser(sub)
    _add_info_parser(sub)
    _add_convert_parser(sub)
    add_gaze_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status."""
    from gaze.cli import run_gaze
    from gaze.errors import GazeError

    parser = build_parser()
    args = parser.parse_args(argv)
    commands = {"render": _cmd_render, "info": _cmd_info, "convert": _cmd_convert, "gaze": run_gaze}
    try:
        return commands[args.command](args)
    except (WarpHybridError, GazeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
