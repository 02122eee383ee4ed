"""What the technician sees and types: each question asked until the answer makes sense
(it says what it expects; a typo raises nothing), and a live display stopped before
any question, so prompts never fight with redraws."""

from __future__ import annotations

import contextlib
import logging
import math
import os
import select
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

from rich.console import Console, RenderableType

from ogacq.cli.plain import console as new_console
from ogacq.cli.plain import shown
from ogacq.cli.repeated_warnings import RepeatCollapsingHandler
from ogacq.errors import InputError

T = TypeVar("T")

console = new_console()


class InputClosed(InputError):
    """The terminal closed (end of input): nobody is there to answer."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass(frozen=True)
class Option:
    key: str
    label: str


class LiveDisplay(Protocol):
    """A rich ``Live`` or ``Progress``: something redrawn in place until stopped."""

    def start(self) -> None: ...

    def stop(self) -> None: ...


class Screen:
    """The console plus the one live display that may be on it."""

    def __init__(self, out: Console = console) -> None:
        self.out = out
        self.live: LiveDisplay | None = None

    # ---------------------------------------------------------------- live display
    def show_live(self, live: LiveDisplay) -> None:
        self.stop_live()
        self.live = live
        live.start()

    def stop_live(self) -> None:
        if self.live is not None:
            live, self.live = self.live, None
            with contextlib.suppress(Exception):
                live.stop()

    # ---------------------------------------------------------------- text
    def heading(self, title: str, step: str = "") -> None:
        self.stop_live()
        self.out.print()
        self.out.rule(f"[bold]{title}[/]" + (f"  [dim]{step}[/]" if step else ""), align="left")

    def say(self, text: RenderableType = "", **kwargs: Any) -> None:
        self.out.print(text, **kwargs)

    # ok, problem and note print text as it is (a port's description, a serial, a
    # device's message): never markup; say() takes markup, its callers escape data
    def ok(self, text: str) -> None:
        self.out.print(f"[green]OK[/]  {shown(text)}")

    def problem(self, text: str) -> None:
        self.out.print(f"[bold red]!![/]  {shown(text)}")

    def note(self, text: str) -> None:
        self.out.print(f"[dim]{shown(text)}[/]")

    # ---------------------------------------------------------------- questions
    def ask(self, question: str, default: str | None = None) -> str:
        """One line of text; the default when the answer is empty."""
        self.stop_live()
        offered = f" [cyan]\\[{shown(default)}][/]" if default not in (None, "") else ""
        end = " " if question.endswith("?") else ": "
        try:
            answer = self.out.input(f"{shown(question)}{offered}{end}").strip()
        except EOFError:
            raise InputClosed("the terminal closed") from None
        return answer if answer or default is None else default

    def ask_parsed(self, question: str, parse: Callable[[str], T], default: str | None = None,
                   ) -> T:
        """Ask until ``parse`` accepts the answer; its ValueError says what is wrong."""
        while True:
            answer = self.ask(question, default)
            try:
                return parse(answer)
            except ValueError as exc:
                self.problem(str(exc))

    def choose(self, question: str, options: Sequence[Option], default: str | None = None,
               ) -> str:
        """One of the options' keys, typed (case does not matter), or the first word of
        its label as listed ("cia402", "six", "retry", "quit"): what a person reads on
        the line is what they type."""
        keys = {o.key.lower(): o.key for o in options}
        named: dict[str, list[str]] = {}
        for o in options:
            name = o.label.split(maxsplit=1)[0].rstrip(":,").lower() if o.label.strip() else ""
            named.setdefault(name, []).append(o.key)
        keys |= {name: found[0] for name, found in named.items()
                 if name and len(found) == 1 and name not in keys}
        for option in options:
            self.out.print(f"  [bold cyan]{shown(option.key)}[/]  {shown(option.label)}")
        while True:
            answer = self.ask(question or "Your choice", default).lower()
            if answer in keys:
                return keys[answer]
            self.problem(f"type one of: {', '.join(o.key for o in options)}")

    def confirm(self, question: str, default: bool = True) -> bool:
        while True:
            answer = self.ask(f"{question} (y/n)", "y" if default else "n").lower()
            if answer in ("y", "yes", "o", "oui"):
                return True
            if answer in ("n", "no", "non"):
                return False
            self.problem("type y or n")

    def reason(self, what: str) -> str:
        """A reason is never empty: it is what the session will say about a skip."""
        while True:
            text = self.ask(f"Why {what}? (one line, kept in the session)")
            if text:
                return text
            self.problem("a reason is needed, so whoever reads the session knows why")


class _ScreenLines:
    """A stream whose lines the screen prints: above a live display, never into it."""

    def __init__(self, screen: Screen) -> None:
        self.screen = screen

    def write(self, text: str) -> None:
        for line in filter(None, text.splitlines()):
            self.screen.note(line)

    def flush(self) -> None:
        pass


@contextlib.contextmanager
def log_on_screen(screen: Screen) -> Iterator[None]:
    """While the wizard runs, the log's terminal lines (a retry, a reconnect) go through
    the screen: written straight to stderr they would break into a redrawn progress
    display or a question."""
    root = logging.getLogger()
    terminal = [h for h in root.handlers if isinstance(h, RepeatCollapsingHandler)]
    on_screen: list[RepeatCollapsingHandler] = []
    for handler in terminal:
        replacement = RepeatCollapsingHandler(_ScreenLines(screen))
        replacement.setFormatter(handler.formatter)
        replacement.setLevel(handler.level)
        root.removeHandler(handler)
        root.addHandler(replacement)
        on_screen.append(replacement)
    try:
        yield
    finally:
        for replacement in on_screen:
            replacement.flush()
            root.removeHandler(replacement)
        for handler in terminal:
            root.addHandler(handler)


class Keys:
    """Single key presses while a live display runs (cbreak: no echo, Ctrl-C still works);
    not on a terminal, :attr:`interactive` is False and callers ask for a line."""

    def __init__(self) -> None:
        self._fd = sys.stdin.fileno() if sys.stdin and not sys.stdin.closed else -1
        self.interactive = self._fd >= 0 and os.isatty(self._fd)
        self._saved: list | None = None

    def __enter__(self) -> Keys:
        if self.interactive:
            import termios
            import tty

            self._saved = termios.tcgetattr(self._fd)
            tty.setcbreak(self._fd)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._saved is not None:
            import termios

            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
            self._saved = None

    def poll(self, timeout_s: float) -> str | None:
        if not self.interactive:
            return None
        ready, _, _ = select.select([self._fd], [], [], timeout_s)
        if not ready:
            return None
        data = os.read(self._fd, 64)
        if not data:
            raise InputClosed("the terminal closed")
        return data.decode(errors="replace")


def detail(exc: Exception) -> str:
    """A driver error's message without the device name in front, for sentences
    that already name the device."""
    text = str(exc)
    where = getattr(exc, "where", "")
    return text[len(where) + 2:] if where and text.startswith(f"{where}: ") else text


def times(count: int, noun: str = "") -> str:
    """``once``, ``3 times``; or ``1 cycle``, ``3 cycles`` with a noun."""
    if noun:
        return f"{count} {noun}" + ("" if count == 1 else "s")
    return "once" if count == 1 else f"{count} times"


def typed_number(text: str, expected: str) -> float:
    """A number typed by a person (a decimal comma is fine); otherwise a ValueError in
    words, ``expected`` saying what to type ("a temperature in °C, for example 20.5"),
    never Python's "could not convert string to float". Not a number (nan) and
    infinity are refused: no comparison with them means anything."""
    try:
        value = float(text.strip().replace(",", "."))
    except ValueError:
        raise ValueError(f"{text.strip()!r} is not a number: type {expected}") from None
    if not math.isfinite(value):
        raise ValueError(f"{text.strip()!r} is not a number: type {expected}")
    return value


def parse_mm(text: str) -> float:
    """A length typed by a person: ``5.71``, ``5,71`` (decimal comma), ``-0.02``."""
    cleaned = text.strip().lower().removesuffix("mm").strip()
    if not cleaned:
        raise ValueError("type the value shown, in mm (for example 5.71)")
    try:
        return typed_number(cleaned, "the value shown, in mm (for example 5.71)")
    except ValueError:
        raise ValueError(f"{text!r} is not a number of mm (for example 5.71)") from None
