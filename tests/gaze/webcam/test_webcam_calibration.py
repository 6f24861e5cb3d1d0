"""Calibration: exact recovery of a quadratic, settling, JSON round trip, bad files and targets."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gaze.errors import GazeError
from gaze.webcam.calibration import (
    TargetSchedule,
    design_matrix,
    fit_calibration,
    fit_polynomial,
    load_calibration,
    read_targets,
)
from gaze.webcam.face import Box, FaceReference
from gaze.webcam.synthetic import calibration_targets

#: A known feature -> screen quadratic (rows x, y; terms 1, u, v, u^2, uv, v^2 on raw features).
TRUE = np.array([[0.5, 9.0, 0.4, 30.0, -12.0, 5.0], [0.5, -0.3, 11.0, 4.0, 8.0, -25.0]])


def true_screen(features: np.ndarray) -> np.ndarray:
    """Screen points of the known quadratic."""
    return design_matrix(features[:, 0], features[:, 1]) @ TRUE.T


def nine_features() -> np.ndarray:
    """Features of a 3x3 raster, slightly sheared (not a product grid)."""
    u, v = np.meshgrid([-0.03, 0.0, 0.03], [-0.02, 0.0, 0.02])
    return np.stack([u.ravel() + 0.1 * v.ravel(), v.ravel() + 0.003 * u.ravel() ** 2 * 100], axis=1)


def test_polynomial_recovers_a_known_quadratic_exactly() -> None:
    features = nine_features()
    calibration = fit_polynomial(features, true_screen(features))
    probe = np.random.default_rng(1).uniform(-0.04, 0.04, size=(50, 2))
    np.testing.assert_allclose(calibration.apply(probe), true_screen(probe), atol=1e-10)
    assert calibration.residual_rms < 1e-12 and calibration.targets == 9


def test_fit_ignores_the_first_0_2_s_after_each_target_change_and_invalid_frames() -> None:
    targets = calibration_targets(dwell_s=0.5)
    features_at_target = nine_features()
    screen = true_screen(features_at_target)
    # Make the quadratic land exactly on the targets: the targets are its images here.
    schedule = TargetSchedule(targets[:, 0], screen[:, 0], screen[:, 1])
    t = np.arange(135) / 30.0
    index = schedule.index_at(t)
    features = features_at_target[index].copy()
    moving = (t - schedule.t[index]) < 0.2 - 1e-6
    features[moving] = 1.0  # the eye in flight: far off, must be ignored
    valid = np.ones(len(t), bool)
    valid[::7] = False
    features[~valid] = -5.0  # lost frames: garbage, must be ignored
    calibration = fit_calibration(t, features, valid, schedule)
    assert calibration.targets == 9
    assert calibration.samples == int((~moving & valid).sum())
    probe = np.random.default_rng(2).uniform(-0.03, 0.03, size=(20, 2))
    np.testing.assert_allclose(calibration.apply(probe), true_screen(probe), atol=1e-9)


def test_settled_counts_frames_from_exactly_0_2_s() -> None:
    schedule = TargetSchedule(np.array([0.0, 0.5]), np.array([0.1, 0.9]), np.array([0.1, 0.9]))
    t = np.arange(30) / 30.0
    settled = schedule.settled(t)
    assert settled.tolist() == [k % 15 >= 6 for k in range(30)]


def test_too_few_targets_is_an_error_naming_the_source() -> None:
    schedule = TargetSchedule(np.array([0.0, 1.0]), np.array([0.1, 0.9]), np.array([0.1, 0.9]))
    t = np.arange(60) / 30.0
    with pytest.raises(GazeError, match="clip.avi.*only 2 of 2 targets"):
        fit_calibration(t, np.zeros((60, 2)), np.ones(60, bool), schedule, where="clip.avi")


def reference() -> FaceReference:
    """A small face reference with a textured template."""
    template = (np.arange(12 * 10).reshape(12, 10) * 2 % 256).astype(np.uint8)
    return FaceReference(template, Box(-5.0, -40.0, 60.0, 60.0), np.array([[3.5, -20.0], [40.25, -19.0]]))


def test_json_round_trip(tmp_path: Path) -> None:
    features = nine_features()
    calibration = fit_polynomial(features, true_screen(features), samples=81, reference=reference())
    path = tmp_path / "calib.json"
    calibration.save(path)
    doc = json.loads(path.read_text())
    assert doc["schema"] == "warp-hybrid-gaze-calibration" and doc["version"] == 1
    assert len(doc["coefficients"]["x"]) == 6 and len(doc["coefficients"]["y"]) == 6
    loaded = load_calibration(path)
    np.testing.assert_array_equal(loaded.coefficients, calibration.coefficients)
    np.testing.assert_array_equal(loaded.feature_mean, calibration.feature_mean)
    np.testing.assert_array_equal(loaded.feature_scale, calibration.feature_scale)
    assert (loaded.targets, loaded.samples) == (9, 81)
    assert loaded.reference is not None
    np.testing.assert_array_equal(loaded.reference.template, reference().template)
    np.testing.assert_array_equal(loaded.reference.eyes, reference().eyes)
    assert loaded.reference.face == reference().face
    np.testing.assert_array_equal(loaded.apply(features), calibration.apply(features))


def good_doc() -> dict:
    """A valid calibration document without a face reference."""
    features = nine_features()
    return fit_polynomial(features, true_screen(features)).to_json()


@pytest.mark.parametrize(
    "change, problem",
    [
        (lambda d: d["coefficients"].update(x=[1.0, 2.0, 3.0]), "'x' must be a list of 6"),
        (lambda d: d.update(feature_mean=[0.0]), "'feature_mean' must be a list of 2"),
        (lambda d: d.update(feature_scale=[1.0, 0.0]), "'feature_scale' must be positive"),
        (lambda d: d.update(version=7), "unsupported calibration version 7"),
        (lambda d: d.update(schema="something"), "not a gaze calibration"),
        (lambda d: d.update(coefficients=[[0] * 6, [0] * 6]), "'coefficients' must be an object"),
        (lambda d: d.update(face_reference={"template_png": "!!", "face_box": [0, 0, 1, 1], "eyes": []}), "not base64"),
    ],
)
def test_bad_calibration_file_names_the_file(tmp_path: Path, change, problem: str) -> None:
    doc = good_doc()
    change(doc)
    path = tmp_path / "bad_calib.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(GazeError, match=problem) as info:
        load_calibration(path)
    assert str(path) in str(info.value)


def test_calibration_file_that_is_not_json_or_missing(tmp_path: Path) -> None:
    path = tmp_path / "calib.json"
    path.write_text("{not json")
    with pytest.raises(GazeError, match=f"{path}: not a JSON calibration file"):
        load_calibration(path)
    with pytest.raises(GazeError, match="calibration file not found"):
        load_calibration(tmp_path / "absent.json")


def test_targets_file(tmp_path: Path) -> None:
    path = tmp_path / "targets.csv"
    path.write_text("t,x,y\n0,0.1,0.1\n0.5,0.9,0.1\n")
    schedule = read_targets(path)
    assert schedule.index_at(np.array([-0.1, 0.0, 0.49, 0.5, 9.0])).tolist() == [-1, 0, 0, 1, 1]
    path.write_text("t,x,y\n0,0.1,0.1\n0,0.9,0.1\n")
    with pytest.raises(GazeError, match="targets.csv: line 3: times must increase"):
        read_targets(path)
    path.write_text("t,x,y\n0,0.1,1.5\n")
    with pytest.raises(GazeError, match="line 2: target .* outside"):
        read_targets(path)
    path.write_text("time,x,y\n0,0.1,0.5\n")
    with pytest.raises(GazeError, match="unknown columns"):
        read_targets(path)
