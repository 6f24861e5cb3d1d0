"""The kernels build for CUDA wherever NVRTC is installed, a GPU or not: the native C++ the
CPU loops share with the per-pixel funcs (the resolve's, the surface pass's, the lights' and
the tally's loops, the tone map, FXAA's contrast test, the camera ray, the exact hit, the
texture taps, the BRDF and the lights) compiles to PTX for
sm_90 (an H100/H200), so a machine with a GPU does not meet a compile error first.
Skipped where Warp finds no NVRTC."""

from __future__ import annotations

import pytest
import warp as wp

import warp_hybrid.lighting.deferred as deferred
import warp_hybrid.post.kernels as post_kernels
import warp_hybrid.primary.kernels as primary_kernels
import warp_hybrid.trace.tally as tally
from warp_hybrid.core.features import SceneFeatures
from warp_hybrid.trace.path import path_kernel
from warp_hybrid.trace.shadows import shadow_kernel
from warp_hybrid.trace.variant import TraceVariant

ARCH = 90


_VARIANT = TraceVariant.for_scene(SceneFeatures.all(), shadow_samples=4, wide_bvh=False)
#: What to build: the modules that hold the project's native loops (every other module
#: takes its native C++, the camera ray for one, from the same sources; the lighting
#: pass's largest variant too), and the tracer's
#: largest variant (every effect, as CUDA runs it: Warp's own BVH queries).
MODULES = {
    "primary": primary_kernels,
    "tally": tally,
    "post": post_kernels,
    "lighting": deferred,
    "lighting with shadow maps and a probe": deferred.shade_kernel(True, True).module,
    "path": path_kernel(_VARIANT).module,
    "shadows": shadow_kernel(*_VARIANT.shadow_key()).module,
}


@pytest.mark.parametrize("name", list(MODULES))
def test_kernels_compile_for_cuda(name: str, tmp_path) -> None:
    if ARCH not in wp.get_cuda_supported_archs():
        pytest.skip(f"NVRTC cannot build for sm_{ARCH} here")
    built = wp.compile_aot_module(MODULES[name], arch=ARCH, module_dir=tmp_path, use_ptx=True)
    assert built and all(path.stat().st_size > 0 for path in built)
