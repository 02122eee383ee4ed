"""The nominal machine: what the machine file says (INTERCHANGE.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace


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


# The Orthoglide prototype of the papers: L = 310.25 mm (2008 section 2.1), rho from
# -100 to +60 mm (2008 section 4.1), comparator indicators of 10 um resolution (2006
# section 4 "Experimental setup", 2008 section 4.1; MODEL.md "Machine").
PAPER_PROTOTYPE = MachineSpec(leg_length_mm=310.25, rho_min_mm=-100.0, rho_max_mm=60.0,
                              gauge_resolution_mm=0.01, name="Orthoglide prototype")
# The same machine with the 1 um digital indicators the 2008 paper recommends for
# industrial use (section 4.1): what the demo and the wizard's rehearsal simulate.
DIGITAL_INDICATOR_RESOLUTION_MM = 0.001
PAPER_PROTOTYPE_DIGITAL = replace(PAPER_PROTOTYPE,
                                  gauge_resolution_mm=DIGITAL_INDICATOR_RESOLUTION_MM)
PAPER_PROTOTYPE_DIGITAL_NOTE = "the papers' Orthoglide prototype, with 1 um digital indicators"
