"""Soak: many renders of a small scene in one process, memory measured at both ends.

Each round is a whole ``warp-hybrid render`` run through ``cli.main`` (load, upload,
BVH, warm-up, frame, the PNG and stats written as one set), every tenth one a refused
run (a bad camera: the error path), so what a long-lived process repeats is covered:
the resident set size (``VmRSS``) after the first rounds and after the last must stay
flat.  The first ``--settle`` rounds (kernels loaded, allocator pools grown) are not
counted.

    .venv/bin/python scripts/soak_render.py [--renders 1000] [--size 32x24] [--json out/soak.json]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def rss_bytes() -> int:
    """This process's resident set size (``VmRSS`` of ``/proc/self/status``)."""
    with open("/proc/self/status", encoding="ascii") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def soak(renders: int, size: str = "32x24", settle: int = 20) -> dict:
    """Run ``settle + renders`` rounds; returns the RSS at the start and the end (MB), at
    each quarter on the way, the rounds and their mean time.  Raises when a round does
    not end as expected."""
    from bad_input_kit import quad_stage

    from warp_hybrid.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        good = quad_stage(root / "quad.usda")
        bad = quad_stage(root / "bad.usda", camera={"focalLength": 0.0})
        out = root / "out"
        rss: dict[str, int] = {}
        quarters: list[float] = []
        t0 = 0.0
        for k in range(settle + renders):
            if k == settle:
                rss["start"] = rss_bytes()
                t0 = time.perf_counter()
            if k > settle and (k - settle) % max(renders // 4, 1) == 0:
                quarters.append(rss_bytes() / 2**20)
            refused = k % 10 == 9
            args = ["render", str(bad if refused else good), "-o", str(out / "x.png"), "--size", size]
            args += ["--stats-json", str(out / "s.json")]
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                code = main(args)
            if code != (2 if refused else 0):
                raise RuntimeError(f"round {k}: exit status {code}")
        elapsed = time.perf_counter() - t0
        rss["end"] = rss_bytes()
    return {
        "renders": renders,
        "size": size,
        "rss_start_mb": rss["start"] / 2**20,
        "rss_end_mb": rss["end"] / 2**20,
        "growth_mb": (rss["end"] - rss["start"]) / 2**20,
        "rss_quarters_mb": quarters,
        "ms_per_round": 1000.0 * elapsed / max(renders, 1),
    }


def main() -> int:
    """Command line: run the soak and print (or write) the numbers."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--renders", type=int, default=1000)
    parser.add_argument("--size", default="32x24")
    parser.add_argument("--settle", type=int, default=20)
    parser.add_argument("--json", default=None, help="also write the numbers here")
    args = parser.parse_args()
    result = soak(args.renders, args.size, args.settle)
    quarters = ", ".join(f"{mb:.1f}" for mb in result["rss_quarters_mb"])
    print(
        f"{result['renders']} renders at {result['size']}: RSS {result['rss_start_mb']:.1f} MB -> "
        f"{result['rss_end_mb']:.1f} MB ({result['growth_mb']:+.1f} MB; on the way {quarters}), "
        f"{result['ms_per_round']:.0f} ms a round"
    )
    if args.json:
        from warp_hybrid.output import write_json

        write_json(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
