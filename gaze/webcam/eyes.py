"""Pupil centres in the eye regions of a tracked face, and the gaze feature they give.

The pupil (with the iris, the darkest blob in the eye) is found by a dark-weighted
centroid: the minimum of the Gaussian-blurred eye region gives a first guess; inside a
disc of ``WINDOW`` pupil radii around it each pixel weighs ``max(0, threshold - I)``
with the threshold halfway between the disc's dark and bright levels (pupil vs. eye
white), and the weighted centroid is taken, re-centring the disc twice.  Edge pixels
weigh by how much of them is pupil, so the centre is sub-pixel.  The feature is the
mean pupil position of both eyes relative to the eye centres that move with the
tracked face anchor, in units of the face width (so that it does not depend on the
camera's resolution).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gaze.webcam.face import FaceTrack

#: Pupil/iris radius as a fraction of the face width, and the eye search region's half size.
PUPIL_FRACTION = 0.035
REGION_HALF = (0.14, 0.08)
#: The centroid's disc radius in pupil radii.
WINDOW = 1.7
#: Dark-to-bright contrast (grey levels) at which pupil confidence reaches 1; below a third of it the pupil is lost.
FULL_CONTRAST = 90.0


@dataclass(frozen=True)
class Pupil:
    """A pupil centre (frame pixels, pixel edges: pixel (i, j) spans [i, i+1)) and its contrast."""

    x: float
    y: float
    contrast: float

    @property
    def confidence(self) -> float:
        """0..1 from the dark-to-bright contrast around the pupil."""
        return float(np.clip(self.contrast / FULL_CONTRAST, 0.0, 1.0))


@dataclass(frozen=True)
class EyeMeasurement:
    """Both pupils (None where lost), the feature (None unless both were found) and a 0..1 confidence."""

    pupils: tuple[Pupil | None, Pupil | None]
    features: np.ndarray | None
    confidence: float


def _centroid(region: np.ndarray, guess: np.ndarray, radius: float) -> tuple[np.ndarray, float] | None:
    """Dark-weighted centroid in a disc around ``guess`` (region pixel-edge coordinates)."""
    h, w = region.shape
    centre = guess.astype(float)
    contrast = 0.0
    for _ in range(3):
        x0, x1 = max(int(centre[0] - radius), 0), min(int(np.ceil(centre[0] + radius)) + 1, w)
        y0, y1 = max(int(centre[1] - radius), 0), min(int(np.ceil(centre[1] + radius)) + 1, h)
        if x1 - x0 < 3 or y1 - y0 < 3:
            return None
        xs, ys = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
        inside = np.hypot(xs - centre[0], ys - centre[1]) <= radius
        values = region[y0:y1, x0:x1][inside].astype(float)
        dark, bright = np.percentile(values, (5.0, 95.0))
        contrast = float(bright - dark)
        weights = np.maximum(0.5 * (dark + bright) - values, 0.0)
        total = float(weights.sum())
        if total <= 0.0:
            return None
        centre = np.array([(weights * xs[inside]).sum(), (weights * ys[inside]).sum()]) / total
    return centre, contrast


def find_pupil(grey: np.ndarray, eye: np.ndarray, face_width: float) -> Pupil | None:
    """The pupil near the eye centre ``eye`` (frame pixels) of a face ``face_width`` px wide."""
    radius = PUPIL_FRACTION * face_width
    hx, hy = REGION_HALF[0] * face_width, REGION_HALF[1] * face_width
    x0, y0 = max(int(eye[0] - hx), 0), max(int(eye[1] - hy), 0)
    x1, y1 = min(int(np.ceil(eye[0] + hx)), grey.shape[1]), min(int(np.ceil(eye[1] + hy)), grey.shape[0])
    if x1 - x0 < 3 or y1 - y0 < 3:
        return None
    region = grey[y0:y1, x0:x1]
    blurred = cv2.GaussianBlur(region, (0, 0), max(radius / 2.0, 0.8))
    _, _, (mx, my), _ = cv2.minMaxLoc(blurred)
    found = _centroid(region, np.array([mx + 0.5, my + 0.5]), WINDOW * radius)
    if found is None or found[1] < FULL_CONTRAST / 3.0:
        return None
    centre, contrast = found
    return Pupil(float(x0 + centre[0]), float(y0 + centre[1]), contrast)


def measure_eyes(grey: np.ndarray, track: FaceTrack) -> EyeMeasurement:
    """Pupils of both eyes and the feature: mean pupil offset from the eye centres / face width."""
    width = track.box.w
    pupils = tuple(find_pupil(grey, eye, width) for eye in track.eyes)
    if pupils[0] is None or pupils[1] is None:
        return EyeMeasurement((pupils[0], pupils[1]), None, 0.0)
    positions = np.array([[p.x, p.y] for p in pupils])
    features = (positions - track.eyes).mean(axis=0) / width
    return EyeMeasurement((pupils[0], pupils[1]), features, min(p.confidence for p in pupils))
