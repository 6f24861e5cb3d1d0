"""The configurations a sweep compares: hybrid at the gaze, and what a user would pick
instead at matching cost.

* ``raster``: deferred shading only.
* ``hybrid``: ray traced inside a window of ``fraction`` of the screen at the gaze.
* ``hybrid_centre``: the same window fixed at the screen centre whatever the gaze (what
  the gaze is worth).
* ``hybrid_fovea``: ``hybrid`` with ``spp`` samples per pixel inside the window
  (``--fovea-spp``: what the periphery saves, spent on the fovea).
* ``full``: every pixel ray traced, one sample per pixel.
* ``full_lowres``: full ray tracing at ``scale`` times the resolution in each direction,
  its linear radiance upscaled bilinearly to the screen before exposure and tone
  mapping (uniform low-resolution ray tracing; ``fraction`` is ``scale**2``, the share
  of the pixels traced).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

METHODS = ("raster", "hybrid", "hybrid_centre", "hybrid_fovea", "full", "full_lowres")

#: Window fractions from 2% to 100%.
DEFAULT_FRACTIONS = (0.02, 0.05, 0.1, 0.25, 0.5, 1.0)
#: Linear scales of the low-resolution full ray tracing.
DEFAULT_LOWRES_SCALES = (0.25, 0.5)


@dataclass(frozen=True)
class Config:
    """One configuration: its ``method`` (``METHODS``), the window share (hybrid) or the
    share of pixels traced (low-res), the low-res linear ``scale``, and the window's
    samples per pixel (``hybrid_fovea``)."""

    method: str
    fraction: float
    scale: float = 1.0
    spp: int = 1

    @property
    def label(self) -> str:
        """A short name for tables and legends."""
        if self.method in ("hybrid", "hybrid_centre"):
            return f"{self.method} {self.fraction:.0%}"
        if self.method == "hybrid_fovea":
            return f"hybrid {self.fraction:.0%} x{self.spp} spp"
        if self.method == "full_lowres":
            return f"full at {self.scale:g}x"
        return self.method


def sweep_configs(
    fractions: Sequence[float] = DEFAULT_FRACTIONS,
    lowres_scales: Sequence[float] = DEFAULT_LOWRES_SCALES,
    fovea_spp: int = 1,
) -> list[Config]:
    """Every configuration of a sweep: raster, hybrid and centre-fixed hybrid at each
    fraction, hybrid with ``fovea_spp`` window samples at each fraction (when above 1),
    full at one sample, and full at each low-res scale."""
    for f in fractions:
        if not 0.0 < f <= 1.0:
            raise ValueError(f"window fractions must be in (0, 1], got {f}")
    for s in lowres_scales:
        if not 0.0 < s < 1.0:
            raise ValueError(f"low-res scales must be in (0, 1), got {s}")
    configs = [Config("raster", 0.0)]
    configs += [Config("hybrid", f) for f in fractions]
    configs += [Config("hybrid_centre", f) for f in fractions]
    if fovea_spp > 1:
        configs += [Config("hybrid_fovea", f, spp=fovea_spp) for f in fractions]
    configs.append(Config("full", 1.0))
    configs += [Config("full_lowres", s * s, s) for s in lowres_scales]
    return configs
