"""Units as ogacq shows them: lengths are kept in mm everywhere; what is left over
(residuals, noise, drift) is shown in micrometres."""

from __future__ import annotations

from collections.abc import Mapping

UM_PER_MM = 1000.0


def signed_per_axis(values_mm: Mapping[str, float]) -> str:
    """``x +0.1234, y -0.0100``: a value per axis, signed, to 0.1 µm (the unit follows
    in the sentence)."""
    return ", ".join(f"{a} {v:+.4f}" for a, v in values_mm.items())
