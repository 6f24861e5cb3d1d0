"""A sweep's results: ``results.csv``, ``results.md`` and one plot per scene.

``results.csv`` has one row per configuration, these columns first: ``scene, method,
label, fraction, scale, ms, flip_mean, flip_foveated, flip_inside, flip_outside, psnr,
spp`` (the window's samples per pixel: 1 but for ``hybrid_fovea``),
then ``<stage>_ms`` for every stage any configuration reported (0 where it did not).
Each plot (``<scene>.png``, matplotlib) shows time (ms) against foveated FLIP, a line
per method, with the Pareto front (the configurations no other is both faster and more
accurate than) marked.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..output import atomic_write_bytes
from .configs import METHODS
from .measure import Measurement

#: The columns every row starts with.
RESULT_COLUMNS = (
    "scene",
    "method",
    "label",
    "fraction",
    "scale",
    "ms",
    "flip_mean",
    "flip_foveated",
    "flip_inside",
    "flip_outside",
    "psnr",
    "spp",
)


def pareto_front(points: Sequence[tuple[float, float]]) -> list[int]:
    """Indices of the points (time, error) that no other point beats in both (ties in
    both keep the first), ordered by time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front: list[int] = []
    best = float("inf")
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def _row(scene: str, m: Measurement, stages: Sequence[str]) -> dict[str, object]:
    e = m.error
    row: dict[str, object] = {
        "scene": scene,
        "method": m.config.method,
        "label": m.config.label,
        "fraction": f"{m.config.fraction:.6f}",
        "scale": f"{m.config.scale:g}",
        "ms": f"{m.ms:.3f}",
        "flip_mean": f"{e.flip_mean:.6f}",
        "flip_foveated": f"{e.flip_foveated:.6f}",
        "flip_inside": f"{e.flip_inside:.6f}",
        "flip_outside": f"{e.flip_outside:.6f}",
        "psnr": f"{e.psnr:.3f}",
        "spp": m.config.spp,
    }
    row.update({f"{s}_ms": f"{m.stages_ms.get(s, 0.0):.3f}" for s in stages})
    return row


def _csv_text(results: Mapping[str, Sequence[Measurement]]) -> str:
    stages = sorted({s for ms in results.values() for m in ms for s in m.stages_ms})
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=[*RESULT_COLUMNS, *(f"{s}_ms" for s in stages)], lineterminator="\n")
    writer.writeheader()
    for scene, measurements in results.items():
        for m in measurements:
            writer.writerow(_row(scene, m, stages))
    return out.getvalue()


def _markdown(results: Mapping[str, Sequence[Measurement]], notes: Mapping[str, str]) -> str:
    lines = []
    for scene, measurements in results.items():
        front = set(pareto_front([(m.ms, m.error.flip_foveated) for m in measurements]))
        lines += [f"### {scene}", ""]
        if scene in notes:
            lines += [notes[scene], ""]
        lines += [
            "| configuration | ms | foveated FLIP | FLIP inside | FLIP outside | FLIP mean | PSNR dB | Pareto |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for i, m in enumerate(measurements):
            e = m.error
            lines.append(
                f"| {m.config.label} | {m.ms:.1f} | {e.flip_foveated:.4f} | {e.flip_inside:.4f} | "
                f"{e.flip_outside:.4f} | {e.flip_mean:.4f} | {e.psnr:.2f} | {'*' if i in front else ''} |"
            )
        lines.append("")
    return "\n".join(lines)


def _plot_png(scene: str, measurements: Sequence[Measurement]) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=100)
    for method in METHODS:
        own = sorted((m for m in measurements if m.config.method == method), key=lambda m: m.ms)
        if own:
            ax.plot([m.ms for m in own], [m.error.flip_foveated for m in own], marker="o", label=method)
    points = [(m.ms, m.error.flip_foveated) for m in measurements]
    front = pareto_front(points)
    ax.step(
        [points[i][0] for i in front],
        [points[i][1] for i in front],
        where="post",
        color="black",
        linestyle="--",
        linewidth=1,
        label="Pareto front",
    )
    ax.set_xscale("log")
    ax.set_xlabel("frame time (ms, median)")
    ax.set_ylabel("foveated FLIP (lower is better)")
    ax.set_title(scene)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def write_results(
    folder: str | Path, results: Mapping[str, Sequence[Measurement]], notes: Mapping[str, str] | None = None
) -> list[Path]:
    """Write ``results.csv``, ``results.md`` and ``<scene>.png`` per scene into
    ``folder`` (atomically each); ``notes`` adds a line under a scene's table."""
    folder = Path(folder)
    written = [folder / "results.csv", folder / "results.md"]
    atomic_write_bytes(written[0], _csv_text(results).encode())
    atomic_write_bytes(written[1], _markdown(results, notes or {}).encode())
    for scene, measurements in results.items():
        path = folder / f"{scene}.png"
        atomic_write_bytes(path, _plot_png(scene, measurements))
        written.append(path)
    return written
