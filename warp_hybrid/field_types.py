"""Type checks for settings dataclasses at the library boundary.

A settings object holds what a caller typed (``RenderSettings(width="640")``); before
any of it reaches a kernel or Warp's code generator, each field is checked against its
annotation and a wrong one is an ``ArgumentTypeError`` naming the field.  Annotations
understood: ``int`` (any integral number but a bool), ``float`` (any real number but a
bool), ``str``, ``bool``, and each of them ``| None``.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from numbers import Integral, Real

from .errors import ArgumentTypeError

_WHAT = {int: "an integer", float: "a number", str: "a string", bool: "True or False"}


def _fits(value: object, kind: type) -> bool:
    if kind is bool:
        return isinstance(value, bool)
    if isinstance(value, bool):
        return False
    if kind is int:
        return isinstance(value, Integral)
    if kind is float:
        return isinstance(value, Real)
    return isinstance(value, kind)


def check_field_types(instance: object) -> None:
    """Raise ``ArgumentTypeError`` naming the first field of the dataclass ``instance``
    whose value does not fit its annotation (see the module docs)."""
    owner = type(instance).__name__
    hints = typing.get_type_hints(type(instance))
    for f in dataclasses.fields(instance):  # type: ignore[arg-type]
        hint = hints[f.name]
        kinds = typing.get_args(hint) if isinstance(hint, types.UnionType) else (hint,)
        value = getattr(instance, f.name)
        if value is None and type(None) in kinds:
            continue
        wanted = [k for k in kinds if k is not type(None)]
        if not any(_fits(value, k) for k in wanted):
            what = " or ".join(_WHAT.get(k, k.__name__) for k in wanted) + (" or None" if type(None) in kinds else "")
            raise ArgumentTypeError(f"{owner}.{f.name} must be {what}, got {type(value).__name__} {value!r}")
