"""9-point calibration: a 2nd-order polynomial from the 2-D eye feature to the screen.

Each screen axis is ``c . [1, u, v, u^2, u v, v^2]`` where ``(u, v)`` is the feature
standardised by its calibration mean and spread (which keeps the least-squares system
well conditioned).  The fit runs over one median feature per target, using only the
frames shown at least ``SETTLE_S`` after the target changed (the eye is still moving
before that) and with a measured feature.  The JSON file (schema below) also carries
the face reference that the features were measured from, so that a later session
tracks the same anchor:

.. code-block:: json

    {"schema": "warp-hybrid-gaze-calibration", "version": 1, "model": "quadratic",
     "terms": ["1", "u", "v", "u^2", "uv", "v^2"],
     "feature_mean": [mu, mv], "feature_scale": [su, sv],
     "coefficients": {"x": [6 numbers], "y": [6 numbers]},
     "settle_s": 0.2, "targets": 9, "samples": 81, "residual_rms": 0.002,
     "face_reference": null | {"template_png": "<base64 PNG, grey>",
                               "face_box": [x, y, w, h], "eyes": [[x, y], [x, y]]}}
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaze.atomic import write_atomic
from gaze.errors import GazeError
from gaze.trace.table import read_table
from gaze.webcam.face import Box, FaceReference

SCHEMA = "warp-hybrid-gaze-calibration"
VERSION = 1
MODEL = "quadratic"
TERMS = ("1", "u", "v", "u^2", "uv", "v^2")
#: Seconds after each target change whose samples are ignored.
SETTLE_S = 0.2
#: Frame times are k / fps in floating point: a sample this close to the settle time counts as settled.
TIME_TOLERANCE = 1e-6


def design_matrix(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The (N, 6) quadratic terms ``1, u, v, u^2, uv, v^2``."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)


@dataclass(frozen=True)
class Calibration:
    """Features -> normalised screen point (origin top-left) by one quadratic per axis."""

    feature_mean: np.ndarray
    feature_scale: np.ndarray
    coefficients: np.ndarray
    targets: int = 0
    samples: int = 0
    residual_rms: float = 0.0
    reference: FaceReference | None = None

    def apply(self, features: np.ndarray) -> np.ndarray:
        """Screen points (..., 2) for features (..., 2)."""
        f = (np.asarray(features, float) - self.feature_mean) / self.feature_scale
        return design_matrix(f[..., 0], f[..., 1]) @ self.coefficients.T

    def to_json(self) -> dict:
        """The JSON document (see the module notes)."""
        reference = None
        if self.reference is not None:
            ok, png = cv2.imencode(".png", self.reference.template)
            if not ok:
                raise GazeError("calibration", "the face template does not encode as PNG")
            box = self.reference.face
            reference = {
                "template_png": base64.b64encode(png.tobytes()).decode("ascii"),
                "face_box": [box.x, box.y, box.w, box.h],
                "eyes": self.reference.eyes.tolist(),
            }
        return {
            "schema": SCHEMA,
            "version": VERSION,
            "model": MODEL,
            "terms": list(TERMS),
            "feature_mean": self.feature_mean.tolist(),
            "feature_scale": self.feature_scale.tolist(),
            "coefficients": {"x": self.coefficients[0].tolist(), "y": self.coefficients[1].tolist()},
            "settle_s": SETTLE_S,
            "targets": self.targets,
            "samples": self.samples,
            "residual_rms": self.residual_rms,
            "face_reference": reference,
        }

    def save(self, path: str | Path) -> None:
        """Write the JSON file atomically."""
        write_atomic(path, json.dumps(self.to_json(), indent=1) + "\n")


def fit_polynomial(
    features: np.ndarray,
    screen: np.ndarray,
    samples: int | None = None,
    reference: FaceReference | None = None,
    where: str = "calibration",
) -> Calibration:
    """Least-squares quadratic from features (N, 2) to screen points (N, 2); N >= 6 in general position."""
    features, screen = np.asarray(features, float), np.asarray(screen, float)
    if features.ndim != 2 or features.shape[1] != 2 or screen.shape != features.shape:
        raise GazeError(where, f"need (N, 2) features and screen points, got {features.shape} and {screen.shape}")
    if len(features) < len(TERMS):
        raise GazeError(where, f"need at least {len(TERMS)} calibration points, got {len(features)}")
    mean = features.mean(axis=0)
    scale = features.std(axis=0)
    if not (scale > 0).all():
        raise GazeError(where, "the eye feature does not vary between targets (were the eyes found?)")
    f = (features - mean) / scale
    design = design_matrix(f[:, 0], f[:, 1])
    if np.linalg.matrix_rank(design) < len(TERMS):
        raise GazeError(where, "the calibration points do not determine a quadratic (too few distinct points)")
    coefficients, *_ = np.linalg.lstsq(design, screen, rcond=None)
    residual = design @ coefficients - screen
    return Calibration(
        mean,
        scale,
        coefficients.T.copy(),
        len(features),
        len(features) if samples is None else samples,
        float(np.sqrt((residual**2).sum(axis=1).mean())),
        reference,
    )


@dataclass(frozen=True)
class TargetSchedule:
    """Calibration targets: target k (normalised x, y) is shown from ``t[k]`` until ``t[k+1]``."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray

    def index_at(self, t: np.ndarray) -> np.ndarray:
        """The target shown at each time (-1 before the first)."""
        return np.searchsorted(self.t, np.asarray(t, float) + TIME_TOLERANCE, side="right") - 1

    def settled(self, t: np.ndarray, settle_s: float = SETTLE_S) -> np.ndarray:
        """True where a target is shown and has been for at least ``settle_s``."""
        index = self.index_at(t)
        since = np.asarray(t, float) - self.t[np.maximum(index, 0)]
        return (index >= 0) & (since >= settle_s - TIME_TOLERANCE)


