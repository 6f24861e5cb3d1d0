"""Face detection (Haar cascades) to start tracking, sub-pixel template tracking in between.

Running a detector on every frame makes the face box jitter by pixels, which swamps
the pupil's few pixels of travel across a screen.  So the Haar cascade only starts
(or restarts) tracking: it fixes a ``FaceReference`` (a grey template of the nose and
mouth, below the eyes so that eye movements do not disturb it, with the face box and
eye centres relative to the template).  Each frame the template is found again by
normalised cross-correlation in a window around its last position; the peak is
refined to sub-pixel precision by a parabola through it and its neighbours, and once
more by matching the template shifted by that fraction (which halves the parabola's
bias, to about 0.02 px rms on the astronaut photo).  When the
best score drops below ``min_score`` the face counts as lost and the detector runs
again; a stored reference (from a calibration) is looked for first, so that the
anchor that the features are measured from stays the same across sessions.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gaze.errors import GazeError

FACE_CASCADE = "haarcascade_frontalface_default.xml"
EYE_CASCADE = "haarcascade_eye.xml"
#: Template region as fractions of the face box (x0, y0, x1, y1): nose and mouth.
TEMPLATE_REGION = (0.2, 0.5, 0.8, 0.9)
#: Pixels cut from each side of the shifted template in ``refine_match`` (bicubic edge effects).
REFINE_MARGIN = 2
#: Eye centres as fractions of the face box when the eye cascade finds no pair.
DEFAULT_EYES = ((0.3, 0.38), (0.7, 0.38))


def load_cascade(name: str) -> cv2.CascadeClassifier:
    """One of the Haar cascades the OpenCV wheel ships in ``cv2.data.haarcascades``."""
    path = cv2.data.haarcascades + name
    cascade = cv2.CascadeClassifier(path)
    if cascade.empty():
        raise GazeError(path, "the Haar cascade does not load (opencv-contrib-python-headless 4.x ships it)")
    return cascade


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in frame pixels (x, y of the top-left corner; pixel edges)."""

    x: float
    y: float
    w: float
    h: float

    def shifted(self, dx: float, dy: float) -> Box:
        """The same box moved by (dx, dy)."""
        return Box(self.x + dx, self.y + dy, self.w, self.h)


class FaceDetector:
    """Largest frontal face by the Haar cascade, run on a frame scaled to ``detect_width``."""

    def __init__(
        self, detect_width: int = 320, scale_factor: float = 1.1, min_neighbors: int = 5, min_face_fraction: float = 0.1
    ) -> None:
        self.detect_width = detect_width
        self.scale_factor = scale_factor
        self.min_neighbors = min_neighbors
        self.min_face_fraction = min_face_fraction
        self._faces = load_cascade(FACE_CASCADE)
        self._eyes = load_cascade(EYE_CASCADE)

    def detect(self, grey: np.ndarray) -> Box | None:
        """The largest face in a grey frame, or None."""
        scale = min(1.0, self.detect_width / grey.shape[1])
        small = cv2.resize(grey, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA) if scale < 1.0 else grey
        side = max(20, int(self.min_face_fraction * small.shape[1]))
        found = self._faces.detectMultiScale(small, self.scale_factor, self.min_neighbors, minSize=(side, side))
        if len(found) == 0:
            return None
        x, y, w, h = max(found.tolist(), key=lambda b: b[2] * b[3])
        return Box(x / scale, y / scale, w / scale, h / scale)

    def eyes(self, grey: np.ndarray, face: Box) -> np.ndarray:
        """Eye centres (2, 2) in frame pixels, left to right: the eye cascade's pair in the upper
        face, or ``DEFAULT_EYES`` fractions of the box when it finds no plausible pair."""
        x0, y0 = int(face.x), int(face.y)
        upper = grey[max(y0, 0) : max(y0 + int(0.6 * face.h), 0), max(x0, 0) : max(x0 + int(face.w), 0)]
        side = max(8, int(face.w / 8))
        found = self._eyes.detectMultiScale(upper, 1.1, 5, minSize=(side, side)) if upper.size else ()
        default = np.array([[face.x + fx * face.w, face.y + fy * face.h] for fx, fy in DEFAULT_EYES])
        if len(found) < 2:
            return default
        boxes = sorted(found.tolist(), key=lambda b: b[2] * b[3], reverse=True)[:2]
        centres = np.array([[max(x0, 0) + x + w / 2.0, max(y0, 0) + y + h / 2.0] for x, y, w, h in boxes])
        centres = centres[np.argsort(centres[:, 0])]
        apart = (centres[1, 0] - centres[0, 0]) / face.w
        level = abs(centres[1, 1] - centres[0, 1]) / face.h
        return centres if 0.25 <= apart <= 0.75 and level <= 0.15 else default


