"""Spans of image rows, ``(first, stop)`` with ``first <= stop`` (empty when equal): what
the passes that redraw only part of a frame (compose, post) say about which rows changed.
"""

from __future__ import annotations

RowSpan = tuple[int, int]

#: No rows.
NO_ROWS: RowSpan = (0, 0)


def span_union(a: RowSpan | None, b: RowSpan | None) -> RowSpan | None:
    """The smallest span holding both ``a`` and ``b`` (None, "any row", absorbs)."""
    if a is None or b is None:
        return None
    if a[0] >= a[1]:
        return b
    if b[0] >= b[1]:
        return a
    return min(a[0], b[0]), max(a[1], b[1])


def span_minus(a: RowSpan, b: RowSpan) -> list[RowSpan]:
    """The rows of ``a`` outside ``b``: at most two non-empty spans, in order."""
    if b[0] >= b[1]:
        return [a] if a[0] < a[1] else []
    parts = [(a[0], min(a[1], b[0])), (max(a[0], b[1]), a[1])]
    return [p for p in parts if p[0] < p[1]]


def span_grow(a: RowSpan, rows: int, height: int) -> RowSpan:
    """``a`` widened by ``rows`` on both sides, clipped to ``0 .. height`` (an empty span
    stays empty)."""
    if a[0] >= a[1]:
        return NO_ROWS
    return max(0, a[0] - rows), min(height, a[1] + rows)


def span_clip(a: RowSpan, height: int) -> RowSpan:
    """``a`` clipped to ``0 .. height`` (empty where nothing is left)."""
    first, stop = max(0, min(a[0], height)), max(0, min(a[1], height))
    return (first, stop) if first < stop else NO_ROWS