def read_targets(path: str | Path) -> TargetSchedule:
    """A targets CSV: header ``t,x,y``, times increasing, points in [0, 1]^2 (``GazeError`` naming it)."""
    if not Path(path).is_file():
        raise GazeError(str(path), "targets file not found")
    table = read_table(path, ",")
    if [h.lower() for h in table.header] != ["t", "x", "y"]:
        raise GazeError(table.path, f"unknown columns {table.header}; a targets file has t,x,y")
    t, x, y = (table.floats(i) for i in range(3))
    if len(t) == 0:
        raise GazeError(table.path, "no targets")
    bad = ~(np.isfinite(t) & np.isfinite(x) & np.isfinite(y))
    if bad.any():
        raise GazeError(table.path, f"line {int(table.lines[np.argmax(bad)])}: empty or non-finite cell")
    if ((x < 0) | (x > 1) | (y < 0) | (y > 1)).any():
        k = int(np.argmax((x < 0) | (x > 1) | (y < 0) | (y > 1)))
        raise GazeError(
            table.path,
            f"line {int(table.lines[k])}: target ({x[k]:g}, {y[k]:g}) is outside [0,1]^2 (normalised, origin top-left)",
        )
    if (np.diff(t) <= 0).any():
        k = int(np.argmax(np.diff(t) <= 0)) + 1
        raise GazeError(table.path, f"line {int(table.lines[k])}: times must increase")
    return TargetSchedule(t, x, y)


def fit_calibration(
    t: np.ndarray,
    features: np.ndarray,
    valid: np.ndarray,
    schedule: TargetSchedule,
    settle_s: float = SETTLE_S,
    reference: FaceReference | None = None,
    where: str = "calibration",
) -> Calibration:
    """Fit from per-frame features: settled, valid frames only; one median feature per target."""
    t, features, valid = np.asarray(t, float), np.asarray(features, float), np.asarray(valid, bool)
    use = valid & schedule.settled(t, settle_s) & np.isfinite(features).all(axis=1)
    index = schedule.index_at(t)
    targets = [k for k in range(len(schedule.t)) if (use & (index == k)).any()]
    if len(targets) < len(TERMS):
        raise GazeError(
            where,
            f"only {len(targets)} of {len(schedule.t)} targets have settled frames with both "
            f"pupils found; a quadratic needs {len(TERMS)}",
        )
    medians = np.array([np.median(features[use & (index == k)], axis=0) for k in targets])
    screen = np.stack([schedule.x[targets], schedule.y[targets]], axis=1)
    return fit_polynomial(medians, screen, int(use.sum()), reference, where)


