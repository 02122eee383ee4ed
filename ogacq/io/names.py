"""The rule for a name a person gives: a machine's name and serial, an operator. Such
a name is recorded in sessions, the history and the record, printed on one line,
written into controller files' comments and stems: so it is one line of text that
shows as it is stored, and no longer than the history keeps."""

from __future__ import annotations

import unicodedata

from ogacq.io.errors import InputError

# the history's columns for names (ogacq/history/schema.py: String(200))
MAX_NAME_CHARACTERS = 200
# Unicode's bidirectional formatting characters (UAX #9, Table 1): they show the text
# around them in another order than it is stored ("RLO" U+202E turns it round)
BIDI_CONTROLS = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e"
                          "\u2066\u2067\u2068\u2069")


def name_problem(value: str) -> str | None:
    """What makes ``value`` unfit for a name (blank aside: each caller says what to
    give instead), or None."""
    if len(value) > MAX_NAME_CHARACTERS:
        return (f"is {len(value)} characters long: a name holds at most "
                f"{MAX_NAME_CHARACTERS}")
    for char in value:
        category = unicodedata.category(char)
        if category == "Cc" or category in ("Zl", "Zp"):
            said = ", a line break" if char in "\n\r" or category in ("Zl", "Zp") else ""
            return (f"holds a control character (U+{ord(char):04X}{said}): write it on one "
                    "line")
        if char in BIDI_CONTROLS:
            return (f"holds a bidirectional control (U+{ord(char):04X}), which shows the text "
                    "in another order than it is stored")
    return None


def parsed_name(text: str) -> str:
    """``text`` stripped, as a name; ValueError saying why it is not one (a typed answer
    is asked again)."""
    value = text.strip()
    problem = name_problem(value)
    if problem is not None:
        raise ValueError(f"{value[:60]!r} {problem}")
    return value


def checked_name(text: str, where: str) -> str:
    """``text`` stripped, as a name; InputError naming ``where`` (an option) otherwise."""
    try:
        return parsed_name(text)
    except ValueError as exc:
        raise InputError(where, str(exc)) from None
