"""Webcam gaze estimator accuracy and speed on synthetic videos with a known gaze.

Renders a 9-point calibration video and a 12-target test video of the astronaut photo
with drawn eyes (640x480, 30 fps, a few px of head drift and jitter; see
gaze/webcam/synthetic.py), writes them with each codec, reads them back through the
capture layer, calibrates on the first and scores the second: median angular error
(degrees, 53 cm wide 1920x1080 screen at 60 cm) and screen pixels over the frames at
least 0.2 s after a target change, and ms per frame (estimator only, and with decoding).
``--haar-every-frame`` adds the ablation that runs the face detector on every frame
instead of tracking.

    .venv/bin/python scripts/bench_gaze.py [--codecs avi mp4] [--seed 0] [--json out/bench_gaze.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gaze.webcam import synthetic  # noqa: E402
from gaze.webcam.calibration import TargetSchedule  # noqa: E402
from gaze.webcam.capture import open_frames  # noqa: E402
from gaze.webcam.commands import calibrate_stream, record_stream  # noqa: E402
from gaze.webcam.estimator import GazeEstimator  # noqa: E402
from gaze.webcam.face import FaceTrack, FaceTracker, make_reference  # noqa: E402


class HaarEveryFrame(FaceTracker):
    """Ablation: the face box of a fresh Haar detection on every frame is the anchor (no tracking);
    the eye offsets within the box come from the first detection."""

    def update(self, grey: np.ndarray) -> FaceTrack | None:
        """Detect; anchor the first frame's reference at the new box."""
        box = self.detector.detect(grey)
        if box is None:
            return None
        if self.reference is None:
            self.reference = make_reference(grey, box, self.detector.eyes(grey, box))
        if self.reference is None:
            return None
        ref = self.reference
        anchor = np.array([box.x - ref.face.x, box.y - ref.face.y])
        return FaceTrack(anchor, ref.face.shifted(*anchor), ref.eyes + anchor, 1.0, True)


def measure(folder: Path, suffix: str, seed: int, haar_every_frame: bool) -> dict:
    """Render, calibrate and score one codec; returns a JSON-ready dict."""
    targets = synthetic.calibration_targets()
    cal = synthetic.render_video(folder / f"calibration{suffix}", targets, 4.5, seed=seed)
    test = synthetic.render_video(folder / f"test{suffix}", synthetic.evaluation_targets(), 6.0, seed=seed + 1)

    def tracker() -> FaceTracker | None:
        return HaarEveryFrame() if haar_every_frame else None

    schedule = TargetSchedule(targets[:, 0], targets[:, 1], targets[:, 2])
    with open_frames(cal.path) as frames:
        calibration, _ = calibrate_stream(frames, schedule, cal.path, GazeEstimator(tracker=tracker()))
    estimator = GazeEstimator(calibration, tracker=tracker())
    start = time.perf_counter()
    with open_frames(test.path) as frames:
        rec = record_stream(frames, estimator)
    total_ms = 1000.0 * (time.perf_counter() - start) / len(rec.t)
    deg, px = synthetic.gaze_errors(test, rec.x, rec.y)
    return {
        "codec": synthetic.FOURCC[suffix],
        "frames": len(rec.t),
        "valid": int(rec.valid.sum()),
        "median_deg": float(np.median(deg)),
        "p90_deg": float(np.percentile(deg, 90)),
        "median_px": float(np.median(px)),
        "ms_per_frame": float(np.median(rec.ms)),
        "ms_per_frame_with_decode": total_ms,
        "calibration_residual": calibration.residual_rms,
    }


def main() -> None:
    """Parse the arguments, run each codec, print a table (and write JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--codecs", nargs="+", choices=("avi", "mp4"), default=["avi", "mp4"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--haar-every-frame", action="store_true", help="also run the detect-every-frame ablation")
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for codec in args.codecs:
            modes = [False, True] if args.haar_every_frame else [False]
            for ablation in modes:
                r = measure(Path(tmp), f".{codec}", args.seed, ablation)
                r["tracker"] = "haar-every-frame" if ablation else "template"
                results.append(r)
    print(
        f"{'codec':6} {'tracker':17} {'median deg':>10} {'p90 deg':>8} {'median px':>9} {'ms/frame':>8} "
        f"{'+decode':>8} {'valid':>9}"
    )
    for r in results:
        print(
            f"{r['codec']:6} {r['tracker']:17} {r['median_deg']:10.3f} {r['p90_deg']:8.3f} {r['median_px']:9.1f} "
            f"{r['ms_per_frame']:8.2f} {r['ms_per_frame_with_decode']:8.2f} {r['valid']:4d}/{r['frames']}"
        )
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
