"""Row spans (``core.rows``): union, difference, growth and clipping, checked row by row
against plain sets."""

from __future__ import annotations

import itertools

from warp_hybrid.core.rows import NO_ROWS, span_clip, span_grow, span_minus, span_union

SPANS = [(a, b) for a, b in itertools.product(range(0, 9, 2), repeat=2) if a <= b]


def _rows(span):
    return set(range(*span))


def test_union_holds_both_and_none_absorbs():
    for a, b in itertools.product(SPANS, repeat=2):
        u = span_union(a, b)
        assert _rows(a) | _rows(b) <= _rows(u)
        if a[0] < a[1] and b[0] < b[1]:
            assert u == (min(a[0], b[0]), max(a[1], b[1]))
        else:  # an empty span adds nothing
            assert _rows(u) == _rows(a) | _rows(b)
    assert span_union(None, (1, 2)) is None and span_union((1, 2), None) is None


def test_minus_is_the_set_difference():
    for a, b in itertools.product(SPANS, repeat=2):
        parts = span_minus(a, b)
        assert all(p[0] < p[1] for p in parts)
        covered = [r for p in parts for r in range(*p)]
        assert sorted(covered) == sorted(_rows(a) - _rows(b)) and len(covered) == len(set(covered))


def test_grow_and_clip():
    assert span_grow((10, 12), 3, 20) == (7, 15)
    assert span_grow((1, 19), 3, 20) == (0, 20)
    assert span_grow((5, 5), 3, 20) == NO_ROWS
    assert span_clip((-4, 7), 5) == (0, 5)
    assert span_clip((6, 9), 5) == NO_ROWS
