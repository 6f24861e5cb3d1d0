"""Synthetic webcam videos with a known gaze, for the estimator's tests and benchmark.

A real face photo (scikit-image's astronaut, shipped with that package) is scaled 2x
into a 640x480 frame and moved by a few pixels of drift and jitter (the head);
eye whites and dark pupils are drawn, anti-aliased, at the eyes that OpenCV's Haar eye
cascade finds in the photo.  Each pupil sits at ``R sin(angle)`` from the eye centre,
where ``angle`` is the visual angle of the gaze target from the screen centre (53 cm
wide 1920x1080 screen at 60 cm): about +-6 px across the screen, slightly nonlinear.
After each target change the eye moves to the new target over ``SACCADE_S``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaze.errors import GazeError
from gaze.screen import ScreenGeometry

FRAME_W, FRAME_H = 640, 480
SCALE = 2.0
#: Where the photo's face centre lands in the frame.
FACE_AT = (320.0, 220.0)
#: Eye-ball radius in frame pixels: the pupil moves R sin(angle); 6 px at the screen's side edge.
EYE_RADIUS_PX = 14.9
WHITE_AXES = (16.0, 11.0)
PUPIL_RADIUS = 5.5
WHITE_LEVEL = 232.0
PUPIL_LEVEL = 35.0
#: The eye's travel time after a target change (the calibration ignores the first 0.2 s).
SACCADE_S = 0.2
#: Video codecs by file suffix; both work in the opencv-python 4.x wheels.
FOURCC = {".avi": "MJPG", ".mp4": "mp4v"}


@dataclass(frozen=True)
class SyntheticVideo:
    """What was rendered: per frame its time and the true gaze point (normalised, top-left)."""

    path: str
    fps: float
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    #: Seconds since the current target appeared (to skip the eye's travel when scoring).
    since_change: np.ndarray


def astronaut_face() -> np.ndarray:
    """The astronaut photo as BGR uint8 (needs scikit-image)."""
    from skimage import data

    return cv2.cvtColor(data.astronaut(), cv2.COLOR_RGB2BGR)


def photo_eyes(photo: np.ndarray) -> np.ndarray:
    """Eye centres (2, 2) in photo pixels, left to right, from the Haar eye cascade."""
    cascade = cv2.CascadeClassifier(cv2.data.haarcascades + "haarcascade_eye.xml")
    grey = cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)
    found = cascade.detectMultiScale(grey, 1.1, 5)
    if len(found) < 2:
        raise GazeError("astronaut photo", f"the Haar eye cascade found {len(found)} eyes, expected 2")
    boxes = sorted(found.tolist(), key=lambda b: b[2] * b[3], reverse=True)[:2]
    centres = np.array([[x + w / 2.0, y + h / 2.0] for x, y, w, h in boxes])
    return centres[np.argsort(centres[:, 0])]


def pupil_offset(x: np.ndarray, y: np.ndarray, screen: ScreenGeometry) -> np.ndarray:
    """Pupil displacement (..., 2) in frame pixels when looking at normalised (x, y)."""
    cx, cy = screen.to_cm(x, y)
    return EYE_RADIUS_PX * np.stack(
        [np.sin(np.arctan2(cx, screen.distance_cm)), np.sin(np.arctan2(cy, np.hypot(cx, screen.distance_cm)))],
        axis=-1,
    )


def grid_targets(xs: tuple[float, ...], ys: tuple[float, ...], dwell_s: float) -> np.ndarray:
    """A raster of targets (rows t, x, y), row by row, each shown for ``dwell_s``."""
    points = [(x, y) for y in ys for x in xs]
    return np.array([(k * dwell_s, x, y) for k, (x, y) in enumerate(points)], dtype=float)


def calibration_targets(dwell_s: float = 0.5) -> np.ndarray:
    """The 9-point calibration raster at 10/50/90 % of the screen."""
    return grid_targets((0.1, 0.5, 0.9), (0.1, 0.5, 0.9), dwell_s)


def evaluation_targets(dwell_s: float = 0.5) -> np.ndarray:
    """Twelve targets between the calibration points."""
    return grid_targets((0.2, 0.4, 0.6, 0.8), (0.25, 0.5, 0.75), dwell_s)


def write_targets_csv(path: str | Path, targets: np.ndarray) -> None:
    """Write a targets file: header ``t,x,y`` and one row per target."""
    rows = ["t,x,y"] + [f"{t:.6f},{x:.6f},{y:.6f}" for t, x, y in targets]
    Path(path).write_text("\n".join(rows) + "\n", encoding="utf-8")


def _head_motion(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Head displacement (N, 2) in pixels: slow drift, sway and per-frame jitter."""
    drift = np.stack([0.25 * t + 2.0 * np.sin(2 * np.pi * t / 6.1), 1.5 * np.sin(2 * np.pi * t / 4.3 + 0.7)], axis=1)
    return drift + rng.normal(0.0, 0.25, size=drift.shape)


