"""A JSON value checked against the annotation that declares it, for the documents
declared once as dataclasses: a calibration record's sections (``ogacq.record.declared``)
and a session's records (``ogacq.session.records``).

The annotation says the JSON: ``str``, ``bool``, ``int`` (64 bits at most: a longer
one overflows every float it meets), ``float`` (a number, an int read as written so
``1`` stays ``1``), :data:`Finite` (a number that is one), ``Any`` (kept as written),
``X | None`` (null allowed), ``tuple[X, ...]`` (a list), ``tuple[X, Y, Z]`` (a list of
three), ``dict[str, X]`` (an object, its keys chosen by the writer); any other class
is read by the caller's ``nested``. A value of another type is the caller's ``error``
naming the key (``compensation.tables[1].files``, ``averaged``).
"""

from __future__ import annotations

import math
import types
import typing
from collections.abc import Callable, Mapping
from typing import Annotated, Any

__all__ = ["Finite", "checked", "shown"]

FINITE = "finite"
Finite = Annotated[float, FINITE]

Fail = Callable[[str, str], Exception]  # (key, what is wrong) -> the error to raise
Nested = Callable[[Any, Any, str], Any]  # (class, value, key) -> the value read

# The JSON type each scalar annotation takes (a bool is not a number: JSON's true is
# not 1 to a reader).
SCALARS: dict[type, tuple[tuple[type, ...], str]] = {
    str: ((str,), "text"), bool: ((bool,), "true or false"), int: ((int,), "a whole number"),
    float: ((int, float), "a number")}


def checked(hint: Any, value: Any, key: str, error: Fail, nested: Nested | None = None) -> Any:
    """``value`` read as ``hint`` says (a list as a tuple), or ``error`` naming ``key``."""
    if hint is Any:
        return value
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is Annotated:
        read = checked(args[0], value, key, error, nested)
        if FINITE in args[1:] and not math.isfinite(read):
            raise error(key, f"must be a finite number, got {shown(value)}")
        return read
    if origin in (types.UnionType, typing.Union):
        if value is None and type(None) in args:
            return None
        (inner,) = (a for a in args if a is not type(None))
        return checked(inner, value, key, error, nested)
    if origin is tuple:
        if not isinstance(value, list):
            raise error(key, f"must be a list, got {shown(value)}")
        each = args[:1] * len(value) if args[1:] == (...,) else args
        if len(each) != len(value):
            raise error(key, f"must be a list of {len(each)}, got {shown(value)}")
        return tuple(checked(h, v, f"{key}[{i}]", error, nested)
                     for i, (h, v) in enumerate(zip(each, value, strict=True)))
    if origin is dict:
        if not isinstance(value, Mapping):
            raise error(key, f"must be an object, got {shown(value)}")
        return {str(k): checked(args[1], v, f"{key}.{k}", error, nested)
                for k, v in value.items()}
    if hint in SCALARS:
        return _scalar(hint, value, key, error)
    assert nested is not None, f"{key}: {hint} is declared with no reader"
    return nested(hint, value, key)


def _scalar(hint: type, value: Any, key: str, error: Fail) -> Any:
    expected, what = SCALARS[hint]
    if isinstance(value, expected) and (hint is bool or not isinstance(value, bool)) \
            and not (isinstance(value, int) and not -(2**63) <= value < 2**63):
        return value
    raise error(key, f"must be {what}, got {shown(value)}")


def shown(value: Any) -> str:
    """A wrong value in a message: its JSON type and a short form of it."""
    text = repr(value)
    kind = {dict: "an object", list: "a list", str: "text", bool: "true or false",
            type(None): "null"}.get(type(value), "a number")
    return f"{kind} ({text[:40]}{'...' if len(text) > 40 else ''})"
