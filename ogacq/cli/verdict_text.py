"""The consistency verdict on the terminal, explained once a command (issue 38.6: the
demo and ``calibrate`` said the whole paragraph four or five times a run).

The first verdict a command states is the paragraph (which test, each p, the level);
each later one is its words and its p, referring to it. ``typer_app.run_app`` starts
every command with :func:`new_command`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported by every command's start (new_command): nothing numeric
    from ogacq.identify.consistency import Verdict

JUDGED = ("consistent", "inconsistent")


class _Explained:
    """Whether this command has stated a verdict in full yet."""

    said = False


def new_command() -> None:
    """A command starts: its first verdict is said in full again."""
    _Explained.said = False


def paragraph(verdict: Verdict) -> str:
    """The verdict in full the first time this command states one, one line after."""
    if _Explained.said and verdict.judged:
        return _brief(verdict)
    _Explained.said = _Explained.said or verdict.judged
    return verdict.describe()


def one_line(verdict: Verdict) -> str:
    """A campaign's last word on its verdict: its one line with the test and the level
    (``Verdict.summary``), shorter still when the paragraph was said before it."""
    if _Explained.said and verdict.judged:
        return _brief(verdict)
    return verdict.summary()


def recorded_paragraph(verdict: Mapping[str, Any]) -> str:
    """:func:`paragraph` of a verdict as a procedure recorded it (``Verdict.to_record``
    with its ``text``: the validation's judgement)."""
    text = str(verdict.get("text", ""))
    p = verdict.get("p_value")
    if verdict.get("state") not in JUDGED or not isinstance(p, int | float):
        return text  # undetermined, or a record without its p: its own words
    if _Explained.said:  # the text opens with the verdict's words: "within the gauge noise ("
        return _as_above(text.partition(" (")[0], float(p), "combined p" in text,
                         float(verdict.get("level") or _level()))
    _Explained.said = True
    return text


def _brief(verdict: Verdict) -> str:
    return _as_above(verdict.headline(), verdict.p_value, verdict.worst_cell is not None,
                     verdict.level)


def _level() -> float:
    from ogacq.identify.consistency import LEVEL

    return LEVEL


def _as_above(headline: str, p: float, combined: bool, level: float) -> str:
    """``within the gauge noise (combined p = 0.363 ≥ 0.01, the test as above)``."""
    from ogacq.identify.consistency import format_p

    which = "combined p" if combined else "p"
    against = "<" if p < level else "≥"
    return f"{headline} ({which} = {format_p(p)} {against} {level:g}, the test as above)"
