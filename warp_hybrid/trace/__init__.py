"""Secondary rays with Warp's mesh BVH: shadows (``shadows``), what surfaces do to rays
(``optics``), the reflection/refraction path (``path``), shared ray helpers (``rays``,
``offset``), the shadow BVHs (``occluders``), the compiled variant (``variant``) and the
pass that launches them (``tracer``)."""

from .tracer import PendingRayCounts, RayCounts, Tracer, TraceSettings
from .variant import TraceVariant

__all__ = ["PendingRayCounts", "RayCounts", "TraceSettings", "TraceVariant", "Tracer"]
