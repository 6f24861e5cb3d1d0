"""Command line: ``warp-hybrid render|replay|bench|info|convert|gaze|view`` (also ``python -m warp_hybrid``).

Every error the package raises on purpose (bad file, bad setting) and every bad
argument is printed as one line naming the file and the problem, with exit status 2;
what a command can check (output paths, settings, the gaze spec) is checked before the
scene is loaded; a run's outputs are written as one set through the one atomic writer
(``gaze.atomic``), so a failed run leaves no file behind; warnings are one ``warning:``
line each, once; Ctrl-C is one line and exit status 130.
"""

from __future__ import annotations

import argparse
import logging
import math
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, NoReturn

from gaze.fixed import point_problem

from .errors import RenderSettingsError, WarpHybridError
from .focus import SHAPES
from .post.postprocess import TONEMAPS
from .renderer import MODES, PRIMARY_PATHS, RenderSettings
from .replay.loop import LoopSettings

if TYPE_CHECKING:
    from .scene.usd.loader import UsdSceneSource


def parse_size(text: str) -> tuple[int, int]:
    """Parse ``WIDTHxHEIGHT`` (e.g. ``640x480``)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"size must look like 640x480, got {text!r}") from exc
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"size must be positive, got {text!r}")
    return w, h


def finite_float(text: str) -> float:
    """argparse type: a finite number (``nan``, ``inf`` and overflowing text refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def parse_exposure(text: str) -> float | None:
    """``auto`` or a number of stops (its range is ``RenderSettings.validate``'s rule)."""
    if text == "auto":
        return None
    try:
        return float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"exposure must be 'auto' or a number of stops, got {text!r}") from exc


def gaze_point(text: str) -> tuple[float, float] | None:
    """``X,Y`` as two finite numbers, or None when ``text`` is not of that form (a spec)."""
    parts = text.split(",")
    if ":" in text or len(parts) != 2:
        return None
    try:
        x, y = float(parts[0]), float(parts[1])
    except ValueError as exc:
        raise RenderSettingsError(f"--gaze must be X,Y or a gaze source spec, got {text!r}") from exc
    problem = point_problem(x, y)
    if problem is not None:
        raise RenderSettingsError(f"--gaze {text}: {problem}")
    return x, y


@contextmanager
def frame_gaze(text: str) -> Iterator[Callable[[float], tuple[float, float]]]:
    """The gaze point of a frame as a function of its time (``seconds`` from the start
    of the stage's time range): ``X,Y`` as given, or a gaze source spec opened now, so a
    bad one is refused before any work, and sampled at that time."""
    point = gaze_point(text)
    if point is not None:
        yield lambda seconds: point
        return
    from gaze.factory import open_source

    with open_source(text) as source:

        def sample(seconds: float) -> tuple[float, float]:
            s = source.sample(seconds)
            return float(s.x), float(s.y)

        yield sample


def _add_scene_arguments(p: argparse.ArgumentParser) -> None:
    """The scene file and how to read it (``_open_scene``)."""
    p.add_argument("scene", help="USD file (.usd/.usda/.usdc/.usdz) or a mesh file trimesh reads")
    p.add_argument(
        "--strict",
        action="store_true",
        help="refuse a stage with a malformed mesh (default: skip that mesh with a warning and draw the rest)",
    )
    p.add_argument(
        "--subdivision-levels",
        default="auto",
        metavar="N|auto",
        help="refinements of meshes that author a subdivision scheme (default auto: per mesh, down to edges of "
        "about 4 pixels at the render size, 1 to 4 levels; 0: their control cage)",
    )


def _open_scene(args: argparse.Namespace) -> UsdSceneSource:
    """The scene source ``_add_scene_arguments`` describes."""
    from .scene.open import open_scene_source
    from .scene.usd.subdivision_level import AUTO, DEFAULT_SCREEN

    levels = args.subdivision_levels
    if levels != AUTO:
        try:
            levels = int(levels)
        except ValueError:
            levels = -1
        if levels < 0:
            raise RenderSettingsError(
                f"--subdivision-levels must be 0 or more, or {AUTO}, got {args.subdivision_levels}"
            )
    screen = tuple(args.size) if getattr(args, "size", None) else DEFAULT_SCREEN
    return open_scene_source(args.scene, strict=args.strict, subdivision_levels=levels, screen=screen)


