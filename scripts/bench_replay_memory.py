"""A long replay keeps memory flat: resident memory at the start and the end of N frames.

Replays ``scenes/textured_animated.usda`` (animated: points copied and the BVH refit
every frame) with a fixed gaze at a small size for ``--frames`` frames (10,000) to an
MP4 and a stats CSV in a temporary folder, and prints the resident set size (RSS,
from /proc/self/statm) after the first 100 frames and at the end, and their
difference.

    .venv/bin/python scripts/bench_replay_memory.py [--frames 10000] [--size 64x48]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def rss_mb() -> float:
    """This process's resident set size in MiB."""
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def main() -> None:
    """Run the replay, sampling RSS after every frame."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10_000)
    ap.add_argument("--size", default="64x48")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))

    from gaze.fixed import FixedSource
    from warp_hybrid.renderer import RenderSettings
    from warp_hybrid.replay.loop import AdaptiveLoop, LoopSettings
    from warp_hybrid.replay.run import ReplayOutputs, replay
    from warp_hybrid.runtime import init_warp
    from warp_hybrid.scene.open import open_scene_source

    init_warp()
    samples: dict[str, float] = {}

    def sample(frame: object) -> None:
        if frame.index == 99:  # type: ignore[attr-defined]
            samples["start"] = rss_mb()
        samples["end"] = rss_mb()

    with tempfile.TemporaryDirectory() as folder:
        outputs = ReplayOutputs(video=Path(folder) / "long.mp4", stats=Path(folder) / "long.csv")
        source = open_scene_source(ROOT / "scenes" / "textured_animated.usda")
        settings = RenderSettings(width=width, height=height, mode="hybrid")
        with AdaptiveLoop(source, settings, LoopSettings(fps=24.0)) as loop:
            result = replay(loop, FixedSource(0.5, 0.5), args.frames, outputs, progress=False, on_frame=sample)
        size_mb = outputs.video.stat().st_size / 2**20
    print(
        f"{result.frames} frames at {width}x{height}: RSS after 100 frames {samples['start']:.1f} MiB, "
        f"at the end {samples['end']:.1f} MiB ({samples['end'] - samples['start']:+.1f} MiB); video {size_mb:.1f} MiB"
    )


if __name__ == "__main__":
    main()
