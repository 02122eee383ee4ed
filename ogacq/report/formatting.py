"""Numbers as a person reads them: a parameter's headline is its value with the
expanded uncertainty of the record (``ogacq.uncertainty.reporting``, the one rule);
a detail (a diagnosis's effect) with as many decimals as its std allows."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ogacq.uncertainty.reporting import Headline, entry_headline

UM_PER_MM = 1000.0


def finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)


def decimals_for(std: float | None, default: int = 4) -> int:
    """Decimals that show the std to two significant digits (0 to 6)."""
    if not finite(std) or std <= 0:
        return default
    return max(0, min(6, 1 - math.floor(math.log10(std))))


def measure(value: float, std: float | None, unit: str) -> str:
    """``+0.03586 ± 0.00057 mm``; a value the data do not determine (infinite or unknown
    std) reads ``not determined``: the fit's number for it is arbitrary."""
    if not finite(value) or not finite(std):
        return "not determined"
    digits = decimals_for(std)
    return f"{value:+.{digits}f} ± {std:.{digits}f} {unit}"


def signed(value: float | None, digits: int = 4) -> str:
    return f"{value:+.{digits}f}" if finite(value) else "-"


def plain(value: float | None, digits: int = 4) -> str:
    return f"{value:.{digits}f}" if finite(value) else "-"


def um(value_mm: float | None, digits: int = 2) -> str:
    """A length in mm written in micrometres, the unit of leftovers and noise."""
    return f"{value_mm * UM_PER_MM:.{digits}f} µm" if finite(value_mm) else "-"


def duration(seconds: float | None) -> str:
    if not finite(seconds):
        return "-"
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    if hours:
        return f"{hours} h {minutes:02d} min"
    return f"{minutes} min {secs:02d} s" if minutes else f"{secs} s"


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