def _add_frame_arguments(p: argparse.ArgumentParser, window_help: str, window_default: float | None) -> None:
    """The options every rendering command shares (size, camera, device, modes, window,
    tracing, post), their defaults from ``RenderSettings``."""
    defaults = RenderSettings()  # the one source of the defaults (the help texts show them)
    p.add_argument(
        "--size",
        type=parse_size,
        default=(defaults.width, defaults.height),
        help=f"WIDTHxHEIGHT (default {defaults.width}x{defaults.height})",
    )
    p.add_argument("--camera", default=None, help="camera prim path (default: the first camera)")
    p.add_argument("--device", default=defaults.device, help=f"Warp device: cpu or cuda:0 (default {defaults.device})")
    p.add_argument("--primary", choices=PRIMARY_PATHS, default=defaults.primary, help="primary visibility path")
    p.add_argument(
        "--mode",
        choices=MODES,
        default=defaults.mode,
        help="raster: deferred shading only; full: every pixel ray traced; hybrid (default): ray traced in the focus window",
    )
    p.add_argument("--window", type=finite_float, default=window_default, help=window_help)
    p.add_argument(
        "--window-shape",
        choices=SHAPES,
        default=defaults.window_shape,
        help=f"focus window shape (default {defaults.window_shape})",
    )
    p.add_argument(
        "--feather",
        type=finite_float,
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
        "--shadow-maps",
        action="store_true",
        default=defaults.shadow_maps,
        help="shadow the raster layer (outside the traced window) with shadow maps (default off: unshadowed)",
    )
    p.add_argument(
        "--shadow-map-size",
        type=int,
        default=defaults.shadow_map_size,
        metavar="N",
        help=f"shadow map texels per face side (default {defaults.shadow_map_size})",
    )
    p.add_argument(
        "--indirect",
        action="store_true",
        default=defaults.indirect,
        help="add the lights' interreflected light (one estimate from their power) to both layers (default off)",
    )
    _add_ring_arguments(p)
    p.add_argument(
        "--probes",
        action="store_true",
        default=defaults.probes,
        help="the raster layer's mirrors and metals reflect a probe of the scene captured by the rasterizer "
        "(default off: the dome only, black without one)",
    )
    p.add_argument(
        "--reuse",
        action="store_true",
        default=defaults.reuse,
        help="--mode hybrid: where the window no longer traces, show the last frames' traced values reprojected "
        "through the G-buffer, fading over a few frames (default off)",
    )
    p.add_argument(
        "--exposure", type=parse_exposure, default=defaults.exposure_ev, help="'auto' (default) or stops (EV)"
    )
    p.add_argument("--tonemap", choices=TONEMAPS, default=defaults.tonemap, help="tone mapping operator")
    p.add_argument("--no-aa", dest="antialias", action="store_false", help="turn the FXAA post pass off")
    p.add_argument(
        "--threads",
        type=int,
        default=defaults.threads,
        help="host threads per pass (default: one per CPU this process may run on, at most 8)",
    )
    p.add_argument(
        "--spp",
        type=int,
        default=defaults.spp,
        help="samples per pixel (--mode full, render only): N > 1 averages N stratified jittered samples in each "
        "pixel (box filter), a converged reference at 16; 1 (default) samples the pixel centres",
    )
    _add_fovea_spp_argument(p)


def _add_ring_arguments(p: argparse.ArgumentParser) -> None:
    """``--ring`` and its sizing: the mid-resolution ring around the focus window."""
    defaults = RenderSettings()
    p.add_argument(
        "--ring",
        action="store_true",
        default=defaults.ring,
        help="--mode hybrid: trace a ring around the window at every --ring-step-th pixel, upsampled with the "
        "G-buffer as the guide (default off)",
    )
    p.add_argument(
        "--ring-scale",
        type=finite_float,
        default=defaults.ring_scale,
        metavar="S",
        help=f"the ring's outer edge, in window radii (default {defaults.ring_scale:g})",
    )
    p.add_argument(
        "--ring-step",
        type=int,
        default=defaults.ring_step,
        metavar="N",
        help=f"the ring traces every N-th pixel in x and y (default {defaults.ring_step})",
    )


