"""Ctrl-C: pause, then resume or quit, the session left resumable. At a question it
interrupts at once; while the campaign runs by itself it waits for the next move,
settle or reading, so a pause never cuts a Modbus exchange, a serial frame or a record
in half and the axes are at rest; a second Ctrl-C meanwhile interrupts at once (the
runner stops the axes and records it)."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType
from typing import TypeVar

from ogacq.cli.plain import shown
from ogacq.cli.wizard.ui import InputClosed, Option, Screen
from ogacq.protocol.runner import CampaignStopped

T = TypeVar("T")


class OperatorQuit(CampaignStopped):
    """The technician chose to quit; inside a campaign the runner records it as an
    interruption (axes stopped, session resumable)."""

    def __init__(self, reason: str = "the operator quit at a pause") -> None:
        super().__init__(reason, "interrupted")


class InterruptGate:
    """The SIGINT handler of the wizard (see the module doc)."""

    def __init__(self) -> None:
        self.pending = False
        self._deferring = 0
        self._immediate = 0
        self._previous: Callable | int | None = None
        self.on_deferred: Callable[[], None] = lambda: None

    def install(self) -> None:
        self._previous = signal.signal(signal.SIGINT, self._handle)

    def uninstall(self) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self._deferring and not self._immediate and not self.pending:
            self.pending = True
            with contextlib.suppress(Exception):
                self.on_deferred()
            return
        self.pending = False
        raise KeyboardInterrupt

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """Hold Ctrl-C until the next checkpoint (the campaign running by itself)."""
        self._deferring += 1
        try:
            yield
        finally:
            self._deferring -= 1
            if not self._deferring:
                self.pending = False  # no checkpoint came (the run ended): nothing to pause

    @contextlib.contextmanager
    def immediate(self) -> Iterator[None]:
        """Ctrl-C at once, inside a deferred block: the technician is being asked."""
        self._immediate += 1
        try:
            yield
        finally:
            self._immediate -= 1

    def take_pending(self) -> bool:
        pending, self.pending = self.pending, False
        return pending


@contextlib.contextmanager
def closed_is_quit() -> Iterator[None]:
    """A terminal closed while the campaign asks: stopped as a quit (recorded, resumable)."""
    try:
        yield
    except InputClosed:
        raise OperatorQuit("the terminal closed") from None


def pause_menu(screen: Screen, where: str, session: Path | None = None) -> None:
    """Return to resume; raise :class:`OperatorQuit` to quit. Ctrl-C here quits."""
    screen.stop_live()
    screen.say()
    screen.say(f"[bold yellow]Paused[/] {shown(where)}.")
    if session is not None:
        screen.say("The axes hold their position; every reading so far is saved in "
                   f"{shown(session)}.")
    try:
        choice = screen.choose("Resume or quit?", [
            Option("r", "resume"),
            Option("q", "quit" + (" (the session stays resumable)" if session else "")),
        ], default="r")
    except (KeyboardInterrupt, InputClosed):
        choice = "q"
    if choice == "q":
        raise OperatorQuit()
    screen.say("[green]Resuming.[/]")


def pausable(screen: Screen, where: str, action: Callable[[], T],
             session: Path | None = None) -> T:
    """Run ``action``; on Ctrl-C offer resume (run it again) or quit."""
    while True:
        try:
            return action()
        except KeyboardInterrupt:
            pause_menu(screen, where, session)
