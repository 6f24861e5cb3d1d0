"""Warp start-up: where compiled kernels are cached, quiet initialisation, devices."""

from __future__ import annotations

import os

import warp as wp

_initialised = False


def init_warp(kernel_cache_dir: str | None = None) -> None:
    """Initialise Warp once, quietly, with the kernel cache in ``kernel_cache_dir``.

    The cache directory comes from the argument, else ``WARP_HYBRID_KERNEL_CACHE``,
    else Warp's default (``~/.cache/warp``).  Tests point it inside ``build/``.
    """
    global _initialised
    if _initialised:
        return
    cache = kernel_cache_dir or os.environ.get("WARP_HYBRID_KERNEL_CACHE")
    if cache:
        wp.config.kernel_cache_dir = os.path.abspath(cache)
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    _initialised = True


def resolve_device(name: str | None) -> wp.context.Device:
    """The Warp device called ``name`` ('cpu', 'cuda:0', or None for 'cpu'), with a
    clear error when it does not exist on this machine."""
    from .errors import RenderSettingsError

    init_warp()
    name = name or "cpu"
    try:
        return wp.get_device(name)
    except Exception as exc:  # Warp raises RuntimeError/ValueError depending on version
        available = ", ".join(d.alias for d in wp.get_devices())
        raise RenderSettingsError(f"device {name!r} is not available here (available: {available})") from exc