@dataclass(frozen=True)
class FaceReference:
    """What tracking follows: a grey template, and relative to its top-left corner the face
    box and the two eye centres (frame pixels)."""

    template: np.ndarray
    face: Box
    eyes: np.ndarray


def make_reference(grey: np.ndarray, face: Box, eyes: np.ndarray) -> FaceReference | None:
    """Cut the template (``TEMPLATE_REGION`` of the face box) out of a frame; None if it leaves the frame."""
    fx0, fy0, fx1, fy1 = TEMPLATE_REGION
    x0, y0 = int(round(face.x + fx0 * face.w)), int(round(face.y + fy0 * face.h))
    x1, y1 = int(round(face.x + fx1 * face.w)), int(round(face.y + fy1 * face.h))
    if x0 < 0 or y0 < 0 or x1 > grey.shape[1] or y1 > grey.shape[0] or x1 - x0 < 8 or y1 - y0 < 8:
        return None
    origin = np.array([x0, y0], dtype=float)
    return FaceReference(grey[y0:y1, x0:x1].copy(), face.shifted(-x0, -y0), eyes - origin)


@dataclass(frozen=True)
class FaceTrack:
    """The tracked face in one frame: the template's top-left ``anchor`` (sub-pixel), the face
    box and eye centres that move with it, and the match score (normalised correlation)."""

    anchor: np.ndarray
    box: Box
    eyes: np.ndarray
    score: float
    redetected: bool


def _parabola_peak(left: float, centre: float, right: float) -> float:
    """Sub-pixel offset in [-0.5, 0.5] of the vertex of the parabola through three samples."""
    curvature = left - 2.0 * centre + right
    if curvature >= 0.0:
        return 0.0
    return float(np.clip(0.5 * (left - right) / curvature, -0.5, 0.5))


def match_template(grey: np.ndarray, template: np.ndarray, guess: np.ndarray, radius: int) -> tuple[np.ndarray, float]:
    """Best match of ``template`` whose top-left lies within ``radius`` px of ``guess``.

    Returns the sub-pixel top-left (x, y) and the normalised correlation score there
    (-1 when the window does not fit in the frame).
    """
    th, tw = template.shape
    gx, gy = int(round(guess[0])), int(round(guess[1]))
    x0, y0 = max(gx - radius, 0), max(gy - radius, 0)
    x1, y1 = min(gx + radius + tw, grey.shape[1]), min(gy + radius + th, grey.shape[0])
    if x1 - x0 < tw or y1 - y0 < th:
        return np.asarray(guess, dtype=float), -1.0
    result = cv2.matchTemplate(grey[y0:y1, x0:x1], template, cv2.TM_CCOEFF_NORMED)
    _, score, _, (px, py) = cv2.minMaxLoc(result)
    dx = _parabola_peak(result[py, px - 1], score, result[py, px + 1]) if 0 < px < result.shape[1] - 1 else 0.0
    dy = _parabola_peak(result[py - 1, px], score, result[py + 1, px]) if 0 < py < result.shape[0] - 1 else 0.0
    return np.array([x0 + px + dx, y0 + py + dy]), float(score)