def _add_fovea_spp_argument(p: argparse.ArgumentParser) -> None:
    """``--fovea-spp``: samples per pixel inside the focus window."""
    p.add_argument(
        "--fovea-spp",
        type=int,
        default=RenderSettings().fovea_spp,
        help="samples per pixel inside the focus window (--mode hybrid, fixed window): the same stratified jitter as "
        "--spp, so the time saved outside the window buys a better fovea (default 1)",
    )


def _add_budget_arguments(p: argparse.ArgumentParser, fps_default: float | None) -> None:
    """The frame-time budget options (``replay.loop.LoopSettings``)."""
    defaults = LoopSettings()
    p.add_argument(
        "--fps",
        type=finite_float,
        default=fps_default,
        help="target frame rate: the budget the focus window adapts to"
        + (f" (default {fps_default:g})" if fps_default is not None else " (default: no budget)"),
    )
    p.add_argument("--budget-ms", type=finite_float, default=None, help="frame-time budget in ms (default 1000 / fps)")
    p.add_argument(
        "--min-window",
        type=finite_float,
        default=defaults.min_window,
        help=f"smallest adaptive window, share of the screen (default {defaults.min_window:g})",
    )
    p.add_argument(
        "--max-window",
        type=finite_float,
        default=defaults.max_window,
        help=f"largest adaptive window, share of the screen (default {defaults.max_window:g})",
    )


def _render_settings(
    args: argparse.Namespace, cache_raster: bool = False, cache_shadows: bool = True
) -> RenderSettings:
    """``RenderSettings`` from the shared frame options (``cache_raster``: keep a still
    view's raster layer across frames, the loop commands' ``--no-raster-cache``;
    ``cache_shadows``: and its primary hits' shadows, their ``--no-shadow-cache``)."""
    defaults = RenderSettings()
    return RenderSettings(
        width=args.size[0],
        height=args.size[1],
        device=args.device,
        mode=args.mode,
        primary=args.primary,
        window_fraction=args.window if args.window is not None else defaults.window_fraction,
        window_shape=args.window_shape,
        feather_px=args.feather,
        max_depth=args.max_depth,
        shadow_samples=args.shadow_samples,
        shadow_maps=args.shadow_maps,
        shadow_map_size=args.shadow_map_size,
        indirect=args.indirect,
        probes=args.probes,
        reuse=args.reuse,
        ring=args.ring,
        ring_scale=args.ring_scale,
        ring_step=args.ring_step,
        exposure_ev=args.exposure,
        tonemap=args.tonemap,
        antialias=args.antialias,
        threads=args.threads,
        spp=args.spp,
        fovea_spp=args.fovea_spp,
        cache_raster=cache_raster,
        cache_shadows=cache_shadows,
    )


def _one_sample(args: argparse.Namespace, what: str) -> None:
    """The adaptive loop renders one sample per pixel: refuse ``--spp`` or
    ``--fovea-spp`` > 1 for ``what``."""
    for flag, value in (("--spp", args.spp), ("--fovea-spp", args.fovea_spp)):
        if value != 1:
            raise RenderSettingsError(f"{flag} {value}: {what} renders one sample per pixel ({flag} 1)")


def _loop_settings(args: argparse.Namespace, start: float, adaptive: bool, saccade: bool = False) -> LoopSettings:
    """``LoopSettings`` from the budget options (``saccade``: ``--saccade``, where the command has it)."""
    return LoopSettings(
        fps=args.fps if args.fps is not None else LoopSettings().fps,
        budget_ms=args.budget_ms,
        adaptive=adaptive,
        min_window=args.min_window,
        max_window=args.max_window,
        start=start,
        saccade=saccade,
    )


def _add_loop_arguments(p: argparse.ArgumentParser) -> None:
    """What only the frame loops (replay, view) take: ``--saccade`` (``LoopSettings.saccade``),
    ``--no-raster-cache`` (``RenderSettings.cache_raster``) and ``--no-shadow-cache``
    (``RenderSettings.cache_shadows``)."""
    p.add_argument(
        "--no-raster-cache",
        dest="raster_cache",
        action="store_false",
        help="draw the raster layer every frame even when the camera and the scene stand still (default: keep it "
        "and redraw only the traced window; the images are the same)",
    )
    p.add_argument(
        "--no-shadow-cache",
        dest="shadow_cache",
        action="store_false",
        help="trace every window pixel's primary shadow rays every frame (default: in a still view, a pixel an "
        "earlier window covered keeps the shadows it traced; the images are the same)",
    )
    p.add_argument(
        "--saccade",
        action="store_true",
        help="while the gaze source labels a saccade (vision suppressed), place the window at the landing point "
        "predicted from the saccade's direction and peak speed (main sequence) instead of at the gaze (default off)",
    )


