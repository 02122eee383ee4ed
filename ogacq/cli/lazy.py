"""A typer group that imports a command's module only when that command runs (or when
the help lists it): ``ogacq refit`` never pays for the simulator, the wizard or
matplotlib.

Commands are named by ``"module:function"``; a sub-group (``ogacq session ...``) by a
``LazyGroupSpec`` of such targets.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import typer
from typer.core import TyperGroup

if TYPE_CHECKING:  # typer vendors its own click
    from typer._click import Command, Context


@dataclass(frozen=True)
class LazyGroupSpec:
    help: str
    commands: Mapping[str, str]  # sub-command name -> "module:function"


def load_function(target: str) -> Callable[..., Any]:
    module, _, name = target.partition(":")
    return getattr(importlib.import_module(module), name)


def build_command(name: str, target: str | LazyGroupSpec) -> Command:
    """The click command of one target: its function's signature gives the options,
    its docstring the help."""
    if isinstance(target, LazyGroupSpec):
        group = typer.Typer(no_args_is_help=True, help=target.help, add_completion=False)
        for sub_name, sub_target in target.commands.items():
            group.command(sub_name)(load_function(sub_target))
        command = typer.main.get_group(group)
    else:
        single = typer.Typer(add_completion=False)
        single.command(name)(load_function(target))
        command = typer.main.get_command(single)
    command.name = name
    return command


class LazyCommandTable(MutableMapping[str, "Command"]):
    """A group's name -> command mapping whose commands are built on first lookup;
    its keys (listing, "did you mean") need no import."""

    def __init__(self, targets: Mapping[str, str | LazyGroupSpec],
                 built: Mapping[str, Command]) -> None:
        self._targets = dict(targets)
        self._built = dict(built)

    def __contains__(self, name: object) -> bool:  # without building it
        return name in self._targets or name in self._built

    def __getitem__(self, name: str) -> Command:
        if name not in self._built:
            self._built[name] = build_command(name, self._targets[name])
        return self._built[name]

    def __setitem__(self, name: str, command: Command) -> None:
        self._built[name] = command

    def __delitem__(self, name: str) -> None:
        if name not in self:
            raise KeyError(name)
        self._targets.pop(name, None)
        self._built.pop(name, None)

    def __iter__(self) -> Iterator[str]:
        return iter({**dict.fromkeys(self._targets), **dict.fromkeys(self._built)})

    def __len__(self) -> int:
        return len(self._targets.keys() | self._built.keys())


class LazyCommands(TyperGroup):
    """A group whose commands are those of ``table`` (set by a subclass), in its order."""

    table: ClassVar[Mapping[str, str | LazyGroupSpec]] = {}

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        self.commands = LazyCommandTable(self.table, self.commands)

    def list_commands(self, ctx: Context) -> list[str]:
        return list(self.commands)  # names only: the base class would build them all
