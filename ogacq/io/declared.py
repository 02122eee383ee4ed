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

__all__ = ["Finite", "Reader", "checked", "reader", "shown"]

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
    return reader(hint)(value, key, error, nested)


def reader(hint: Any) -> Reader:
    """What :func:`checked` does for ``hint``, as one function of (value, key, error,
    nested): a caller that reads the same annotations again and again keeps it."""
    try:
        return _READERS[hint]
    except KeyError:
        read = _READERS[hint] = _reader(hint)
        return read


# Each annotation's reader, built once: a session of thousands of records checks the same
# few annotations on every line, and reading an annotation apart (typing.get_origin,
# get_args) each time cost more than the check.
Reader = Callable[[Any, str, Fail, Nested | None], Any]
_READERS: dict[Any, Reader] = {}


def _reader(hint: Any) -> Reader:
    """The reader of ``hint``: the checks its annotation says, in the order said above."""
    if hint is Any:
        return lambda value, key, error, nested: value
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is Annotated:
        return _finite(_reader(args[0])) if FINITE in args[1:] else _reader(args[0])
    if origin in (types.UnionType, typing.Union):
        (inner,) = (a for a in args if a is not type(None))
        return _or_null(_reader(inner)) if type(None) in args else _reader(inner)
    if origin is tuple:
        if args[1:] == (...,):
            return _list_of(_reader(args[0]))
        return _list_of_each(tuple(_reader(a) for a in args))
    if origin is dict:
        return _object_of(_reader(args[1]))
    return _scalar(hint) if hint in SCALARS else _by_nested(hint)


def _finite(inner: Reader) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        out = inner(value, key, error, nested)
        if not math.isfinite(out):
            raise error(key, f"must be a finite number, got {shown(value)}")
        return out
    return read


def _or_null(inner: Reader) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        return None if value is None else inner(value, key, error, nested)
    return read


def _list_of(each: Reader) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        if not isinstance(value, list):
            raise error(key, f"must be a list, got {shown(value)}")
        return tuple(each(v, f"{key}[{i}]", error, nested) for i, v in enumerate(value))
    return read


def _list_of_each(each: tuple[Reader, ...]) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        if not isinstance(value, list):
            raise error(key, f"must be a list, got {shown(value)}")
        if len(each) != len(value):
            raise error(key, f"must be a list of {len(each)}, got {shown(value)}")
        return tuple(r(v, f"{key}[{i}]", error, nested)
                     for i, (r, v) in enumerate(zip(each, value, strict=True)))
    return read


def _object_of(each: Reader) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        if not isinstance(value, Mapping):
            raise error(key, f"must be an object, got {shown(value)}")
        return {str(k): each(v, f"{key}.{k}", error, nested) for k, v in value.items()}
    return read


def _scalar(hint: type) -> Reader:
    expected, what = SCALARS[hint]
    numeric = hint is not bool and hint is not str  # true is no number; an int fits 64 bits

    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        if isinstance(value, expected) and not (numeric and (
                isinstance(value, bool)
                or isinstance(value, int) and not -(2**63) <= value < 2**63)):
            return value
        raise error(key, f"must be {what}, got {shown(value)}")
    return read


def _by_nested(hint: Any) -> Reader:
    def read(value: Any, key: str, error: Fail, nested: Nested | None) -> Any:
        assert nested is not None, f"{key}: {hint} is declared with no reader"
        return nested(hint, value, key)
    return read


def shown(value: Any) -> str:
    """A wrong value in a message: its JSON type and a short form of it."""
    text = repr(value)
    kind = {dict: "an object", list: "a list", str: "text", bool: "true or false",
            type(None): "null"}.get(type(value), "a number")
    return f"{kind} ({text[:40]}{'...' if len(text) > 40 else ''})"