def _add_render_parser(sub: argparse._SubParsersAction) -> None:
    defaults = RenderSettings()
    p = sub.add_parser("render", help="render a scene to a PNG (and optionally AOVs and statistics)")
    _add_scene_arguments(p)
    p.add_argument("-o", "--output", required=True, help="output PNG path")
    _add_frame_arguments(
        p,
        f"focus window area as a fraction of the screen (0..1, default {defaults.window_fraction:g})",
        defaults.window_fraction,
    )
    p.add_argument("--time", type=finite_float, default=None, help="USD time code (default: the stage's start)")
    p.add_argument("--aov-dir", default=None, help="write depth/position/normal/albedo/color .npy files here")
    p.add_argument("--stats-json", default=None, help="write per-stage timings and counts as JSON here")
    p.add_argument(
        "--gaze",
        default="0.5,0.5",
        help="where the viewer looks: X,Y normalised (origin top-left), or a gaze source spec "
        "(e.g. trace:PATH) sampled at the frame's time (default 0.5,0.5)",
    )
    _add_budget_arguments(p, None)
    p.add_argument(
        "--warm-up",
        type=int,
        default=5,
        help="with --fps/--budget-ms: frames the budget controller learns from before the one written (default 5)",
    )


def _cmd_render(args: argparse.Namespace) -> int:
    from .output import Outputs, check_image_path, check_outputs
    from .renderer import Renderer
    from .runtime import init_warp
    from .scene.usd.camera import select_camera

    check_image_path(args.output)  # everything a run can check, before any work
    check_outputs({"-o": args.output, "--stats-json": args.stats_json}, {"--aov-dir": args.aov_dir})
    settings = _render_settings(args)
    settings.validate()
    with frame_gaze(args.gaze) as gaze_at:
        init_warp()
        t0 = time.perf_counter()
        source = _open_scene(args)
        scene = source.scene_at(args.time)
        load_ms = (time.perf_counter() - t0) * 1000.0
        camera = select_camera(scene.cameras, args.camera, source=str(args.scene))
        gaze = gaze_at(source.info.seconds(scene.time))
    if args.fps is not None or args.budget_ms is not None:
        frame = _render_on_budget(args, source, settings, gaze)
    else:
        with Renderer(scene, settings) as renderer:
            renderer.warm_up(camera)
            frame = renderer.render(camera, renderer.default_window(gaze))
    frame.stats["setup_ms"] = {"load": load_ms, **frame.stats["setup_ms"]}
    with Outputs() as outputs:  # the run's files as one set: all or none
        outputs.add_png(args.output, frame.image)
        if args.aov_dir:
            outputs.add_aovs(args.aov_dir, frame.aovs())
        if args.stats_json:
            outputs.add_json(args.stats_json, frame.stats)
    stages = ", ".join(f"{k} {v:.1f}" for k, v in frame.stats["stages_ms"].items())
    print(
        f"{args.output}: {settings.width}x{settings.height}, {scene.triangle_count} triangles, frame {frame.stats['frame_ms']:.1f} ms ({stages})"
    )
    return 0


def _render_on_budget(args: argparse.Namespace, source: object, settings: RenderSettings, gaze: tuple[float, float]):
    """``render --fps``: the adaptive loop learns on ``--warm-up`` frames of the still
    scene, then renders the frame written; its stats get a ``budget`` entry."""
    from gaze.source import GazeSample

    from .replay.loop import AdaptiveLoop

    if args.warm_up < 0:
        raise RenderSettingsError(f"--warm-up must be >= 0, got {args.warm_up}")
    _one_sample(args, "render --fps/--budget-ms (the adaptive loop)")
    t = source.info.seconds(args.time if args.time is not None else source.info.default_time)
    sample = GazeSample(gaze[0], gaze[1], t)
    loop_settings = _loop_settings(args, t, adaptive=args.mode == "hybrid")
    with AdaptiveLoop(source, settings, loop_settings, camera_path=args.camera) as loop:
        loop.renderer.warm_up(loop.camera)
        for _ in range(args.warm_up):
            loop.step(t, sample)
        last = loop.step(t, sample)
    frame = last.frame
    plan = last.plan
    frame.stats["frame_ms"] = last.frame_ms
    frame.stats["budget"] = {
        "budget_ms": last.budget_ms,
        "frame_ms": last.frame_ms,
        "within_budget": last.within_budget,
        "window_fraction": last.window_fraction,
        "traced_fraction": last.traced_fraction,
        "warm_up_frames": args.warm_up,
        "predicted_frame_ms": plan.predicted_frame_ms if plan else None,
        "infeasible": plan.infeasible if plan else None,
        "reason": plan.reason if plan else None,
    }
    return frame


