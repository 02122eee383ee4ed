"""A JSON object read as a typed value that gives it back exactly: the session's
header and the calibration record (``SessionHeader``, ``CalibrationRecord``).

The keys a version reads are named attributes, each with the JSON type that version
writes; every other key, and a named one of another type (a hand-edited file), is
kept in ``extra``, and ``order`` keeps the keys as written, so ``to_json`` gives back
the same keys in the same order with the same values (digests, ids and revisions
computed from the JSON do not depend on the type).
"""

from __future__ import annotations

import typing
from collections.abc import Mapping, Sequence
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
    """The mixin of a frozen dataclass whose fields are the named keys, each annotated
    ``T | None`` with ``T`` its JSON type (``str``, ``bool``, ``int``, ``JsonObject``
    an object, ``Sequence[Any]`` a list), then ``extra`` (a JsonObject) and ``order``
    (a tuple of keys)."""

    extra: JsonObject
    order: tuple[str, ...]
    _named: ClassVar[dict[str, type]]  # by class, from its annotations once

    @classmethod
    def named(cls) -> dict[str, type]:
        """Each named key and its JSON type (dict: an object), from the annotations."""
        if "_named" not in cls.__dict__:
            hints = typing.get_type_hints(cls)
            cls._named = {f.name: _JSON_TYPES[next(a for a in typing.get_args(hints[f.name])
                                                   if a is not type(None))]
                          for f in fields(cast(Any, cls)) if f.name not in ("extra", "order")}
        return cls._named

    @classmethod
    def from_json(cls, document: JsonObject) -> Self:
        """The value a JSON object says."""
        named: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        for key, value in document.items():
            expected = cls.named().get(key)
            if expected is not None and (value is None or json_type_is(value, expected)):
                named[key] = value
            else:
                extra[key] = value
        return cast(Any, cls)(**named, extra=extra, order=tuple(document))

    def to_json(self) -> dict[str, Any]:
        """The JSON object, exactly as it was read (keys in their order)."""
        keys = self.order or (*(n for n in self.named() if getattr(self, n) is not None),
                              *self.extra)
        return {key: self.extra[key] if key in self.extra else getattr(self, key)
                for key in keys}

    def __contains__(self, key: str) -> bool:
        """Whether the object has ``key`` at all (null included)."""
        return key in (self.order or self.to_json())


# A named key's annotation (``T | None``) and the JSON type it is read as.
_JSON_TYPES: dict[Any, type] = {str: str, bool: bool, int: int, JsonObject: dict,
                                Sequence[Any]: list}
