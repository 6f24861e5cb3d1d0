"""Pupil centres by the dark-weighted centroid: sub-pixel on drawn eyes, lost on a blank region."""

from __future__ import annotations

import numpy as np

from gaze.webcam.eyes import find_pupil, measure_eyes
from gaze.webcam.face import Box, FaceTrack
from gaze.webcam.synthetic import _draw_eye

FACE_W = 160.0


def eye_image(pupils: list[tuple[float, float]], centres: list[tuple[float, float]]) -> np.ndarray:
    """Grey skin with drawn eyes (white ellipse, dark pupil) at the given positions."""
    frame = np.full((120, 200, 3), 190, np.uint8)
    for centre, pupil in zip(centres, pupils, strict=True):
        _draw_eye(frame, np.array(centre), np.array(pupil))
    return frame[..., 0].copy()


def test_pupil_centre_is_sub_pixel() -> None:
    centre = (60.0, 50.0)
    for dx, dy in [(0.0, 0.0), (0.3, 0.1), (-3.7, 1.45), (5.2, -2.6), (-5.9, 3.3)]:
        pupil = (centre[0] + dx, centre[1] + dy)
        found = find_pupil(eye_image([pupil], [centre]), np.array(centre), FACE_W)
        assert found is not None and found.confidence == 1.0
        np.testing.assert_allclose((found.x, found.y), pupil, atol=0.08)


def test_features_average_both_eyes_relative_to_the_anchor_and_lost_pupils_give_none() -> None:
    centres = [(55.0, 50.0), (140.0, 52.0)]
    offset = (2.5, -1.5)
    image = eye_image([(c[0] + offset[0], c[1] + offset[1]) for c in centres], centres)
    track = FaceTrack(np.zeros(2), Box(20.0, 0.0, FACE_W, FACE_W), np.array(centres), 0.99, False)
    measured = measure_eyes(image, track)
    assert measured.features is not None and measured.confidence == 1.0
    np.testing.assert_allclose(measured.features * FACE_W, offset, atol=0.08)
    blank = np.full_like(image, 190)
    blank[:, 100:] = image[:, 100:]
    lost = measure_eyes(blank, track)
    assert lost.features is None and lost.confidence == 0.0 and lost.pupils[0] is None and lost.pupils[1] is not None
