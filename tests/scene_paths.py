"""Where the tests find the shared real scenes (a uniquely named module, so test files
can import it at collection time; ``conftest`` names are ambiguous across folders)."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def shared_scenes_dir() -> Path:
    """``WARP_HYBRID_SHARED_SCENES`` or ``../shared/scenes`` next to the checkout."""
    return Path(os.environ.get("WARP_HYBRID_SHARED_SCENES", ROOT.parent / "shared" / "scenes"))
