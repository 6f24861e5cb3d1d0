"""Image error against a reference: FLIP (NVIDIA's evaluator) on the tone-mapped sRGB
frames, PSNR on linear radiance, and FLIP weighted by the eye's acuity around the gaze.

Pure numpy and ``flip_evaluator``; no Warp kernels.
"""

from .flip import flip_map
from .foveation import MAR_FOVEA_DEG, MAR_SLOPE, acuity_weight, foveated_mean
from .psnr import psnr
from .report import ErrorReport, evaluate, layout_mask
from .viewing import ViewingSetup

__all__ = [
    "MAR_FOVEA_DEG",
    "MAR_SLOPE",
    "ErrorReport",
    "ViewingSetup",
    "acuity_weight",
    "evaluate",
    "flip_map",
    "foveated_mean",
    "layout_mask",
    "psnr",
]
