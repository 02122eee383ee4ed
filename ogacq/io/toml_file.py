"""ogacq's TOML files (machine, campaign, effects, offset table) read and written
through their declared schemas (``ogacq_drivers.config_schema``), every error an
:class:`InputError` naming the file, the line and the key."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ogacq_drivers.config_schema import Issue, Source, Table, load, parse_document
from ogacq.io.errors import InputError
from ogacq.io.text import check_line_ends, read_text


def input_error(issue: Issue) -> InputError:
    return InputError(issue.file, issue.message, issue.line)


def read_toml(path: str | Path, what: str) -> tuple[dict[str, Any], Source]:
    """The parsed file and its source (to name lines in later checks); ``what`` names
    the file's role in messages ("the machine file"). FileNotFoundError passes
    through, for callers to whom a missing file means something."""
    try:
        content = read_text(path)
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise InputError(path, f"cannot read {what}: {exc.strerror or exc}") from None
    return parse_toml_text(content, path, what)


def parse_toml_text(content: str, path: str | Path, what: str) -> tuple[dict[str, Any], Source]:
    """``content``, read before from ``path`` (a pipe can be read only once), parsed as
    :func:`read_toml` parses a file, its errors naming ``path``."""
    source = Source(str(path), input_error, content, what)
    try:
        return parse_document(source), source
    except InputError as exc:
        # tomllib says "Invalid date or datetime" or "Expected newline" of a bad date:
        # the date rule says what is wrong with it, naming the key and the value
        # (imported here: the rule's patterns are compiled for a file refused only)
        from ogacq.io.dates import toml_date_error

        check_line_ends(path, content)  # tomllib: "Expected newline" (TOML's are LF, CRLF)
        lines = content.splitlines()
        if exc.line is not None and 0 < exc.line <= len(lines):
            line_text = lines[exc.line - 1]
            found = toml_date_error(path, exc.problem, line_text, exc.line)
            if found is not None:
                raise found from None
            comma = _DECIMAL_COMMA.match(line_text)
            if comma is not None:
                raise InputError(path, f"{comma['key']} = {comma['value']}: a decimal comma; "
                                 "TOML writes a number's decimals after a point: "
                                 f"{comma['key']} = {comma['value'].replace(',', '.')}",
                                 exc.line) from None
        raise


# ``key = 0,05``: what tomllib says only "Expected newline" of
_DECIMAL_COMMA = re.compile(r"[ \t]*(?P<key>[A-Za-z0-9_.\-\"]+)[ \t]*=[ \t]*"
                            r"(?P<value>[+-]?[0-9]+,[0-9]+)[ \t]*(#.*)?$")


def load_toml(path: str | Path, schema: Table, what: str) -> tuple[Any, Source]:
    """The file checked against ``schema`` and built; a missing file is refused."""
    try:
        data, source = read_toml(path, what)
    except FileNotFoundError:
        raise InputError(path, f"no such {what.removeprefix('the ')}") from None
    return load(schema, data, source), source
