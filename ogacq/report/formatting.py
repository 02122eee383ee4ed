"""Numbers as a person reads them; a detail (a diagnosis's effect) by the rule of
``ogacq.uncertainty.reporting``, its std in place of U."""

from __future__ import annotations

import math
from typing import TypeGuard

from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import measure  # the console's rule too


def finite(x: float | None) -> TypeGuard[float]:
    return x is not None and math.isfinite(x)


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


__all__ = ["UM_PER_MM", "duration", "finite", "measure", "plain", "signed", "um"]
