"""A command's options and arguments declared without importing typer.

``Annotated[Path, Option("--machine", "-m", help=...)]`` says what
``Annotated[Path, typer.Option("--machine", "-m", help=...)]`` says. typer builds the
command from it (``ogacq.cli.lazy`` turns each declaration into typer's own when it
builds a command: the help, the errors and completion are typer's), and the commands
that answer without typer (``ogacq.cli.fast_path``: refit, diagnose) are parsed from
the same declarations, so the two cannot disagree on a name, a flag or a choice.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any


@dataclass(frozen=True, init=False)
class Option:
    """An option: its names (``--machine``, ``-m``), help, metavar and lower bound."""

    names: tuple[str, ...]
    help: str | None
    metavar: str | None
    min: int | float | None

    def __init__(self, *names: str, help: str | None = None, metavar: str | None = None,
                 min: int | float | None = None) -> None:
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "help", help)
        object.__setattr__(self, "metavar", metavar)
        object.__setattr__(self, "min", min)

    def typer_keywords(self) -> dict[str, Any]:
        """What typer.Option takes besides the names: only what was given."""
        given = {"help": self.help, "metavar": self.metavar, "min": self.min}
        return {key: value for key, value in given.items() if value is not None}


@dataclass(frozen=True)
class Argument:
    """A positional argument: its help."""

    help: str | None = None


Declaration = Option | Argument


def annotated_parameters(
        function: Callable[..., Any]) -> list[tuple[inspect.Parameter, Any, list[Any]]]:
    """Each parameter of ``function`` with its type and the metadata its ``Annotated``
    annotation carries (none when it is not Annotated), the annotations resolved."""
    hints = typing.get_type_hints(function, include_extras=True)
    found = []
    for parameter in inspect.signature(function).parameters.values():
        hint = hints.get(parameter.name, parameter.annotation)
        if typing.get_origin(hint) is Annotated:
            base, *metadata = typing.get_args(hint)
            found.append((parameter, base, metadata))
        else:
            found.append((parameter, hint, []))
    return found
