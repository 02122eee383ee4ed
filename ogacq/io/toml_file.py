"""Reading the project's TOML files (machine, campaign, effects, offset table) with
errors that name the file and the line."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from ogacq.io.errors import InputError


def read_toml(path: str | Path, what: str) -> tuple[dict[str, Any], str]:
    """The parsed table and the text (to find lines in); ``what`` names the file's
    role in messages ("machine file"). FileNotFoundError passes through for callers
    for whom a missing file means something."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise InputError(path, f"cannot read {what}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise InputError(path, f"{what} is not a text file") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        match = re.search(r"line (\d+)", str(exc))
        raise InputError(path, f"not valid TOML: {str(exc).split(' (at')[0]}",
                         int(match.group(1)) if match else None) from None


def line_of(text: str, key: str, after: int = 0) -> int | None:
    """The first line (1-based) after line ``after`` that sets ``key`` or opens the
    table ``[key]``/``[[key]]``."""
    pattern = re.compile(rf"\s*(\[\[?{re.escape(key)}\]\]?|{re.escape(key)}\s*=)")
    for number, line in enumerate(text.splitlines()[after:], after + 1):
        if pattern.match(line):
            return number
    return None
