"""Ray tracing of the secondary effects (shadows, reflections, refractions) for a
list of pixels: ``Tracer`` with its ``TraceSettings`` and ``RayCounts``."""

from .kernels import TraceVariant
from .tracer import RayCounts, Tracer, TraceSettings, trace_variant

__all__ = ["RayCounts", "TraceSettings", "TraceVariant", "Tracer", "trace_variant"]
