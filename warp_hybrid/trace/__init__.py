"""Secondary rays with Warp's mesh BVH: shadows (``shadows``), what surfaces do to rays
(``optics``), the reflection/refraction path (``path``), shared ray helpers (``rays``,
``offset``), the shadow BVHs (``occluders``), the compiled variant (``variant``), the ray tally by
screen tile (``tally``) and the pass that launches them (``tracer``)."""

from .tally import TILE_PX, RayCounts, RayTally, TileCounts
from .tracer import Tracer, TraceSettings
from .variant import TraceVariant

__all__ = ["TILE_PX", "RayCounts", "RayTally", "TileCounts", "TraceSettings", "TraceVariant", "Tracer"]
