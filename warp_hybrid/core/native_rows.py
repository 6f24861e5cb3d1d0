"""C++ pieces the native row loops share (the post stage's tone map, ``post/kernels.py``,
and FXAA's contrast test, ``post/aa.py``; the raster resolve and the surface pass's
footprints, ``primary/kernels.py``; the lighting pass's direct light,
``lighting/direct_rows.py``): how many pixels a loop takes at a time, and a pointer to
one row of an array."""

from __future__ import annotations

#: Pixels a row loop takes at a time on the CPU (its scratch arrays live on the stack).
CHUNK_CPU = 64

#: C++: the loop's ``CHUNK``, ``CHUNK_CPU`` on the CPU and one on CUDA (where a launch item
#: is one pixel).
CHUNK_CPP = f"""
#if defined(__CUDA_ARCH__)
constexpr int CHUNK = 1;
#else
constexpr int CHUNK = {CHUNK_CPU};
#endif
"""


def row_cpp(array: str, row: str, ctype: str, const: bool = True) -> str:
    """C++ expression: a pointer to ``ctype`` at the start of row ``row`` of the Warp array
    named ``array`` (a step of its first stride in bytes; the row's own elements must be
    contiguous)."""
    qualifier = "const " if const else ""
    return f"(({qualifier}{ctype}*)(({qualifier}char*){array}.data + (size_t)({row}) * {array}.strides[0]))"
