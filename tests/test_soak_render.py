"""A short soak (``scripts/soak_render.py``): 200 CLI renders and refusals in this
process leave the resident set flat (the 1,000-render run is the script's default)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))

from soak_render import soak  # noqa: E402


@pytest.mark.soak
def test_many_renders_keep_memory_flat() -> None:
    result = soak(200, "16x12", settle=100)
    assert result["renders"] == 200
    assert result["growth_mb"] < 12.0, result  # 3.6 MB measured; a 60 kB-a-round leak would show
