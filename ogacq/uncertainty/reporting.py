"""How a result and its uncertainty are written for a person to read: the one rule
of every headline (the console's summaries, the wizard's result, the report's
header, Results and figures).

JCGM 100:2008 (GUM) 7.2.6: the expanded uncertainty U is quoted to at most two
significant digits, and the estimate is rounded to the same decimal place; 7.2.2
and 7.2.4: U is stated with its coverage factor k. Rounding is to the nearest
digit (GUM 7.2.6 leaves rounding up to "common sense"; at two significant digits
the nearest is never more than 5 % below U, and every decision ogacq makes uses
the unrounded U). The standard deviation of the fit is a detail, shown only
where the detail is (the refit table, the budget).

Kept import-light (no numpy): the command line imports it at start-up.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ogacq.model.instrument import finite_number

SIGNIFICANT_DIGITS = 2  # GUM 7.2.6: "at most two significant digits"
MAX_DECIMALS = 9  # below 1 nm in mm: a U smaller than this is shown as 0
DEFAULT_DECIMALS = 4  # a value without U: 0.1 um in mm


def _finite(x: float | None) -> bool:
    return x is not None and not isinstance(x, bool) and math.isfinite(x)


def uncertainty_decimals(u: float) -> int:
    """Decimals that show ``u`` (> 0) to two significant digits, after rounding: 0.00996
    rounds to 0.010, shown with three decimals, not 0.0100. Negative for a U of 100
    or more (0.0 decimals shown; the value is rounded to tens)."""
    decimals = SIGNIFICANT_DIGITS - 1 - math.floor(math.log10(u))
    if round(u, decimals) >= 10.0 ** (SIGNIFICANT_DIGITS - decimals):  # 0.00996 -> 0.0100
        decimals -= 1
    return min(decimals, MAX_DECIMALS)


def fixed(value: float, decimals: int, *, sign: bool = False) -> str:
    """``value`` rounded to ``decimals`` places (a negative count rounds to tens,
    hundreds); ``-0.0`` is written without its sign."""
    rounded = round(value, decimals)
    if rounded == 0:
        rounded = 0.0
    return f"{rounded:{'+' if sign else ''}.{max(decimals, 0)}f}"


@dataclass(frozen=True)
class Headline:
    """A value with its expanded uncertainty, as a person reads it."""

    value: str  # "+0.0347", or "not determined"
    U: str | None  # "0.0035"; None when U was not evaluated
    k: float | None
    unit: str
    complete: bool = True  # False: the budget left a source out (U understated)

    @property
    def k_text(self) -> str:
        return f"k = {self.k:g}" if self.k is not None else "k not stated"

    def __str__(self) -> str:
        """``+0.0347 ± 0.0035 mm (k = 2)``; ``+0.0347 mm (U not evaluated)``."""
        if self.U is None:
            if self.value == NOT_DETERMINED:
                return NOT_DETERMINED
            return f"{self.value} {self.unit} (U not evaluated)"
        incomplete = "; budget incomplete" if not self.complete else ""
        return f"{self.value} ± {self.U} {self.unit} ({self.k_text}{incomplete})"


NOT_DETERMINED = "not determined"


def headline(value: float | None, U: float | None, k: float | None, unit: str, *,
             complete: bool = True, sign: bool = True) -> Headline:
    """``value`` and its expanded uncertainty ``U`` (coverage factor ``k``) rounded by
    the GUM rule; a value without a finite U keeps DEFAULT_DECIMALS and says U was
    not evaluated; a value that is not finite is "not determined"."""
    if not _finite(value):
        return Headline(NOT_DETERMINED, None, k, unit, complete)
    assert value is not None
    if not _finite(U) or U is None or U < 0:
        return Headline(fixed(value, DEFAULT_DECIMALS, sign=sign), None, k, unit, complete)
    decimals = uncertainty_decimals(U) if U > 0 else DEFAULT_DECIMALS
    return Headline(fixed(value, decimals, sign=sign), fixed(U, decimals), k, unit, complete)


def rounded(value: float | None, U: float | None, *, sign: bool = False) -> str:
    """Another quantity of the same row (a simulator's truth, an error) at the
    decimal place of ``U``; ``-`` when it is not a number."""
    if not _finite(value):
        return "-"
    assert value is not None
    decimals = uncertainty_decimals(U) if _finite(U) and U is not None and U > 0 \
        else DEFAULT_DECIMALS
    return fixed(value, decimals, sign=sign)


def two_digits(u: float | None) -> str:
    """An uncertainty alone (u, a std) to two significant digits; ``-`` when unknown."""
    if not _finite(u) or u is None or u < 0:
        return "-"
    return fixed(u, uncertainty_decimals(u)) if u > 0 else "0"


def entry_headline(entry: Mapping[str, Any] | None, unit: str = "mm") -> Headline:
    """The headline of one parameter of a record's ``results`` (``value_mm``, ``U_mm``,
    ``k``, ``complete``: docs/calibration-record.md section 5)."""
    entry = entry or {}
    complete = entry.get("complete")
    return headline(finite_number(entry.get("value_mm")), finite_number(entry.get("U_mm")),
                    finite_number(entry.get("k")), str(entry.get("unit") or unit),
                    complete=complete is not False)


def result_entry(results: Mapping[str, Any] | None, name: str) -> Mapping[str, Any]:
    """``joint_offset.x``'s entry of a record's ``results`` (empty when absent)."""
    group, _, where = name.partition(".")
    entry = ((results or {}).get(group) or {}).get(where)
    return entry if isinstance(entry, Mapping) else {}


def result_headline(results: Mapping[str, Any] | None, name: str, value: float,
                    unit: str) -> Headline:
    """The headline of parameter ``name`` (its ``value`` as identified, its U from the
    record's ``results``)."""
    return entry_headline({**result_entry(results, name), "value_mm": value}, unit)


def expanded_mm(results: Mapping[str, Any] | None, name: str) -> float | None:
    """The U of parameter ``name`` in the record, None when not evaluated."""
    U = result_entry(results, name).get("U_mm")
    return float(U) if isinstance(U, int | float) and not isinstance(U, bool) \
        and math.isfinite(U) else None


# A detail's value with its std (a diagnosis's effect, on the console and the page).
def measure(value: float, std: float | None, unit: str) -> str:
    """``+0.03586 ± 0.00057 mm``; a value the data do not determine (infinite or unknown
    std) reads ``not determined``: the fit's number for it is arbitrary."""
    if not _finite(value) or not _finite(std) or std is None:
        return "not determined"
    # the one rule of every headline (a std of 100 ppm gave "+2908 ± 100" here and
    # "+2910" where the same effect's value was rounded beside it)
    return f"{rounded(value, std, sign=True)} ± {two_digits(std)} {unit}"
