"""The scene on the device: upload (``upload.DeviceScene``), the dome's ambient data
(``dome``), texture mip chains (``mipmaps``) and the ``@wp.func`` evaluation every pass
shares (``surface``: materials and textures at a hit; ``environment``: the dome)."""

from .upload import DeviceScene

__all__ = ["DeviceScene"]
