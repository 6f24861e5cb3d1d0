"""CPU and CUDA agree (issue 10, case 10): the shipped hard-case scenes rendered on both
devices pass the invariance rule; skipped where no CUDA device exists."""

from __future__ import annotations

import pytest
import warp as wp
from hard_kit import SCENES, render_file

from warp_hybrid.scene.invariance import compare


@pytest.mark.parametrize("name", ["cornell_glass", "hard_cases"])
def test_cpu_and_cuda_agree(name):
    if not wp.is_cuda_available():
        pytest.skip("no CUDA device")
    cpu = render_file(SCENES / f"{name}.usda", "cpu", 96, 72)
    cuda = render_file(SCENES / f"{name}.usda", "cuda:0", 96, 72)
    a = compare(cpu.view, cuda.view)
    assert a.all >= 0.99 and a.interior <= 0.002 * a.pixels, a
