"""A record's inner sections declared once, as frozen dataclasses: ``read`` builds one
from the record's JSON, every key checked against its annotation, and ``written``
gives the same JSON back (the keys in the order read, the values as written).

The annotation says the JSON (``ogacq.io.declared``), another :class:`Section` a
nested object. A field without a default must be there; one with a default may be
absent, and is then not written back. A key the declaration does not name is kept
in ``extra`` (a newer or hand-edited record), so nothing read is lost.

A value of another type than declared is a :class:`RecordSectionError` naming the
key (``compensation.tables[1].files``): the report states what the record holds,
and a section it cannot read is said, not shown as something else.
"""

from __future__ import annotations

import typing
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, field, fields
from typing import Any, TypeVar

from ogacq.errors import InputError
from ogacq.io.declared import checked, shown

__all__ = ["RecordSectionError", "Section", "read", "read_as", "written"]

S = TypeVar("S", bound="Section")


class RecordSectionError(InputError, ValueError):
    """A section of a calibration record that is not what ``ogacq-record/1`` writes:
    the key and what is wrong (a hand-edited or damaged record.json)."""

    def __init__(self, key: str, problem: str) -> None:
        self.key = key
        self.problem_of_key = problem  # without the key: "must be a list, got text (...)"
        super().__init__(None, f"the calibration record's {key} {problem}")


@dataclass(frozen=True, kw_only=True)
class Section:
    """The base of a declared section: what the record held beyond the declaration,
    and the order of its keys (empty: the declared fields, then ``extra``)."""

    extra: Mapping[str, Any] = field(default_factory=dict, repr=False)
    order: tuple[str, ...] = field(default=(), repr=False)

    def holds(self, key: str) -> bool:
        """Whether the JSON has ``key`` at all (null included)."""
        return key in (self.order or written(self))


BOOKKEEPING = frozenset({"extra", "order"})


Declared = tuple[tuple[str, Any, bool], ...]
_DECLARED: dict[type, Declared] = {}  # by class: its annotations resolved once


def _declared(cls: type[Section]) -> Declared:
    """Each declared field: its key, its annotation, whether the JSON must have it."""
    if cls not in _DECLARED:
        hints = typing.get_type_hints(cls)
        _DECLARED[cls] = tuple((f.name, hints[f.name],
                                f.default is MISSING and f.default_factory is MISSING)
                               for f in fields(cls) if f.name not in BOOKKEEPING)
    return _DECLARED[cls]


def read(cls: type[S], value: Any, key: str) -> S:
    """The section ``cls`` from the JSON ``value`` found at ``key``."""
    if not isinstance(value, Mapping):
        raise RecordSectionError(key, f"must be an object, got {shown(value)}")
    named: dict[str, Any] = {}
    for name, hint, required in _declared(cls):
        if name in value:
            named[name] = _value(hint, value[name], f"{key}.{name}")
        elif required:
            raise RecordSectionError(f"{key}.{name}", "is missing")
    extra = {k: v for k, v in value.items() if k not in named}
    return cls(**named, extra=extra, order=tuple(value))


def read_as(hint: Any, value: Any, key: str) -> Any:
    """The JSON ``value`` found at ``key`` read as ``hint`` says (``tuple[Entry, ...]``,
    ``dict[str, Entry]``, ...); null: None."""
    return None if value is None else _value(hint, value, key)


def written(section: Section) -> dict[str, Any]:
    """The JSON object of ``section``, as it was read (or declared, when built)."""
    declared = {name: hint for name, hint, _ in _declared(type(section))}
    keys = section.order or (*declared, *section.extra)
    return {k: _json(getattr(section, k)) if k in declared else section.extra[k]
            for k in keys if k in declared or k in section.extra}


def _value(hint: Any, value: Any, key: str) -> Any:
    """``value`` read as ``hint`` says, or RecordSectionError naming ``key``."""
    return checked(hint, value, key, RecordSectionError, _section)


def _section(hint: Any, value: Any, key: str) -> Any:
    assert issubclass(hint, Section), f"{key}: {hint} is no section"
    return read(hint, value, key)


def _json(value: Any) -> Any:
    if isinstance(value, Section):
        return written(value)
    if isinstance(value, tuple):
        return [_json(v) for v in value]
    return {k: _json(v) for k, v in value.items()} if isinstance(value, dict) else value
