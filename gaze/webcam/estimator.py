"""The per-frame webcam pipeline: frame -> face -> eyes -> feature -> calibration -> smoothing.

``GazeEstimator.measure`` tracks the face and finds the pupils; ``to_sample`` turns a
measurement into a ``GazeSample``: the calibrated point, One Euro smoothed (Casiez
et al. 2012), clamped to [0, 1]^2.  Confidence is the lower of the face match
(normalised correlation rescaled from the tracker's ``min_score`` .. 1 to 0 .. 1) and
the pupils' contrast, capped at ``REANCHORED_CONFIDENCE`` when the calibration's face
reference was not found again and tracking had to start on a new one; a lost face or
pupil gives an invalid sample (confidence 0) that holds the last valid point.  Without
a calibration every sample is the screen centre, invalid, with the raw feature in
``GazeSample.features``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gaze.filters import OneEuroFilter
from gaze.source import GazeSample
from gaze.webcam.calibration import Calibration
from gaze.webcam.eyes import EyeMeasurement, measure_eyes
from gaze.webcam.face import FaceReference, FaceTrack, FaceTracker

#: One Euro settings on normalised screen points (cutoffs in Hz, beta in 1/(screen widths per second)).
MIN_CUTOFF_HZ = 1.0
BETA = 5.0
D_CUTOFF_HZ = 1.0
#: Confidence cap when the face had to be re-anchored on a new template, so that the
#: calibration's anchor (and with it the calibration) no longer strictly applies.
REANCHORED_CONFIDENCE = 0.5


def default_smoothing() -> OneEuroFilter:
    """The estimator's One Euro filter (``MIN_CUTOFF_HZ``, ``BETA``, ``D_CUTOFF_HZ``)."""
    return OneEuroFilter(MIN_CUTOFF_HZ, BETA, D_CUTOFF_HZ)


@dataclass(frozen=True)
class Measurement:
    """What one frame showed: the face track and pupils (None when lost) and the face
    reference the feature is measured against."""

    t: float
    track: FaceTrack | None
    eyes: EyeMeasurement | None
    reference: FaceReference | None
    face_confidence: float

    @property
    def features(self) -> np.ndarray | None:
        """The 2-D feature, or None when the face or a pupil was lost."""
        return None if self.eyes is None else self.eyes.features

    @property
    def confidence(self) -> float:
        """0 when lost, else the lower of the face and pupil confidences."""
        if self.features is None or self.eyes is None:
            return 0.0
        return min(self.face_confidence, self.eyes.confidence)


class GazeEstimator:
    """Turns BGR (or grey) frames into gaze samples; one instance per video stream."""

    def __init__(
        self,
        calibration: Calibration | None = None,
        tracker: FaceTracker | None = None,
        smoothing: OneEuroFilter | None = None,
    ) -> None:
        self.calibration = calibration
        reference = calibration.reference if calibration is not None else None
        self.tracker = tracker or FaceTracker(reference=reference)
        self.smoothing = smoothing or default_smoothing()
        self._last = (0.5, 0.5)

    def measure(self, image: np.ndarray, t: float) -> Measurement:
        """Track the face and find the pupils in one frame taken at time ``t``."""
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        track = self.tracker.update(grey)
        if track is None:
            return Measurement(t, None, None, self.tracker.reference, 0.0)
        face_confidence = (track.score - self.tracker.min_score) / (1.0 - self.tracker.min_score)
        eyes = measure_eyes(grey, track)
        return Measurement(t, track, eyes, self.tracker.reference, float(np.clip(face_confidence, 0.0, 1.0)))

    def to_sample(self, measurement: Measurement) -> GazeSample:
        """The gaze sample for a measurement (smoothing state advances)."""
        t, features = measurement.t, measurement.features
        raw = None if features is None else (float(features[0]), float(features[1]))
        if measurement.track is None:
            self.smoothing.reset()
        if self.calibration is None or features is None:
            return GazeSample(*self._last, t, confidence=0.0, valid=False, features=raw)
        point = self.smoothing(t, self.calibration.apply(features))
        self._last = (float(np.clip(point[0], 0.0, 1.0)), float(np.clip(point[1], 0.0, 1.0)))
        confidence = measurement.confidence
        if self.calibration.reference is not None and measurement.reference is not self.calibration.reference:
            confidence = min(confidence, REANCHORED_CONFIDENCE)
        return GazeSample(*self._last, t, confidence=confidence, features=raw)

    def process(self, image: np.ndarray, t: float) -> GazeSample:
        """``to_sample(measure(image, t))``."""
        return self.to_sample(self.measure(image, t))
