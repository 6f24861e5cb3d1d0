"""Composition of the traced focus layer over the raster image."""

from .blend import Compositor

__all__ = ["Compositor"]
