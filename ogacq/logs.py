"""The loggers of ogacq's modules, made by :func:`logger`: the command line's handlers
installed first.

``ogacq.cli.app`` hands its terminal handler to :func:`before_first_logger` and
installs it (:func:`setup_now`) before a command runs; a module that logs before that
(one imported by the command line itself) installs it with its first logger, before
that logger's first record. ``drivers`` (which imports nothing of ogacq) and the
command line's own modules use ``logging`` directly.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import logging

_BEFORE_FIRST: list[Callable[[], None]] = []


def before_first_logger(setup: Callable[[], None]) -> None:
    """Run ``setup`` once, when the first logger is made (or now, by :func:`setup_now`)."""
    if setup not in _BEFORE_FIRST:  # ``main`` run again in one process
        _BEFORE_FIRST.append(setup)


def setup_now() -> None:
    """Run the setups waiting for the first logger now (the command line's handlers
    before a command that may log from any module)."""
    while _BEFORE_FIRST:
        _BEFORE_FIRST.pop(0)()


def logger(name: str) -> logging.Logger:
    """``logging.getLogger(name)``, the waiting setups run first."""
    import logging

    setup_now()
    return logging.getLogger(name)
