"""Numbers as a person reads them: a parameter's headline is its value with the
expanded uncertainty of the record (``ogacq.uncertainty.reporting``, the one rule);
a detail (a diagnosis's effect) with as many decimals as its std allows."""

from __future__ import annotations

import math
from typing import TypeGuard

from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import expanded_mm, result_entry, result_headline


def finite(x: float | None) -> TypeGuard[float]:
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



__all__ = ["UM_PER_MM", "decimals_for", "duration", "expanded_mm", "finite", "measure",
           "plain", "result_entry", "result_headline", "signed", "um"]