def _add_replay_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "replay",
        help="replay a gaze trace over a scene at a fixed frame rate, the window adapting to the budget, to video",
    )
    _add_scene_arguments(p)
    p.add_argument("--gaze", required=True, help="gaze source spec (trace:PATH, fixed:X,Y, webcam:..., cursor)")
    _add_budget_arguments(p, LoopSettings().fps)
    _add_loop_arguments(p)
    length = p.add_mutually_exclusive_group()
    length.add_argument("--frames", type=int, default=None, help="frames to render")
    length.add_argument(
        "--duration",
        type=finite_float,
        default=None,
        help="seconds to render (default: the stage's time range, else the gaze trace's length, else 5)",
    )
    p.add_argument("--start", type=finite_float, default=0.0, help="first frame's time, seconds from the stage's start")
    _add_frame_arguments(
        p,
        "a fixed focus window (share of the screen) instead of the budget controller's (default: adaptive)",
        None,
    )
    p.add_argument("--out", default=None, help="H.264 MP4 video of the frames")
    p.add_argument("--stats", default=None, help="per-frame stats CSV")
    p.add_argument("--summary-json", default=None, help="the summary as JSON")
    p.add_argument("--overlay", action="store_true", help="draw the focus window and the gaze point on the video")
    p.add_argument("--frames-dir", default=None, help="also write each frame as a PNG here")
    p.add_argument("--warm-up", type=int, default=3, help="untimed frames before the replay (default 3)")
    p.add_argument(
        "--error-csv",
        default=None,
        help="per-frame error against full ray-traced references of the same frames (FLIP, foveated FLIP, FLIP "
        "inside/outside the window, PSNR), measured after the timed frames",
    )
    p.add_argument("--error-spp", type=int, default=16, help="samples per pixel of those references (default 16)")


def _replay_frames(args: argparse.Namespace, source: object, gaze_source: object) -> int:
    """How many frames ``replay`` renders (``--frames``, ``--duration`` or the default)."""
    if args.frames is not None:
        if args.frames < 1:
            raise RenderSettingsError(f"--frames must be >= 1, got {args.frames}")
        return args.frames
    duration = args.duration
    if duration is None:
        info = source.info  # type: ignore[attr-defined]
        if info.time_range and info.time_range[1] > info.time_range[0]:
            duration = (info.time_range[1] - info.time_range[0]) / info.time_codes_per_second - args.start
        else:
            duration = getattr(gaze_source, "duration", None) or 5.0
    fps = args.fps if args.fps is not None else LoopSettings().fps
    if not (duration > 0.0 and math.isfinite(duration)):
        raise RenderSettingsError(f"--duration must be positive, got {duration}")
    return max(1, int(round(duration * fps)))


