"""What a reader sees of a record: its values as the page prints them, and the
page's text, to check one against the other."""

from __future__ import annotations

import html
import re
from collections.abc import Iterator
from typing import Any

import numpy as np


def leaves(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """Every scalar of a JSON document with its path (``instruments[0].serial``)."""
    if isinstance(value, dict):
        for key, inner in value.items():
            yield from leaves(inner, f"{path}.{key}" if path else key)
    elif isinstance(value, list):
        for k, inner in enumerate(value):
            yield from leaves(inner, f"{path}[{k}]")
    else:
        yield path, value


def printed(value: Any) -> str | None:
    """How the page prints a record value; None for what has no single spelling
    (nothing, a yes/no)."""
    if value is None or isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return str(np.format_float_positional(value, trim="-"))
    return " ".join(str(value).split())


def unshown(record: dict, text: str) -> list[str]:
    """The record's values the page's ``text`` does not show, as ``path = value``."""
    text = " ".join(text.split())
    return [f"{path} = {value!r}" for path, value in leaves(record)
            if (spelled := printed(value)) is not None and spelled not in text]


def page_text(page: str) -> str:
    """The page as a reader sees it: no tags, no style, no embedded images."""
    page = re.sub(r"<style>.*?</style>", " ", page, flags=re.S)
    page = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", page)
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", page)).split())
