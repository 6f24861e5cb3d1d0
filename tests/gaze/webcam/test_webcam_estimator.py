"""The whole webcam estimator on synthetic videos read back from MJPG/mp4v files."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from gaze.screen import ScreenGeometry
from gaze.webcam import synthetic
from gaze.webcam.calibration import Calibration
from gaze.webcam.capture import open_frames
from gaze.webcam.commands import record_stream
from gaze.webcam.estimator import REANCHORED_CONFIDENCE, GazeEstimator

if TYPE_CHECKING:
    from conftest import Videos

#: The issue's target for the median error, degrees.
MAX_MEDIAN_DEG = 1.5


def test_end_to_end_error_is_within_the_bound(videos: Videos, calibration: Calibration) -> None:
    assert calibration.targets == 9 and calibration.samples == 9 * 9  # 15 frames per target, 6 settling
    with open_frames(videos.test.path) as frames:
        rec = record_stream(frames, GazeEstimator(calibration))
    np.testing.assert_array_equal(rec.t, videos.test.t)
    assert rec.valid.all() and (rec.confidence > 0.6).all()
    deg, px = synthetic.gaze_errors(videos.test, rec.x, rec.y, ScreenGeometry(1920, 1080, 53.0, 60.0))
    print(
        f"webcam estimator: median {np.median(deg):.3f} deg ({np.median(px):.1f} px), "
        f"90th percentile {np.percentile(deg, 90):.3f} deg over {deg.size} settled frames"
    )
    assert np.median(deg) <= MAX_MEDIAN_DEG
    # Every test target is told apart: the per-target median lands nearer its own target than any other.
    targets = synthetic.evaluation_targets()
    settled = videos.test.since_change >= 0.2
    for k, (_, tx, ty) in enumerate(targets):
        pick = settled & (videos.test.x == tx) & (videos.test.y == ty)
        est = np.array([np.median(rec.x[pick]), np.median(rec.y[pick])])
        nearest = np.argmin(np.hypot(targets[:, 1] - est[0], targets[:, 2] - est[1]))
        assert nearest == k


def test_without_calibration_samples_are_the_centre_with_raw_features(videos: Videos) -> None:
    estimator = GazeEstimator()
    with open_frames(videos.test.path) as frames:
        samples = [estimator.process(frames.read().image, k / 30.0) for k in range(3)]
    for s in samples:
        assert (s.x, s.y, s.valid, s.confidence) == (0.5, 0.5, False, 0.0)
        assert s.features is not None and all(abs(f) < 0.1 for f in s.features)


def test_lost_face_gives_invalid_samples_holding_the_last_point(videos: Videos, calibration: Calibration) -> None:
    estimator = GazeEstimator(calibration)
    with open_frames(videos.test.path) as frames:
        good = [estimator.process(frames.read().image, k / 30.0) for k in range(5)][-1]
    assert good.valid and good.confidence > 0.6
    blank = np.full((480, 640, 3), 128, np.uint8)
    lost = estimator.process(blank, 0.2)
    assert not lost.valid and lost.confidence == 0.0 and lost.features is None
    assert (lost.x, lost.y) == (good.x, good.y)


def test_calibration_whose_face_reference_is_not_found_caps_the_confidence(
    videos: Videos, calibration: Calibration
) -> None:
    assert calibration.reference is not None
    noise = np.random.default_rng(0).integers(0, 256, calibration.reference.template.shape, dtype=np.uint8)
    foreign = replace(calibration, reference=replace(calibration.reference, template=noise))
    estimator = GazeEstimator(foreign)
    with open_frames(videos.test.path) as frames:
        sample = estimator.process(frames.read().image, 0.0)
    assert estimator.tracker.reference is not foreign.reference
    assert sample.valid and sample.confidence == REANCHORED_CONFIDENCE
