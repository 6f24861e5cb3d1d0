"""Outputs are written atomically and PNGs keep row 0 at the top, RGB order."""

from __future__ import annotations

import json
import os
import stat

import cv2
import numpy as np
import pytest

from warp_hybrid.errors import WarpHybridError
from warp_hybrid.output import atomic_write_bytes, write_aovs, write_json, write_png


def test_png_row_zero_is_top_and_rgb(tmp_path) -> None:
    img = np.zeros((4, 6, 3), np.uint8)
    img[0, 0] = (255, 0, 0)  # top-left red
    img[3, 5] = (0, 0, 255)  # bottom-right blue
    path = tmp_path / "a.png"
    write_png(path, img)
    back = cv2.imread(str(path))[..., ::-1]
    np.testing.assert_array_equal(back, img)


def test_failed_write_leaves_nothing(tmp_path) -> None:
    target = tmp_path / "out.bin"
    with pytest.raises(TypeError):
        atomic_write_bytes(target, object())  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_existing_file_survives_failed_overwrite(tmp_path) -> None:
    target = tmp_path / "x.png"
    write_png(target, np.zeros((2, 2, 3), np.uint8))
    before = target.read_bytes()
    with pytest.raises(ValueError):
        write_png(target, np.zeros((2, 2), np.float32))
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"]


def test_png_extension_enforced(tmp_path) -> None:
    with pytest.raises(WarpHybridError, match="must be a .png"):
        write_png(tmp_path / "x.jpg", np.zeros((2, 2, 3), np.uint8))


def test_aovs_and_json(tmp_path) -> None:
    depth = np.array([[1.0, np.inf]], np.float32)
    paths = write_aovs(tmp_path / "aov", {"depth": depth})
    assert [p.name for p in paths] == ["depth.npy"]
    np.testing.assert_array_equal(np.load(paths[0]), depth)
    write_json(tmp_path / "s.json", {"a": float("inf"), "b": [np.float32(1.5)]})
    assert json.loads((tmp_path / "s.json").read_text()) == {"a": None, "b": [1.5]}


def test_new_file_gets_umask_mode_and_folder_is_created(tmp_path) -> None:
    target = tmp_path / "new_dir" / "x.png"
    old = os.umask(0o022)
    try:
        write_png(target, np.zeros((2, 2, 3), np.uint8))
    finally:
        os.umask(old)
    assert stat.S_IMODE(target.stat().st_mode) == 0o644


def test_overwrite_keeps_the_mode_and_errors_name_the_file(tmp_path) -> None:
    target = tmp_path / "s.json"
    target.write_text("{}")
    target.chmod(0o600)
    write_json(target, {"a": 1})
    assert stat.S_IMODE(target.stat().st_mode) == 0o600 and json.loads(target.read_text()) == {"a": 1}
    (tmp_path / "taken.png").mkdir()
    with pytest.raises(WarpHybridError, match="taken.png: output path is a folder"):
        write_png(tmp_path / "taken.png", np.zeros((2, 2, 3), np.uint8))
