"""Comparing a public JSON output with its golden file: the structure exactly (keys in
their order, types, nesting, list lengths), every string, boolean, null and integer
exactly, every float to what the numerics determine.

A float's tolerance is one unit of the golden's last printed decimal (``diagnose
--json`` and ``refit --json`` round: a value on a rounding edge may print either
side on another BLAS kernel) plus 1e-6 of its size and 1e-9 absolute (a value
computed in full, as record.json keeps it, moves by ~1e-15 between kernels; 1e-6
of a joint offset is about 1e-3 of its std in these campaigns). A caller widens a
key's tolerance where the physics, not the arithmetic, sets it (a live campaign's
readings: ``loose``), or names keys whose values are not compared at all, only
their type (wall times, ports, timings: ``typed_only``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

RELATIVE = 1e-6
ABSOLUTE = 1e-9

# a path as a tuple of keys (list indices as "[]") -> its extra tolerance, or None
Loose = Callable[[tuple[str, ...]], float | None]


def quantum(value: float) -> float:
    """One unit of the last decimal ``value`` prints with (0 in exponent notation, where
    the value is kept in full)."""
    text = repr(value)
    if "e" in text or "." not in text:
        return 0.0
    return 10.0 ** -len(text.split(".")[1])


def kind(value: Any) -> str:
    """A JSON value's type as the format promises it (an integer written as a float, 3.0,
    is a number like any other)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    return "object"


def compare(expected: Any, actual: Any, where: str = "", *,
            typed_only: frozenset[str] = frozenset(), loose: Loose | None = None,
            path: tuple[str, ...] = ()) -> list[str]:
    """Every difference between ``expected`` and ``actual``, one line each (empty: the
    same)."""
    here = where or "(top)"
    if kind(expected) != kind(actual):
        return [f"{here}: a {kind(actual)} ({actual!r:.80}), expected a {kind(expected)} "
                f"({expected!r:.80})"]
    if path and path[-1] in typed_only:
        return []
    if isinstance(expected, Mapping):
        if list(expected) != list(actual):
            return [f"{here}: keys {list(actual)}, expected {list(expected)}"]
        out: list[str] = []
        for key in expected:
            out += compare(expected[key], actual[key], f"{where}.{key}", typed_only=typed_only,
                           loose=loose, path=(*path, key))
        return out
    if isinstance(expected, list):
        if len(expected) != len(actual):
            return [f"{here}: {len(actual)} items, expected {len(expected)}"]
        out = []
        for k, (e, a) in enumerate(zip(expected, actual, strict=True)):
            out += compare(e, a, f"{where}[{k}]", typed_only=typed_only, loose=loose,
                           path=(*path, "[]"))
        return out
    if isinstance(expected, float):
        tolerance = quantum(expected) + RELATIVE * abs(expected) + ABSOLUTE
        extra = loose(path) if loose is not None else None
        if extra is not None:
            tolerance += extra
        if not abs(actual - expected) <= tolerance:
            return [f"{here}: {actual!r}, expected {expected!r} within {tolerance:.3g}"]
        return []
    if expected != actual:
        return [f"{here}: {actual!r:.200}, expected {expected!r:.200}"]
    return []
