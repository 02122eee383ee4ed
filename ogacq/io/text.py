"""Decoding the text files a user gives: UTF-8, the one encoding every format of
ogacq is defined in. A leading byte order mark (what a spreadsheet's "CSV UTF-8"
export and some editors write) is harmless and dropped; any other encoding is
named by its first wrong byte's line and column, so the user knows what to fix."""

from __future__ import annotations

import codecs
import re
from pathlib import Path

from ogacq.io.errors import InputError


def decode_text(data: bytes, path: str | Path) -> str:
    """``data`` (the content of ``path``, or its first lines) as text."""
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        raise InputError(path, "UTF-16 text (it begins with the byte order mark "
                         f"{data[:2].hex(' ').upper()}: a spreadsheet's \"Unicode text\"?); "
                         "save the file as UTF-8", 1)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line_start = data.rfind(b"\n", 0, exc.start) + 1
        column = len(data[line_start:exc.start].decode("utf-8")) + 1
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputError(path, f"not UTF-8 text (byte 0x{data[exc.start]:02x} at column "
                         f"{column}); save the file as UTF-8", line) from None
    return text.removeprefix("\ufeff")


def read_text(path: str | Path) -> str:
    """The whole file as text; OSError (a missing file included) passes through, for
    callers that say what the file was for."""
    return decode_text(Path(path).read_bytes(), path)


def strip_bom(data: bytes) -> bytes:
    """Bytes read line by line (sessions: JSON lines) without a leading BOM."""
    return data.removeprefix(codecs.BOM_UTF8)


def check_line_ends(path: str | Path, text: str) -> None:
    """Refuse a carriage return that ends no CRLF: the line end of classic Mac OS, which
    the formats do not take (docs/formats.md, "Text": LF or CRLF; TOML 1.0 the same)."""
    lone = _LONE_CR.search(text)
    if lone is not None:
        raise InputError(path, "a line ends in a lone carriage return (CR, the line end of "
                         "classic Mac OS): lines end in LF or CRLF; save the file with Unix "
                         "or Windows line ends", text.count("\n", 0, lone.start()) + 1)


_LONE_CR = re.compile(r"\r(?!\n)")
