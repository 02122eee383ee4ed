"""Turning a command line's words into the values a command's function takes, for the
plain types ogacq's options have, without pydantic.

typer 0.29 coerces every parameter through a pydantic TypeAdapter: importing pydantic
and building the adapters cost a 72-reading ``refit`` a third of its run (0.1 s). The
types ogacq's commands use (str, Path, int, float, bool, an Enum of choices, their
Optional forms and lists) are coerced here instead, and stricter: a number is ASCII
digits (no fullwidth ``１２``, no ``1_000``, which Python's own ``int`` accepts) and
finite. Anything else is left to typer (``plain_runtime_param`` returns None).

The hook is typer's private ``_runtime_param`` slot, which the project pins typer's
minor version for (pyproject.toml); tests/cli/test_coercion.py holds the results to
typer's own for every value it accepts.
"""

from __future__ import annotations

import re
import types
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any, Union, get_args, get_origin

from typer._click.exceptions import BadParameter
from typer._coercion import RuntimeParam, TypeDescriptor

if TYPE_CHECKING:
    from typer._click import Context
    from typer.core import _TyperParameter

_INTEGER = re.compile(r"[+-]?[0-9]+")
_DECIMAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def _integer(text: str) -> int:
    if not _INTEGER.fullmatch(text):
        raise ValueError(f"{text!r} is not a whole number")
    return int(text)


def _decimal(text: str) -> float:
    if not _DECIMAL.fullmatch(text):
        raise ValueError(f"{text!r} is not a number")
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise ValueError(f"{text!r} is too large a number")
    return value


def _leaf(annotation: Any) -> Any:
    """The converter of one plain type, or None when it is not one."""
    if annotation is str:
        return str
    if annotation is Path:
        return Path
    if annotation is int:
        return _integer
    if annotation is float:
        return _decimal
    if annotation is bool:
        return bool
    if isinstance(annotation, type) and issubclass(annotation, Enum):
        members = {str(m.value): m for m in annotation}

        def choose(text: str) -> Enum:
            if text not in members:
                raise ValueError(f"{text!r} is not one of "
                                 f"{', '.join(repr(v) for v in members)}")
            return members[text]
        return choose
    return None


def _without_none(annotation: Any) -> tuple[Any, bool]:
    """``X | None`` -> (X, True); anything else unchanged."""
    if get_origin(annotation) in (Union, types.UnionType):
        args = [a for a in get_args(annotation) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return annotation, False


@dataclass(frozen=True)
class PlainRuntimeParam(RuntimeParam):
    convert: Any
    is_list: bool
    minimum: float | None
    maximum: float | None

    def _coerce_value(self, value: Any, param: _TyperParameter, ctx: Context) -> Any:
        try:
            if self.is_list:
                return [self._one(v) for v in value]
            return self._one(value)
        except ValueError as problem:
            raise BadParameter(str(problem), ctx=ctx, param=param) from None

    def _one(self, value: Any) -> Any:
        if not isinstance(value, str):  # a default, or a flag's bool: already a value
            return value
        if not value.isascii() and self.convert in (_integer, _decimal):
            raise ValueError(f"{value!r} is not a number written in ASCII digits")
        out = self.convert(value)
        if self.minimum is not None and out < self.minimum:
            raise ValueError(f"{out} is below the least allowed, {self.minimum:g}")
        if self.maximum is not None and out > self.maximum:
            raise ValueError(f"{out} is above the largest allowed, {self.maximum:g}")
        return out


def plain_runtime_param(descriptor: TypeDescriptor) -> PlainRuntimeParam | None:
    """The coercion of a parameter of a plain type, or None to leave it to typer."""
    info = descriptor.parameter_info
    if descriptor.is_file or getattr(info, "parser", None) is not None \
            or getattr(info, "click_type", None) is not None:
        return None
    annotation, _ = _without_none(descriptor.annotation)
    is_list = get_origin(annotation) is list
    if is_list:
        (annotation,) = get_args(annotation) or (None,)
    convert = _leaf(annotation)
    if convert is None:
        return None
    return PlainRuntimeParam(parameter_info=info, annotation=descriptor.annotation,
                             convert=convert, is_list=is_list,
                             minimum=getattr(info, "min", None),
                             maximum=getattr(info, "max", None))