def _cmd_replay(args: argparse.Namespace) -> int:
    from pathlib import Path

    from gaze.factory import open_source

    from .replay.loop import AdaptiveLoop
    from .replay.run import ReplayOutputs, replay
    from .replay.summary import format_summary
    from .runtime import init_warp

    if not (args.out or args.stats or args.summary_json or args.frames_dir or args.error_csv):
        raise RenderSettingsError(
            "replay writes nothing: give --out, --stats, --summary-json, --frames-dir or --error-csv"
        )
    if args.error_csv:
        RenderSettings(mode="full", spp=args.error_spp).validate()
    if args.warm_up < 0:
        raise RenderSettingsError(f"--warm-up must be >= 0, got {args.warm_up}")
    _one_sample(args, "replay")
    from .output import check_outputs

    check_outputs(
        {"--out": args.out, "--stats": args.stats, "--summary-json": args.summary_json, "--error-csv": args.error_csv},
        {"--frames-dir": args.frames_dir},
    )
    settings = _render_settings(args, cache_raster=args.raster_cache, cache_shadows=args.shadow_cache)
    settings.validate()
    init_warp()
    source = _open_scene(args)
    loop_settings = _loop_settings(args, args.start, adaptive=args.window is None, saccade=args.saccade)
    outputs = ReplayOutputs(
        video=Path(args.out) if args.out else None,
        stats=Path(args.stats) if args.stats else None,
        summary_json=Path(args.summary_json) if args.summary_json else None,
        frames_dir=Path(args.frames_dir) if args.frames_dir else None,
        overlay=args.overlay,
        errors=Path(args.error_csv) if args.error_csv else None,
        error_spp=args.error_spp,
    )
    with open_source(args.gaze) as gaze_source:
        frames = _replay_frames(args, source, gaze_source)
        with AdaptiveLoop(source, settings, loop_settings, camera_path=args.camera) as loop:
            result = replay(loop, gaze_source, frames, outputs, warm_up=args.warm_up)
    if result.gaze_failure:
        print(
            f"warning: the gaze source failed mid-replay ({result.gaze_failure}); held its last point", file=sys.stderr
        )
    print(format_summary(result.summary))
    if result.interrupted:
        print(f"interrupted after {result.frames} frames; outputs hold the frames done", file=sys.stderr)
        return 130
    return 0


def _float_list(text: str) -> list[float]:
    """Comma-separated numbers (``0.02,0.1,0.5``)."""
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc


def _add_bench_parser(sub: argparse._SubParsersAction) -> None:
    from .sweep.configs import DEFAULT_FRACTIONS, DEFAULT_LOWRES_SCALES

    defaults = RenderSettings()
    p = sub.add_parser("bench", help="speed against error: every method's time and error against a converged reference")
    p.add_argument("scenes", nargs="+", metavar="SCENE", help="USD or mesh files")
    p.add_argument("--gaze", default="0.5,0.5", help="where the viewer looks: X,Y normalised (default 0.5,0.5)")
    p.add_argument("--out", required=True, help="folder for results.csv, results.md and one plot per scene")
    p.add_argument(
        "--size",
        type=parse_size,
        default=(defaults.width, defaults.height),
        help=f"WIDTHxHEIGHT (default {defaults.width}x{defaults.height})",
    )
    p.add_argument("--repeats", type=int, default=3, help="timed renders per configuration (median; default 3)")
    p.add_argument(
        "--fractions",
        type=_float_list,
        default=list(DEFAULT_FRACTIONS),
        help="hybrid window fractions (default " + ",".join(f"{f:g}" for f in DEFAULT_FRACTIONS) + ")",
    )
    p.add_argument(
        "--lowres",
        type=_float_list,
        default=list(DEFAULT_LOWRES_SCALES),
        help="linear scales of the upscaled low-res full ray tracing (default "
        + ",".join(f"{s:g}" for s in DEFAULT_LOWRES_SCALES)
        + ")",
    )
    p.add_argument("--reference-spp", type=int, default=16, help="samples per pixel of the reference (default 16)")
    p.add_argument(
        "--exposure",
        type=parse_exposure,
        default=None,
        help="one exposure for the reference and every configuration: stops (EV), or 'auto' (default: metered "
        "once on the reference)",
    )
    _add_fovea_spp_argument(p)
    p.add_argument(
        "--noise-spp",
        type=int,
        default=None,
        help="also measure the reference's own noise against this many samples (e.g. 32)",
    )
    p.add_argument(
        "--fovea-fraction",
        type=finite_float,
        default=0.1,
        help="the window at the gaze whose FLIP is reported as inside (default 0.1)",
    )
    p.add_argument("--camera", default=None, help="camera prim path (default: the first camera)")
    p.add_argument("--device", default=defaults.device, help=f"Warp device (default {defaults.device})")
    p.add_argument("--threads", type=int, default=defaults.threads, help="host threads per pass")
    p.add_argument("--shadow-samples", type=int, default=defaults.shadow_samples, help="shadow samples per light")
    p.add_argument("--max-depth", type=int, default=defaults.max_depth, help="secondary bounces per pixel")
    p.add_argument(
        "--shadow-maps", action="store_true", help="shadow the raster layer with shadow maps in every configuration"
    )
    p.add_argument(
        "--indirect", action="store_true", help="the lights' indirect estimate in every configuration and the reference"
    )
    _add_ring_arguments(p)
    p.add_argument("--probes", action="store_true", help="the raster layer's reflection probe in every configuration")


