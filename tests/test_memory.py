"""The memory estimate (``warp_hybrid.memory``) against the arrays a renderer really
holds: never below them, at most 1.5 times them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from warp_hybrid import Renderer, RenderSettings, open_scene_source
from warp_hybrid.memory import frame_bytes

CORNELL = Path(__file__).resolve().parents[1] / "scenes" / "cornell_glass.usda"


def _ours(obj: object) -> bool:
    """An object of this project (a pass, a buffer set, a Warp struct of ours) whose
    attributes may hold arrays; other libraries' objects are not walked."""
    return type(obj).__module__.startswith("warp_hybrid") or type(type(obj)).__module__.startswith("warp")


def _array_bytes(root: object) -> dict[int, int]:
    """Bytes of every distinct Warp array reachable from ``root``'s attributes, by pointer."""
    seen, found, stack = set(), {}, [root]
    while stack:
        obj = stack.pop()
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        if isinstance(obj, wp.array):
            ptr = getattr(obj, "ptr", None)  # a kernel-local fixedarray has none
            if ptr is not None:
                found[ptr] = obj.size * wp.types.type_size_in_bytes(obj.dtype)
        elif isinstance(obj, dict):
            stack.extend(obj.values())
        elif isinstance(obj, (list, tuple, set)):
            stack.extend(obj)
        elif _ours(obj) and hasattr(obj, "__dict__") and not isinstance(obj, (type, np.ndarray)):
            stack.extend(vars(obj).values())
    return found


@pytest.mark.parametrize(
    "mode, threads, spp, fovea_spp, reuse, blended",
    [
        ("raster", 1, 1, 1, False, False),
        ("hybrid", 2, 1, 1, False, False),
        ("full", 2, 1, 1, False, False),
        ("full", 1, 2, 1, False, False),
        ("hybrid", 1, 1, 2, False, False),
        ("hybrid", 1, 1, 1, True, False),
        ("raster", 2, 1, 1, False, True),
    ],
)
def test_frame_estimate_covers_the_frame_buffers(
    mode: str, threads: int, spp: int, fovea_spp: int, reuse: bool, blended: bool
) -> None:
    """Per pixel: the growth of the arrays held from 64x48 to 128x96 against the estimate's
    (``reuse``: temporal reuse's history; ``blended``: the glass made alpha-blended, so the
    layer behind it is drawn)."""
    scene = open_scene_source(CORNELL).scene_at(None)
    if blended:
        glass = [dataclasses.replace(m, alpha_blended=m.is_transmissive) for m in scene.materials]
        scene = dataclasses.replace(scene, materials=glass)
    held = []
    for w, h in ((64, 48), (128, 96)):
        settings = RenderSettings(
            width=w, height=h, mode=mode, threads=threads, spp=spp, fovea_spp=fovea_spp, reuse=reuse
        )
        with Renderer(scene, settings) as renderer:
            renderer.render(scene.cameras[0])
            arrays = _array_bytes(renderer)
            on_scene = _array_bytes(renderer.device_scene)
            held.append(sum(n for ptr, n in arrays.items() if ptr not in on_scene))
    grown = held[1] - held[0]
    lights = len(scene.lights)
    extra = (blended, reuse)
    estimated = frame_bytes(128, 96, lights, threads, spp, fovea_spp, *extra) - frame_bytes(
        64, 48, lights, threads, spp, fovea_spp, *extra
    )
    assert grown <= estimated <= 1.5 * grown, (grown / (128 * 96 - 64 * 48), estimated / (128 * 96 - 64 * 48))


def test_shadow_maps_are_in_the_estimate() -> None:
    """The maps add every face of every light (a cube map each at most), the target a
    face is drawn into with one key slice per thread, and the projected points; off,
    nothing."""
    from warp_hybrid.memory import shadow_map_bytes

    assert shadow_map_bytes(0, 3, 2, 1000) == 0
    n = 512
    assert shadow_map_bytes(n, 2, 2, 1000) == 2 * 6 * 4 * n * n + (12 + 2 * 8) * n * n + 24 * 1000