def _numbers(doc: dict, key: str, count: int, where: str) -> np.ndarray:
    """A list of ``count`` finite numbers under ``key``."""
    return _finite_list(doc.get(key), key, count, where)


def _finite_list(value: object, name: str, count: int, where: str) -> np.ndarray:
    """``value`` as ``count`` finite numbers; ``GazeError`` naming ``where`` and ``name`` otherwise."""
    if (
        not isinstance(value, list)
        or len(value) != count
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise GazeError(where, f"{name!r} must be a list of {count} finite numbers, got {value!r:.80}")
    return np.asarray(value, dtype=float)


def _reference(doc: object, where: str) -> FaceReference | None:
    """The stored face reference, or None."""
    if doc is None:
        return None
    if not isinstance(doc, dict):
        raise GazeError(where, "'face_reference' must be an object or null")
    try:
        png = np.frombuffer(base64.b64decode(doc.get("template_png", ""), validate=True), np.uint8)
    except (ValueError, TypeError):
        raise GazeError(where, "'face_reference.template_png' is not base64") from None
    template = cv2.imdecode(png, cv2.IMREAD_GRAYSCALE) if png.size else None
    if template is None or min(template.shape) < 8:
        raise GazeError(where, "'face_reference.template_png' is not a grey PNG of at least 8x8 pixels")
    box = _numbers(doc, "face_box", 4, where)
    if box[2] <= 0 or box[3] <= 0:
        raise GazeError(where, f"'face_reference.face_box' needs a positive size, got {box.tolist()}")
    eyes = doc.get("eyes")
    if not isinstance(eyes, list) or len(eyes) != 2:
        raise GazeError(where, "'face_reference.eyes' must be two [x, y] points")
    points = np.array([_finite_list(e, "eyes", 2, where) for e in eyes])
    return FaceReference(template, Box(*box.tolist()), points)


def calibration_from_json(doc: object, where: str) -> Calibration:
    """Validate a parsed calibration document; ``GazeError`` naming ``where`` on any problem."""
    if not isinstance(doc, dict):
        raise GazeError(where, "a calibration file holds one JSON object")
    if doc.get("schema") != SCHEMA:
        raise GazeError(where, f"not a gaze calibration (schema {doc.get('schema')!r}, expected {SCHEMA!r})")
    if doc.get("version") != VERSION:
        raise GazeError(where, f"unsupported calibration version {doc.get('version')!r} (this build reads {VERSION})")
    if doc.get("model") != MODEL or doc.get("terms") != list(TERMS):
        raise GazeError(where, f"unsupported model {doc.get('model')!r} with terms {doc.get('terms')!r}")
    mean = _numbers(doc, "feature_mean", 2, where)
    scale = _numbers(doc, "feature_scale", 2, where)
    if not (scale > 0).all():
        raise GazeError(where, f"'feature_scale' must be positive, got {scale.tolist()}")
    coefficients = doc.get("coefficients")
    if not isinstance(coefficients, dict):
        raise GazeError(where, "'coefficients' must be an object with 'x' and 'y' lists of 6 numbers")
    rows = np.stack([_numbers(coefficients, axis, len(TERMS), f"{where}: coefficients") for axis in ("x", "y")])
    counts = [doc.get(k, 0) for k in ("targets", "samples")]
    residual = doc.get("residual_rms", 0.0)
    if not all(isinstance(c, int) and c >= 0 for c in counts) or not isinstance(residual, (int, float)):
        raise GazeError(where, "'targets'/'samples' must be counts and 'residual_rms' a number")
    return Calibration(
        mean,
        scale,
        rows,
        counts[0],
        counts[1],
        float(residual),
        _reference(doc.get("face_reference"), f"{where}: face_reference"),
    )


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration JSON file (``GazeError`` naming the file when missing or malformed)."""
    path = Path(path)
    if not path.is_file():
        raise GazeError(str(path), "calibration file not found")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise GazeError(str(path), f"not a JSON calibration file ({exc})") from None
    return calibration_from_json(doc, str(path))