def _cmd_bench(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .replay.progress import Progress
    from .runtime import init_warp
    from .scene.open import open_scene_source
    from .scene.usd.camera import select_camera
    from .sweep.configs import sweep_configs
    from .sweep.measure import SceneSweep
    from .sweep.report import write_results

    if args.repeats < 1:
        raise RenderSettingsError(f"--repeats must be >= 1, got {args.repeats}")
    configs = sweep_configs(args.fractions, args.lowres, args.fovea_spp)
    gaze = gaze_point(args.gaze)
    if gaze is None:
        raise RenderSettingsError(f"bench --gaze must be X,Y (normalised, origin top-left), got {args.gaze!r}")
    base = RenderSettings(
        width=args.size[0],
        height=args.size[1],
        device=args.device,
        threads=args.threads,
        shadow_samples=args.shadow_samples,
        max_depth=args.max_depth,
        exposure_ev=args.exposure,
        shadow_maps=args.shadow_maps,
        indirect=args.indirect,
        probes=args.probes,
        ring=args.ring,
        ring_scale=args.ring_scale,
        ring_step=args.ring_step,
    )
    base.validate()
    from .output import check_outputs

    check_outputs({}, {"--out": args.out})
    init_warp()
    results, notes = {}, {}
    with Progress(len(configs) * len(args.scenes), unit="config", budgeted=False) as bar:
        for path in args.scenes:
            scene = open_scene_source(path, screen=tuple(args.size)).scene_at(None)
            camera = select_camera(scene.cameras, args.camera, source=str(path))
            sweep = SceneSweep(
                scene, camera, base, gaze, args.repeats, args.reference_spp, fovea_fraction=args.fovea_fraction
            )
            name = Path(path).stem
            results[name] = []
            for config in configs:
                results[name].append(sweep.measure(config))
                bar.update()
            note = f"reference: full, {args.reference_spp} spp, exposure {sweep.exposure_ev:+.2f} EV for every row"
            if args.ring:
                note += "; hybrid rows with the mid-resolution ring "
                note += f"(--ring-scale {args.ring_scale:g}, --ring-step {args.ring_step})"
            if args.noise_spp:
                noise = sweep.reference_noise(args.noise_spp)
                note += f"; its own noise against {args.noise_spp} spp: FLIP {noise.flip_mean:.4f}"
            notes[name] = note
    for written in write_results(args.out, results, notes):
        print(written)
    return 0


def _add_info_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="summarise a scene: counts, lights, cameras, time range, effects needed")
    _add_scene_arguments(p)
    p.add_argument("--time", type=finite_float, default=None)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")


def _cmd_info(args: argparse.Namespace) -> int:
    import json

    from .scene.usd.info import format_info, scene_info

    source = _open_scene(args)
    scene = source.scene_at(args.time)
    info = scene_info(scene, source)
    print(json.dumps(info, indent=2) if args.json else format_info(info))
    return 0


def _add_convert_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="convert OBJ/PLY/STL/glTF/GLB (through trimesh) to .usda or .usdc")
    p.add_argument("input")
    p.add_argument("output", help="destination .usd, .usda or .usdc")


def _cmd_convert(args: argparse.Namespace) -> int:
    from .output import check_outputs
    from .scene.authoring.convert import convert_mesh_file
    from .scene.authoring.writer import check_usd_path

    check_usd_path(args.output)
    check_outputs({"OUT": args.output})
    convert_mesh_file(args.input, args.output)
    print(f"{args.output}: written")
    return 0


def _add_view_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="interactive viewer: a local web page where the cursor (or the webcam) is the gaze")
    _add_scene_arguments(p)
    p.add_argument("--port", type=int, default=8000, help="TCP port (default 8000)")
    p.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1; any other is warned about)"
    )
    p.add_argument("--gaze", default="cursor", help="cursor (default), webcam:INDEX[?calibration=FILE] or trace:PATH")
    _add_budget_arguments(p, LoopSettings().fps)
    _add_loop_arguments(p)
    _add_frame_arguments(
        p, "a fixed focus window (share of the screen) instead of the budget controller's (default: adaptive)", None
    )
    p.add_argument("--jpeg-quality", type=int, default=80, help="JPEG quality of the frames, 1..100 (default 80)")
    p.add_argument("--record-dir", default="recordings", help="where recordings go (default recordings/)")
    p.add_argument(
        "--calibration-out",
        default="calibration.json",
        help="where the webcam calibration made on the page is saved (default calibration.json)",
    )