def _draw_eye(frame: np.ndarray, centre: np.ndarray, pupil: np.ndarray) -> None:
    """Anti-aliased eye white (ellipse) with a dark pupil (disc) clipped to it, in place."""
    a, b = WHITE_AXES
    x0, x1 = int(np.floor(centre[0] - a - 2)), int(np.ceil(centre[0] + a + 2))
    y0, y1 = int(np.floor(centre[1] - b - 2)), int(np.ceil(centre[1] + b + 2))
    xs, ys = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
    f = np.hypot((xs - centre[0]) / a, (ys - centre[1]) / b)
    white = np.clip((1.0 - f) * b + 0.5, 0.0, 1.0)
    disc = np.clip(PUPIL_RADIUS - np.hypot(xs - pupil[0], ys - pupil[1]) + 0.5, 0.0, 1.0) * white
    patch = frame[y0:y1, x0:x1].astype(float)
    eye = WHITE_LEVEL * (1.0 - disc) + PUPIL_LEVEL * disc
    patch = patch * (1.0 - white[..., None]) + eye[..., None] * white[..., None]
    frame[y0:y1, x0:x1] = np.clip(np.rint(patch), 0, 255).astype(np.uint8)


def render_video(
    path: str | Path,
    targets: np.ndarray,
    duration_s: float,
    fps: float = 30.0,
    seed: int = 0,
    screen: ScreenGeometry | None = None,
) -> SyntheticVideo:
    """Render and write a video of the face following ``targets`` (rows t, x, y) for ``duration_s``.

    The codec follows the suffix (``.avi`` MJPG, ``.mp4`` mp4v).  Returns the true gaze
    per frame (during the eye's travel, the target it is moving to).
    """
    path = Path(path)
    if path.suffix not in FOURCC:
        raise GazeError(str(path), f"synthetic videos are {' or '.join(FOURCC)}")
    screen = screen or ScreenGeometry()
    photo = astronaut_face()
    eyes = photo_eyes(photo)
    face_centre = eyes.mean(axis=0) + np.array([0.0, 12.0])
    base_shift = np.array(FACE_AT) - SCALE * face_centre
    n = int(round(duration_s * fps))
    t = np.arange(n) / fps
    rng = np.random.default_rng(seed)
    head = _head_motion(t, rng)
    current = np.clip(np.searchsorted(targets[:, 0], t + 1e-9, side="right") - 1, 0, len(targets) - 1)
    since = t - targets[current, 0]
    goal = pupil_offset(targets[:, 1], targets[:, 2], screen)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*FOURCC[path.suffix]), fps, (FRAME_W, FRAME_H))
    if not writer.isOpened():
        raise GazeError(str(path), f"this OpenCV build cannot write {FOURCC[path.suffix]} video")
    try:
        for k in range(n):
            i = current[k]
            s = min(since[k] / SACCADE_S, 1.0)
            ease = s * s * (3.0 - 2.0 * s)
            offset = goal[max(i - 1, 0)] + (goal[i] - goal[max(i - 1, 0)]) * ease
            shift = base_shift + head[k]
            matrix = np.array([[SCALE, 0.0, shift[0]], [0.0, SCALE, shift[1]]])
            frame = cv2.warpAffine(
                photo, matrix, (FRAME_W, FRAME_H), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
            )
            for eye in eyes:
                centre = SCALE * eye + shift
                _draw_eye(frame, centre, centre + offset)
            writer.write(frame)
    finally:
        writer.release()
    return SyntheticVideo(str(path), fps, t, targets[current, 1], targets[current, 2], since)


def gaze_errors(
    video: SyntheticVideo,
    x: np.ndarray,
    y: np.ndarray,
    screen: ScreenGeometry | None = None,
    settle_s: float = SACCADE_S,
) -> tuple[np.ndarray, np.ndarray]:
    """Errors of estimated points (one per frame) against the true gaze, in degrees and in screen
    pixels, over the frames at least ``settle_s`` after a target change."""
    screen = screen or ScreenGeometry()
    x, y = np.asarray(x, float), np.asarray(y, float)
    if x.shape != video.t.shape or y.shape != video.t.shape:
        raise GazeError(video.path, f"{video.t.size} frames rendered, {x.size} estimates given")
    settled = video.since_change >= settle_s - 1e-6
    deg = screen.angle_deg(x[settled], y[settled], video.x[settled], video.y[settled])
    px = np.hypot((x[settled] - video.x[settled]) * screen.width_px, (y[settled] - video.y[settled]) * screen.height_px)
    return deg, px
