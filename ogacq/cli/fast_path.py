"""The analysis commands (refit, diagnose) run without typer when their command line
is plainly well formed.

Importing typer costs about 40 % of numpy's import, a third of a 72-reading refit. The
commands the table marks ``fast`` declare their options with ``ogacq.cli.declare``;
this module parses a command line against those declarations and calls the function.
Whatever it cannot vouch for is left to typer, which then runs the whole line as it
runs every command (so its help, its messages and its exit codes stay the only ones):
``--help``, ``--version``, an unknown or repeated option, an option without its value,
a flag given one, a value that is not among the choices, a missing or extra argument,
``-`` for a file, short options run together, completion's environment, and a
parameter whose type this module does not know. ``OGACQ_NO_FAST_PATH=1`` sends every
line to typer (the tests compare the two).
"""

from __future__ import annotations

import inspect
import os
import types
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from ogacq.cli.command_table import COMMANDS, LazyCommandSpec, import_target
from ogacq.cli.declare import Argument, Option, annotated_parameters
from ogacq.cli.log_options import LOG_FILE_OPTION, VERBOSE_FLAGS, apply_log_options

NO_FAST_PATH = "OGACQ_NO_FAST_PATH"
COMPLETION = "_OGACQ_COMPLETE"  # click's completion: typer answers it

PLAIN_TYPES = (Path, str, bool)


@dataclass(frozen=True)
class Declared:
    """One parameter of a command's function, as its annotation declares it."""

    name: str  # the function's keyword
    kind: type  # Path, str, bool or an Enum of choices
    declaration: Option | Argument
    default: Any  # inspect.Parameter.empty when the command line must give it

    @property
    def option_names(self) -> tuple[str, ...]:
        """An option's names; typer names one declared without them after its keyword
        (``weighting`` -> ``--weighting``)."""
        if not isinstance(self.declaration, Option):
            return ()
        return self.declaration.names or (f"--{self.name.replace('_', '-')}",)


def declared_parameters(function: Callable[..., Any]) -> list[Declared] | None:
    """Each parameter of ``function`` with its declaration and plain type; None when
    one is not declared with ``ogacq.cli.declare`` or has a type not known here."""
    declared = []
    for parameter, base, metadata in annotated_parameters(function):
        declarations = [m for m in metadata if isinstance(m, Option | Argument)]
        kind = _plain_kind(base)
        if len(declarations) != 1 or kind is None:
            return None
        declared.append(Declared(parameter.name, kind, declarations[0], parameter.default))
    return declared


def _plain_kind(base: Any) -> type | None:
    """``Path``, ``Path | None``, ``str | None``, ``bool``, an Enum: the type a word
    becomes; None for any other."""
    if isinstance(base, types.UnionType):
        args = [a for a in typing.get_args(base) if a is not type(None)]
        if len(args) != 1 or len(typing.get_args(base)) != 2:
            return None
        base = args[0]
    if base in PLAIN_TYPES or (isinstance(base, type) and issubclass(base, Enum)):
        return base
    return None


def _value(parameter: Declared, word: str) -> Any | None:
    """``word`` as the parameter's type; None when typer should judge it."""
    if word == "" or word == "-":
        return None
    if issubclass(parameter.kind, Enum):
        choices = {str(member.value): member for member in parameter.kind}
        return choices.get(word)
    make: Callable[[str], Any] = parameter.kind  # Path or str
    return make(word)


def _option_value(parameter: Declared, has_value: str, value: str,
                  words: Sequence[str], k: int) -> tuple[Any, int] | None:
    """An option's value (the flag's True, ``--opt=value``'s or the next word's) and
    where the words go on; None when typer should judge it."""
    if parameter.kind is bool:
        return (None if has_value else True), k
    if not has_value:
        if k == len(words) or words[k].startswith("-"):
            return None
        value = words[k]
        k += 1
    converted = _value(parameter, value)
    return None if converted is None else (converted, k)


def _split(parameters: Sequence[Declared],
           words: Sequence[str]) -> tuple[dict[str, Any], list[str]] | None:
    """The options' values by keyword, and the positional words."""
    options = {name: p for p in parameters for name in p.option_names}
    given: dict[str, Any] = {}
    positional: list[str] = []
    k = 0
    while k < len(words):
        word = words[k]
        k += 1
        if word == "--":
            return given, positional + list(words[k:])
        if not word.startswith("-") or word == "-":
            positional.append(word)
            continue
        name, has_value, value = word.partition("=")
        parameter = options.get(name)
        if parameter is None or parameter.name in given or \
                (has_value and not name.startswith("--")):
            return None
        found = _option_value(parameter, has_value, value, words, k)
        if found is None or found[0] is None:
            return None
        given[parameter.name], k = found
    return given, positional


def parse(parameters: Sequence[Declared], words: Sequence[str]) -> dict[str, Any] | None:
    """The keywords the command's function gets for ``words`` (what follows the
    command's name), as typer would give them; None when typer should judge them."""
    split = _split(parameters, words)
    if split is None:
        return None
    given, positional = split
    arguments = [p for p in parameters if isinstance(p.declaration, Argument)]
    if len(positional) > len(arguments):
        return None
    for parameter, word in zip(arguments, positional, strict=False):
        converted = _value(parameter, word)
        if converted is None:
            return None
        given[parameter.name] = converted
    for parameter in parameters:
        if parameter.name not in given:
            if parameter.default is inspect.Parameter.empty:
                return None
            given[parameter.name] = parameter.default
    return given


def _root_options(argv: Sequence[str]) -> tuple[bool, Path | None, int] | None:
    """--verbose and --log-file before the command's name (``global_options_first``
    has moved them there), and where the command's name is; None for any other."""
    verbose, log_file, k = False, None, 0
    while k < len(argv) and argv[k].startswith("-"):
        word = argv[k]
        if word in VERBOSE_FLAGS:
            verbose = True
        elif word.startswith(f"{LOG_FILE_OPTION}=") and log_file is None \
                and word.partition("=")[2]:
            log_file = Path(word.partition("=")[2])
        elif word == LOG_FILE_OPTION and log_file is None and k + 1 < len(argv) \
                and argv[k + 1] not in ("", "-"):
            log_file = Path(argv[k + 1])
            k += 1
        else:
            return None
        k += 1
    return verbose, log_file, k


def fast_call(argv: Sequence[str]) -> Callable[[], None] | None:
    """The command ``argv`` asks for, ready to run without typer; None when typer
    should run it."""
    if os.environ.get(NO_FAST_PATH) or COMPLETION in os.environ:
        return None
    root = _root_options(argv)
    if root is None:
        return None
    verbose, log_file, k = root
    spec = COMMANDS.get(argv[k]) if k < len(argv) else None
    if not isinstance(spec, LazyCommandSpec) or not spec.fast:
        return None
    function = import_target(spec.target)
    parameters = declared_parameters(function)
    keywords = parse(parameters, argv[k + 1:]) if parameters is not None else None
    if keywords is None:
        return None

    def call() -> None:
        if verbose or log_file is not None:  # else logging waits for a logger (ogacq.logs)
            apply_log_options(verbose, log_file)
        function(**keywords)

    return call
