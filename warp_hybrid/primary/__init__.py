"""Primary visibility: the G-buffer pass, by rasterization or by ray casting
(``base.PrimaryVisibility`` and its two implementations)."""

from .base import PrimaryVisibility
from .rasterizer import Rasterizer
from .raycast import RayCaster

__all__ = ["PrimaryVisibility", "RayCaster", "Rasterizer"]
