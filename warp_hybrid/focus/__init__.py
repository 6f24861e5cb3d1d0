"""The focus window: where the viewer looks, which pixels to trace, how to blend them."""

from .region import FocusRegion, FocusRegionBuilder
from .window import SHAPES, FocusWindow, WindowLayout

__all__ = ["SHAPES", "FocusRegion", "FocusRegionBuilder", "FocusWindow", "WindowLayout"]
