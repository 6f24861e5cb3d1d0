"""The scene on the device: upload (``upload.DeviceScene``), the dome's ambient data
(``dome``), texture mip chains (``mipmaps``), the CPU's 4-wide BVH copies (``wide_bvh``) and
the ``@wp.func`` evaluation every pass shares (``surface``: materials and textures at a hit;
``environment``: the dome)."""

from .upload import DeviceScene

__all__ = ["DeviceScene"]
