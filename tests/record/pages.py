"""What a reader sees of a record: its values as the page prints them, and the
page's text, to check one against the other."""

from __future__ import annotations

import html
import math
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


def two_significant(u: float) -> str:
    """An uncertainty to two significant digits, trailing zeros kept (0.00198 -> 0.0020,
    0.00996 -> 0.010), written here from the rule, not ogacq's. (numpy's positional
    formatting drops the zero a rounding up leaves: 0.00198 -> 0.002.)"""
    exponent = math.floor(math.log10(u))
    decimals = 1 - exponent
    q = round(u, decimals)
    if q >= 10.0 ** (exponent + 1):  # rounded up into the next decade: one digit less
        decimals -= 1
    return f"{q:.{max(decimals, 0)}f}"


def gum(value: float, U: float) -> tuple[str, str]:
    """JCGM 100:2008 7.2.6 written out independently: U to two significant digits,
    the value (signed) to the same decimal place."""
    u_text = two_significant(U)
    decimals = len(u_text.split(".")[1]) if "." in u_text else 0
    value_text = f"{value:+.{decimals}f}"
    return ("+" + value_text[1:] if float(value_text) == 0 else value_text), u_text


# The results a person reads: rounded by the headline rule (record.json keeps every
# digit); each number's spelling on the page.
ROUNDED = ("results.", "validation_results.", "acceptance.", "budget.", "verdict.",
           "monte_carlo.")


def check_spelling(path: str, value: float, record: dict) -> str | None:
    """A figure of the Monte-Carlo check as the page writes it: a u to two significant
    digits, the ratio to two decimals, the mean (signed) and the interval's ends at the
    decimal place of the budget's u_c."""
    _, figure, rest = path.split(".", 2)
    if figure in ("u_mm", "u_c_mm") and value:
        return two_significant(value)
    if figure == "ratio":
        return f"{value:.2f}"
    u = record["monte_carlo"].get("u_c_mm", {}).get(rest.split("[")[0])
    if figure not in ("mean_mm", "interval_95_mm") or not u:
        return None
    text = gum(value, u)[0]
    return text if figure == "mean_mm" else text.removeprefix("+")


def rounded_spelling(path: str, value: Any, record: dict) -> str | None:
    """How the page writes a number a person reads as a result (``results``, and the
    acceptance's deviations and the budget's contributions): a value at its U's decimal
    place, u, U and the fit std to two significant digits, the effective dof whole."""
    if path.startswith("monte_carlo."):
        return check_spelling(path, value, record)
    *where, key = path.split(".")
    if where == ["verdict"]:  # a p-value as the terminal says it (format_p)
        from ogacq.identify.consistency import format_p

        if key == "chi2_dof":  # as the verdict's text says it: "per dof 1.46"
            return f"{value:.3g}"
        return format_p(value) if key == "p" or key.startswith("p_") else None
    if key in ("U_mm", "u_mm", "std_mm", "u_input") and value:
        return two_significant(value)
    if key == "sensitivity":  # to three significant digits, enough for u's two
        return f"{value:.3g}"
    if key == "dof_eff":
        return f"{value:.0f}"
    if key not in ("value_mm", "temperature_correction_mm"):
        return None
    entry = record
    for part in where:  # e.g. acceptance, as_found, rows[3]
        name, *indices = part.split("[")
        entry = entry[name]
        for index in indices:
            entry = entry[int(index.rstrip("]"))]
    U = entry.get("U_mm")
    return gum(value, U)[0] if U else None


def unshown(record: dict, text: str) -> list[str]:
    """The record's values the page's ``text`` does not show, as ``path = value``: as
    record.json holds them, or for the results as the headline rule rounds them."""
    text = " ".join(text.split())
    missing = []
    for path, value in leaves(record):
        spelled = printed(value)
        if spelled is None or spelled in text:
            continue
        if path.startswith(ROUNDED) and isinstance(value, int | float):
            spelled = rounded_spelling(path, value, record)
            if spelled is not None and spelled in text:
                continue
        missing.append(f"{path} = {value!r}")
    return missing


def page_text(page: str) -> str:
    """The page as a reader sees it: no tags, no style, no embedded images."""
    page = re.sub(r"<style>.*?</style>", " ", page, flags=re.S)
    page = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", page)
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", page)).split())