def refine_match(
    grey: np.ndarray, template: np.ndarray, estimate: np.ndarray, margin: int = REFINE_MARGIN
) -> tuple[np.ndarray, float]:
    """Remove most of the parabola's sub-pixel bias: shift the template by the estimate's
    fractional part (bicubic), match its inner part again within 1 px and add the small
    residual offset, where the parabola is nearly exact.  Returns the refined top-left and score."""
    base = np.floor(estimate)
    frac = estimate - base
    th, tw = template.shape
    if th <= 2 * margin + 2 or tw <= 2 * margin + 2:
        return estimate, -1.0
    shift = np.array([[1.0, 0.0, frac[0]], [0.0, 1.0, frac[1]]])
    shifted = cv2.warpAffine(template, shift, (tw, th), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    inner = shifted[margin : th - margin, margin : tw - margin]
    anchor, score = match_template(grey, inner, base + margin, 1)
    if score < 0.0:
        return estimate, score
    return anchor - margin + frac, score


class FaceTracker:
    """Haar-initialised sub-pixel template tracking of one face (see the module notes).

    ``search_fraction`` (of the face width) bounds the motion between frames and the
    search around a fresh detection; ``min_score`` is the correlation below which the
    face counts as lost.
    """

    def __init__(
        self,
        detector: FaceDetector | None = None,
        reference: FaceReference | None = None,
        search_fraction: float = 0.12,
        min_score: float = 0.6,
    ) -> None:
        self.detector = detector or FaceDetector()
        self.reference = reference
        self.search_fraction = search_fraction
        self.min_score = min_score
        self._anchor: np.ndarray | None = None

    def _radius(self, scale: float = 1.0) -> int:
        assert self.reference is not None
        return max(4, int(round(scale * self.search_fraction * self.reference.face.w)))

    def _track(self, anchor: np.ndarray, score: float, redetected: bool) -> FaceTrack:
        assert self.reference is not None
        ref = self.reference
        self._anchor = anchor
        return FaceTrack(anchor, ref.face.shifted(*anchor), ref.eyes + anchor, score, redetected)

    def _locate(self, grey: np.ndarray, guess: np.ndarray, radius: int) -> tuple[np.ndarray, float]:
        """The reference template near ``guess``: coarse match, a second look when the peak lies
        on the window's edge (the face moved further), then sub-pixel refinement."""
        assert self.reference is not None
        template = self.reference.template
        anchor, score = match_template(grey, template, guess, radius)
        if np.abs(anchor - np.round(guess)).max() >= radius - 0.5:
            anchor, score = match_template(grey, template, anchor, radius)
        if score >= self.min_score:
            refined, refined_score = refine_match(grey, template, anchor)
            if refined_score >= self.min_score:
                anchor = refined
        return anchor, score

    def _acquire(self, grey: np.ndarray) -> FaceTrack | None:
        """Detect the face; look for the stored reference there, else take a new reference."""
        box = self.detector.detect(grey)
        if box is None:
            return None
        if self.reference is not None:
            guess = np.array([box.x - self.reference.face.x, box.y - self.reference.face.y])
            anchor, score = self._locate(grey, guess, self._radius(2.0))
            if score >= self.min_score:
                return self._track(anchor, score, True)
        reference = make_reference(grey, box, self.detector.eyes(grey, box))
        if reference is None:
            return None
        self.reference = reference
        origin = np.array([box.x - reference.face.x, box.y - reference.face.y])
        return self._track(origin, 1.0, True)

    def update(self, grey: np.ndarray) -> FaceTrack | None:
        """Track the face into a new grey frame; None when it is lost and not found again."""
        if self._anchor is not None and self.reference is not None:
            anchor, score = self._locate(grey, self._anchor, self._radius())
            if score >= self.min_score:
                return self._track(anchor, score, False)
        self._anchor = None
        return self._acquire(grey)

    def reset(self) -> None:
        """Forget the current position (the reference stays); the next frame detects again."""
        self._anchor = None