def _cmd_view(args: argparse.Namespace) -> int:
    from pathlib import Path

    from gaze.factory import split_spec

    from .runtime import init_warp
    from .viewer.render_thread import ViewSettings
    from .viewer.serve import build_viewer, serve

    if not 1 <= args.jpeg_quality <= 100:
        raise RenderSettingsError(f"--jpeg-quality must lie in 1..100, got {args.jpeg_quality}")
    if split_spec(args.gaze)[0] == "fixed":
        raise RenderSettingsError(f"view --gaze must be cursor, webcam:... or trace:..., got {args.gaze!r}")
    _one_sample(args, "view (the adaptive loop)")
    init_warp()
    source = _open_scene(args)
    settings = ViewSettings(
        render=_render_settings(args, cache_raster=args.raster_cache, cache_shadows=args.shadow_cache),
        loop=_loop_settings(args, 0.0, adaptive=args.window is None, saccade=args.saccade),
        camera_path=args.camera,
        gaze=args.gaze,
        jpeg_quality=args.jpeg_quality,
        record_dir=Path(args.record_dir),
        calibration_file=Path(args.calibration_out),
    )
    serve(build_viewer(source, settings), args.host, args.port)
    return 0


class OneLineParser(argparse.ArgumentParser):
    """argparse with this program's error rule: a bad argument is one line (naming the
    option and the problem, pointing at ``--help``) and exit status 2; and a value that
    starts with ``-`` and a digit (``--size -5x10``) is a value, not an unknown option,
    so it gets its option's own message.  Sub-commands' parsers are of this class too."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._negative_number_matcher = re.compile(r"^-\d")

    def error(self, message: str) -> NoReturn:
        """Print ``error: PROG: MESSAGE (PROG --help for usage)`` and exit with status 2."""
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


class _WarningLines(logging.Handler):
    """Prints each warning the package logs as one ``warning:`` line on stderr."""

    def emit(self, record: logging.LogRecord) -> None:
        print(f"warning: {_clean(record.getMessage())}", file=sys.stderr)


def _clean(text: str) -> str:
    """A message as printed: pxr's mangled namespaces dropped."""
    from .scene.usd.pxr_text import strip_namespaces

    return strip_namespaces(text)


@contextmanager
def _report_warnings() -> Iterator[None]:
    """While a command runs, print the package's logged warnings (each logged once per
    scene) and Python warnings as one ``warning:`` line each, once: the commands do not
    print them again."""
    logger = logging.getLogger("warp_hybrid")
    handler = _WarningLines(logging.WARNING)
    logger.addHandler(handler)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _warning_line
            yield
    finally:
        logger.removeHandler(handler)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (render, replay, bench, info, convert, gaze, view)."""
    from gaze.cli import add_gaze_parser

    parser = OneLineParser(prog="warp-hybrid", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    _add_render_parser(sub)
    _add_replay_parser(sub)
    _add_bench_parser(sub)
    _add_info_parser(sub)
    _add_convert_parser(sub)
    add_gaze_parser(sub)
    _add_view_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the process exit status."""
    from gaze.cli import run_gaze
    from gaze.errors import GazeError

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, or a bad argument (already printed as one line)
        return exc.code if isinstance(exc.code, int) else 2
    commands = {
        "render": _cmd_render,
        "replay": _cmd_replay,
        "bench": _cmd_bench,
        "info": _cmd_info,
        "convert": _cmd_convert,
        "view": _cmd_view,
        "gaze": run_gaze,
    }
    try:
        with _report_warnings():
            return commands[args.command](args)
    except (WarpHybridError, GazeError) as exc:
        print(f"error: {_clean(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"interrupted: warp-hybrid {args.command} stopped; no file is left half-written", file=sys.stderr)
        return 130


def _warning_line(message: Warning | str, *_: object, **__: object) -> None:
    """``warnings.showwarning`` for the command line: one ``warning:`` line."""
    print(f"warning: {_clean(str(message))}", file=sys.stderr)
