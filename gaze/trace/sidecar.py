"""Metadata files that exports put beside the gaze file, read for the pixel size of pixel
coordinates: Pupil Cloud's ``info.json`` (which device: Neon or Invisible) and Pupil
Player's ``iMotions_info.csv`` (the world camera's resolution)."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

#: Scene camera pixel size of each Pupil Labs device, and the ``info.json`` key only its recordings have.
SCENE_CAMERAS = {"Neon": (1600, 1200), "Invisible": (1088, 1080)}
DEVICE_KEYS = {"module_serial_number": "Neon", "glasses_serial_number": "Invisible"}
INFO_JSON = "info.json"
IMOTIONS_INFO = "iMotions_info.csv"
_SIZE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")


def parse_size(text: str) -> tuple[int, int] | None:
    """``'1280x720'`` (or ``'1920 x 1080'``) as positive (width, height); None when it is not one."""
    match = _SIZE.match(text)
    if match is None:
        return None
    w, h = int(match.group(1)), int(match.group(2))
    return (w, h) if w > 0 and h > 0 else None


def pupil_cloud_device(folder: Path) -> str | None:
    """The device (``'Neon'`` or ``'Invisible'``) that ``info.json`` in ``folder`` names, or None
    when the file is absent, unreadable or names neither."""
    try:
        info = json.loads((folder / INFO_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(info, dict):
        return None
    return next((device for key, device in DEVICE_KEYS.items() if key in info), None)


def imotions_world_size(folder: Path) -> tuple[int, int] | None:
    """The ``World Camera Resolution`` in ``iMotions_info.csv`` (a copy of Pupil's ``info.csv``,
    rows ``key,value``) in ``folder``, or None when absent or unreadable."""
    try:
        rows = list(csv.reader((folder / IMOTIONS_INFO).read_text(encoding="utf-8-sig").splitlines()))
    except (OSError, ValueError, csv.Error):
        return None
    for row in rows:
        if len(row) >= 2 and row[0].strip().lower() == "world camera resolution":
            return parse_size(row[1])
    return None
