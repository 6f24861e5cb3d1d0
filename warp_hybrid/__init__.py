"""warp-hybrid: an adaptive hybrid raster / ray-tracing renderer on NVIDIA Warp.

The library API in one place: open a scene, make a renderer for a device and a size,
render frames, read their AOVs and statistics.
"""

from .errors import RenderSettingsError, SceneError, WarpHybridError
from .output import write_aovs, write_json, write_png
from .renderer import Frame, Renderer, RenderSettings
from .runtime import init_warp
from .scene.open import open_scene_source
from .scene.usd.loader import load_scene

__all__ = [
    "Frame",
    "RenderSettings",
    "RenderSettingsError",
    "Renderer",
    "SceneError",
    "WarpHybridError",
    "init_warp",
    "load_scene",
    "open_scene_source",
    "write_aovs",
    "write_json",
    "write_png",
]
