"""Units as ogacq shows them: lengths are kept in mm everywhere; what is left over
(residuals, noise, drift) is shown in micrometres."""

from __future__ import annotations

import math
from collections.abc import Mapping

UM_PER_MM = 1000.0


def signed_per_axis(values_mm: Mapping[str, float]) -> str:
    """``x +0.1234, y -0.0100``: a value per axis, signed, to 0.1 µm (the unit follows
    in the sentence)."""
    return ", ".join(f"{a} {v:+.4f}" for a, v in values_mm.items())


def json_number(x: float | None, digits: int) -> float | None:
    """``x`` rounded to ``digits`` decimals for a JSON document; null where it is not a
    finite number (JSON has no NaN nor infinity: a std not determined)."""
    return None if x is None or not math.isfinite(x) else round(float(x), digits)
