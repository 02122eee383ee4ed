"""A typer group that imports a command's module only when that command runs:
``ogacq refit`` never pays for the simulator, the wizard or matplotlib, and
``ogacq --help`` lists every command from the table's summaries without importing
any of them.

Commands are named by a ``LazyCommandSpec`` (``"module:function"`` and the first
paragraph of its help); a sub-group (``ogacq session ...``) by a ``LazyGroupSpec``
of ``"module:function"`` targets.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import inspect
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from typing import Any, ClassVar

import typer
from typer.core import TyperCommand, TyperGroup

from ogacq.cli.command_table import LazyCommandSpec, LazyGroupSpec, import_target

# typer vendors click as a private package (typer._click) and exports none of these
# classes: named here by their role, untyped, rather than imported from its insides.
Command = Any
Context = Any
Parameter = Any


def flags_without_value(params: list[Parameter]) -> list[Parameter]:
    """typer 0.29's rich help shows a flag's type as if it took a value
    (``--json <bool>``, while ``--json true`` is refused): a flag gets an empty metavar,
    which that help prints instead of the type."""
    for param in params:
        if getattr(param, "is_flag", False) and param.metavar is None:
            param.metavar = ""
        descriptor = getattr(param, "type_descriptor", None)
        if param.metavar is None and descriptor is not None and descriptor.is_ranged:
            # the range is printed with the default ([default: 1; x>=0]), not as a type
            param.metavar = f"<{descriptor.ranged_type_name}>"
        if param.param_type_name == "argument" and param.metavar is None and param.name:
            param.metavar = param.name.upper()  # "SESSION", not click's "{session}"
    return params


def one_paragraph_lines(text: str | None) -> str | None:
    """A docstring's paragraphs each on one line: typer's rich help keeps the source's
    line breaks, which then break the help's lines raggedly."""
    if text is None:
        return None
    paragraphs = inspect.cleandoc(text).split("\n\n")
    return "\n\n".join(" ".join(p.split()) for p in paragraphs)


class FlagCommand(TyperCommand):
    def get_params(self, ctx: Context) -> list[Parameter]:
        return flags_without_value(super().get_params(ctx))


class FlagGroup(TyperGroup):
    default_command: str | None = None  # run when the first word is not a sub-command

    def get_params(self, ctx: Context) -> list[Parameter]:
        return flags_without_value(super().get_params(ctx))

    def parse_args(self, ctx: Context, args: list[str]) -> list[str]:
        # with no word at all too: `ogacq history` lists the machines, where click
        # would print the group's help and exit 2
        if self.default_command and (not args or (args[0] not in self.commands
                                                  and args[0] not in ctx.help_option_names)):
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)


def _command(app: typer.Typer, name: str, function: Callable[..., Any],
             epilog: str | None) -> None:
    help_text = one_paragraph_lines(function.__doc__)
    # the group's listing shows the first paragraph whole, wrapped (click would cut it
    # at 45 characters with "...")
    summary = help_text.split("\n\n")[0] if help_text else None
    app.command(name, cls=FlagCommand, help=help_text, short_help=summary,
                epilog=epilog)(function)


@contextlib.contextmanager
def collector_paused() -> Iterator[None]:
    """A command's modules imported with Python's cyclic garbage collector paused, then
    frozen (``gc.freeze``: kept out of every later collection). An import makes
    thousands of long-lived objects and no garbage, so each collection it triggers
    scans the heap for nothing: ~10 % of a short ``diagnose``'s CPU, and the frozen heap
    ~15 % more. The collector runs again for the command itself, over what the command
    makes (Mercurial pauses it around its large parses the same way, ``util.nogc``)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        freeze_once()
        if enabled:
            gc.enable()


@functools.cache
def freeze_once() -> None:
    """The heap frozen once per process: a command line builds one command, and a
    process that runs many in turn (the tests) would otherwise pin, at each, whatever
    garbage it held then."""
    gc.freeze()


def build_command(name: str, target: str | LazyCommandSpec | LazyGroupSpec,
                  epilog: str | None = None) -> Command:
    """The click command of one target: its function's signature gives the options,
    its docstring the help; ``epilog`` ends every help page."""
    if isinstance(target, LazyGroupSpec):
        group = typer.Typer(cls=FlagGroup, no_args_is_help=True, help=target.help,
                            rich_markup_mode=None,
                            add_completion=False, epilog=epilog)
        for sub_name, sub_target in target.commands.items():
            _command(group, sub_name, import_target(sub_target), epilog)
        flags = typer.main.get_group(group)
        assert isinstance(flags, FlagGroup)  # typer makes the group of the class given
        flags.default_command = target.default
        command: Command = flags
    else:
        single = typer.Typer(add_completion=False, rich_markup_mode=None)
        function = target.target if isinstance(target, LazyCommandSpec) else target
        _command(single, name, import_target(function), epilog)
        command = typer.main.get_command(single)
    command.name = name
    return command


class LazyCommandTable(MutableMapping[str, "Command"]):
    """A group's name -> command mapping whose commands are built on first lookup;
    its keys (listing, "did you mean") need no import."""

    def __init__(self, targets: Mapping[str, str | LazyCommandSpec | LazyGroupSpec],
                 built: Mapping[str, Command], epilog: str | None = None) -> None:
        self._targets = dict(targets)
        self._built = dict(built)
        self._epilog = epilog
        # While the group's own help is formatted, a command not yet built is looked up
        # for its summary only: a command that says it and nothing more (never run).
        self.listing = False

    def __contains__(self, name: object) -> bool:  # without building it
        return name in self._targets or name in self._built

    def __getitem__(self, name: str) -> Command:
        if self.listing and name not in self._built:
            summary = _summary(self._targets[name])
            return typer.core.TyperCommand(name, help=summary, short_help=summary)
        if name not in self._built:
            with collector_paused():
                self._built[name] = build_command(name, self._targets[name], self._epilog)
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


class LazyCommands(FlagGroup):
    """A group whose commands are those of ``table`` (set by a subclass), in its order;
    each command's help ends with ``command_epilog``."""

    table: ClassVar[Mapping[str, str | LazyCommandSpec | LazyGroupSpec]] = {}
    command_epilog: ClassVar[str | None] = None

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        self.commands = LazyCommandTable(self.table, self.commands, self.command_epilog)

    def list_commands(self, ctx: Context) -> list[str]:
        return list(self.commands)  # names only: the base class would build them all

    def format_help(self, ctx: Context, formatter: Any) -> None:
        table = self.commands
        assert isinstance(table, LazyCommandTable)
        table.listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            table.listing = False


def _summary(target: str | LazyCommandSpec | LazyGroupSpec) -> str | None:
    if isinstance(target, LazyCommandSpec):
        return target.summary
    if isinstance(target, LazyGroupSpec):
        return one_paragraph_lines(target.help)
    return None
