"""The nominal machine: what the machine file says (INTERCHANGE.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class MachineSpec:
    leg_length_mm: float
    rho_min_mm: float
    rho_max_mm: float
    gauge_resolution_mm: float
    gauge_repeatability_mm: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    def problems(self) -> list[str]:
        """What makes this geometry impossible, in words (empty when fine)."""
        out = []
        if not self.leg_length_mm > 0:
            out.append(f"leg_length_mm must be positive, got {self.leg_length_mm}")
        if not self.rho_min_mm < 0 < self.rho_max_mm:
            out.append("need rho_min_mm < 0 < rho_max_mm, "
                       f"got {self.rho_min_mm}, {self.rho_max_mm}")
        if self.leg_length_mm > 0 and max(abs(self.rho_min_mm), abs(self.rho_max_mm)) >= \
                self.leg_length_mm:
            out.append("the Max/Min postures must lie within one leg length of the zero posture "
                       f"(|rho| < {self.leg_length_mm})")
        if not self.gauge_resolution_mm > 0:
            out.append(f"gauge_resolution_mm must be positive, got {self.gauge_resolution_mm}")
        if self.gauge_repeatability_mm is not None and not self.gauge_repeatability_mm > 0:
            out.append("gauge_repeatability_mm must be positive, "
                       f"got {self.gauge_repeatability_mm}")
        return out

    @property
    def alpha_max_rad(self) -> float:
        return math.asin(self.rho_max_mm / self.leg_length_mm)

    @property
    def alpha_min_rad(self) -> float:
        return math.asin(self.rho_min_mm / self.leg_length_mm)


PAPER_PROTOTYPE = MachineSpec(leg_length_mm=310.25, rho_min_mm=-100.0, rho_max_mm=60.0,
                              gauge_resolution_mm=0.01, name="Orthoglide prototype")
