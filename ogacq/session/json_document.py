"""A JSON object read as a typed value that gives it back exactly: the session's
header and the calibration record (``SessionHeader``, ``CalibrationRecord``).

The keys a version reads are named attributes, each with the JSON type that version
writes; every other key, and a named one of another type (a hand-edited file), is
kept in ``extra``, and ``order`` keeps the keys as written, so ``to_json`` gives back
the same keys in the same order with the same values (digests, ids and revisions
computed from the JSON do not depend on the type).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any, ClassVar, Self, cast

JsonObject = Mapping[str, Any]


def json_type_is(value: Any, expected: type) -> bool:
    """Whether ``value`` is of the JSON type ``expected`` (dict: any object; a bool is
    neither a number nor a string)."""
    if expected is dict:
        return isinstance(value, Mapping)
    return isinstance(value, expected) and (expected is bool or not isinstance(value, bool))


class NamedJson:
    """The mixin of a frozen dataclass whose fields are ``NAMED``'s keys, then ``extra``
    (a JsonObject) and ``order`` (a tuple of keys)."""

    NAMED: ClassVar[Mapping[str, type]]  # each named key and its JSON type
    extra: JsonObject
    order: tuple[str, ...]

    @classmethod
    def from_json(cls, document: JsonObject) -> Self:
        """The value a JSON object says."""
        named: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        for key, value in document.items():
            expected = cls.NAMED.get(key)
            if expected is not None and (value is None or json_type_is(value, expected)):
                named[key] = value
            else:
                extra[key] = value
        return cast(Any, cls)(**named, extra=extra, order=tuple(document))

    def to_json(self) -> dict[str, Any]:
        """The JSON object, exactly as it was read (keys in their order)."""
        keys = self.order or (*(n for n in self.NAMED if getattr(self, n) is not None),
                              *self.extra)
        return {key: self.extra[key] if key in self.extra else getattr(self, key)
                for key in keys}

    def __contains__(self, key: str) -> bool:
        """Whether the object has ``key`` at all (null included)."""
        return key in (self.order or self.to_json())

    @classmethod
    def check_named(cls) -> None:
        """NAMED and the dataclass's fields name the same keys (run at import)."""
        names = {f.name for f in fields(cast(Any, cls))} - {"extra", "order"}
        assert set(cls.NAMED) == names, (cls.__name__, set(cls.NAMED) ^ names)
