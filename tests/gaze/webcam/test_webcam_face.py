"""Face detection on the astronaut photo and sub-pixel template tracking."""

from __future__ import annotations

import cv2
import numpy as np

from gaze.webcam.face import FaceDetector, FaceTracker
from gaze.webcam.synthetic import astronaut_face, photo_eyes

# Where the face and eyes of skimage's astronaut are (photo pixels), by inspection.
FACE_CENTRE = (224.0, 113.0)
EYES = ((202.0, 101.0), (246.5, 103.5))


def test_detector_finds_the_astronauts_face_and_eyes() -> None:
    grey = cv2.cvtColor(astronaut_face(), cv2.COLOR_BGR2GRAY)
    detector = FaceDetector(detect_width=512)
    box = detector.detect(grey)
    assert box is not None
    assert abs(box.x + box.w / 2 - FACE_CENTRE[0]) < 8 and abs(box.y + box.h / 2 - FACE_CENTRE[1]) < 8
    assert 80 <= box.w <= 115
    np.testing.assert_allclose(detector.eyes(grey, box), EYES, atol=3.0)
    np.testing.assert_allclose(photo_eyes(astronaut_face()), EYES, atol=3.0)


def frame_at(photo: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """The photo scaled 1.25x into a 640x480 grey frame, shifted by (dx, dy) pixels."""
    matrix = np.array([[1.25, 0.0, 40.0 + dx], [0.0, 1.25, 60.0 + dy]])
    bgr = cv2.warpAffine(photo, matrix, (640, 480), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)


def test_template_tracking_is_sub_pixel() -> None:
    photo = astronaut_face()
    tracker = FaceTracker()
    first = tracker.update(frame_at(photo, 0.0, 0.0))
    assert first is not None and first.redetected
    shifts = [(0.3, -0.2), (1.7, 0.45), (-2.25, 1.1), (4.6, -3.35), (0.0, 0.0)]
    for dx, dy in shifts:
        track = tracker.update(frame_at(photo, dx, dy))
        assert track is not None and not track.redetected and track.score > 0.95
        np.testing.assert_allclose(track.anchor - first.anchor, (dx, dy), atol=0.08)
        np.testing.assert_allclose(track.eyes - first.eyes, [(dx, dy), (dx, dy)], atol=0.08)


def test_lost_face_is_found_again_with_the_same_reference() -> None:
    photo = astronaut_face()
    tracker = FaceTracker()
    first = tracker.update(frame_at(photo, 0.0, 0.0))
    reference = tracker.reference
    assert first is not None
    assert tracker.update(np.full((480, 640), 128, np.uint8)) is None
    again = tracker.update(frame_at(photo, 6.3, -2.2))
    assert again is not None and again.redetected and tracker.reference is reference
    np.testing.assert_allclose(again.anchor - first.anchor, (6.3, -2.2), atol=0.1)
