"""The nominal machine: what the machine file says (INTERCHANGE.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # a machine file's [tolerances]: the class built only for one
    from ogacq.model.tolerances import Tolerances

DECISION_RULES = ("guard-band", "simple")
# Steel legs when the machine file does not say: the linear expansion coefficient
# of carbon steel, 11.5e-6 /K (about 10..13e-6 /K across carbon steels; no single
# normative source, a handbook figure), the default docs/calibration-record.md
# section 1 names.
STEEL_EXPANSION_PPM_PER_K = 11.5
# The reference temperature of dimensional measurements (ISO 1:2022, 20 degC): the
# machine's nominal leg length is taken to hold there.
REFERENCE_TEMPERATURE_C = 20.0


# A dial indicator's graduation is 0.01 mm (0.1 mm on the coarsest), a digital
# indicator's step 0.01 to 0.0001 mm and a length gauge's down to 0.00001 mm; its
# repeatability lies in the same span (Mitutoyo catalogue, "Indicators"; no other source).
GAUGE_STEP_RANGE_MM = (1e-6, 0.1)
# No parallel machine's leg or travel is under a millimetre: such a value in the machine
# file was written in metres (no source).
MACHINE_LENGTH_FLOOR_MM = 1.0
# Ball screws are made with leads from 1 mm (miniature screws) to 100 mm (high-helix
# screws for fast axes): THK "Ball Screw" general catalogue, lead tables A15; a
# gear or belt between motor and screw gives a motor revolution of the same order.
SCREW_LEAD_RANGE_MM = (0.5, 100.0)
SCREW_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Screw:
    """What the machine file states of one axis's drive: ``lead_mm`` the travel per
    revolution of its screw and ``revolution_mm`` the travel per revolution of its motor
    (encoder), where a belt or gear sits between them (None: not stated). A screw's
    lead error and its wobble repeat every lead; an encoder's interpolation error and
    a motor's cogging every motor revolution: the periods a separating scan must
    sample (``ogacq.protocol.scan_design``)."""

    lead_mm: float | None = None
    revolution_mm: float | None = None

    def periods_mm(self) -> tuple[float, ...]:
        """The periods an error of this drive repeats with: each stated revolution."""
        return tuple(sorted({p for p in (self.lead_mm, self.revolution_mm) if p}))


@dataclass(frozen=True)
class MachineSpec:
    """A machine's nominal geometry and gauges (the machine file, INTERCHANGE.md), with
    its identity and acceptance tolerances."""

    leg_length_mm: float
    rho_min_mm: float
    rho_max_mm: float
    gauge_resolution_mm: float
    gauge_repeatability_mm: float | None = None
    name: str = ""
    serial: str = ""
    # the legs' linear expansion coefficient, 1e-6 /K; None: not stated (steel assumed
    # where a number is needed, see ``expansion_ppm_per_k``)
    leg_expansion_ppm_per_k: float | None = None
    tolerances: Tolerances | None = None
    # each axis's drive as the file states it, by axis name (sorted; a tuple: hashable)
    screws: tuple[tuple[str, Screw], ...] = ()

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError("; ".join(problems))

    def problems(self) -> list[str]:
        """What makes this geometry impossible, in words (empty when fine)."""
        out = []
        for key in ("leg_length_mm", "rho_min_mm", "rho_max_mm"):
            value = getattr(self, key)
            if 0 < abs(value) < MACHINE_LENGTH_FLOOR_MM:  # a leg, a travel shorter than 1 mm
                out.append(f"{key} = {value:g} mm: metres? ({value * 1000:g} mm: the machine "
                           "file's lengths are in millimetres)")
        if not self.leg_length_mm > 0:
            out.append(f"leg_length_mm must be positive, got {self.leg_length_mm}")
        if not self.rho_min_mm < 0 < self.rho_max_mm:
            out.append("need rho_min_mm < 0 < rho_max_mm, "
                       f"got {self.rho_min_mm}, {self.rho_max_mm}")
        if self.leg_length_mm > 0 and max(abs(self.rho_min_mm), abs(self.rho_max_mm)) >= \
                self.leg_length_mm:
            out.append("the Max/Min postures must lie within one leg length of the zero posture "
                       f"(|rho| < {self.leg_length_mm} mm)")
        for key in ("gauge_resolution_mm", "gauge_repeatability_mm"):
            value = getattr(self, key)
            if value is None:
                continue
            if not value > 0:
                out.append(f"{key} must be positive, got {value}")
            elif not GAUGE_STEP_RANGE_MM[0] <= value <= GAUGE_STEP_RANGE_MM[1]:
                out.append(f"{key} = {value:g} mm is no indicator's (they show "
                           f"{GAUGE_STEP_RANGE_MM[0]:g} to {GAUGE_STEP_RANGE_MM[1]:g} mm): "
                           + ("micrometres written as mm?" if value > 1 else
                              "is the unit mm?"))
        if self.leg_expansion_ppm_per_k is not None and not (
                0 <= self.leg_expansion_ppm_per_k < 1000):
            out.append("leg_expansion_ppm_per_k must be 0..1000 (steel 11.5), "
                       f"got {self.leg_expansion_ppm_per_k}")
        return out + self._screw_problems()

    def _screw_problems(self) -> list[str]:
        out = []
        low, high = SCREW_LEAD_RANGE_MM
        for axis, screw in self.screws:
            if axis not in SCREW_AXES:
                out.append(f"screws.{axis}: no such axis (x, y or z)")
                continue
            for key in ("lead_mm", "revolution_mm"):
                value = getattr(screw, key)
                if value is not None and not low <= value <= high:
                    out.append(f"screws.{axis}.{key} = {value:g} mm is no drive's (screws "
                               f"advance {low:g} to {high:g} mm a revolution): "
                               + ("micrometres written as mm?" if value > high else
                                  "is the unit mm?"))
        return out

    def screw(self, axis: str) -> Screw:
        """What the file states of ``axis``'s drive (an empty Screw: nothing)."""
        return dict(self.screws).get(axis, Screw())

    @property
    def expansion_ppm_per_k(self) -> float:
        """The legs' expansion coefficient: the file's, or steel's."""
        if self.leg_expansion_ppm_per_k is None:
            return STEEL_EXPANSION_PPM_PER_K
        return self.leg_expansion_ppm_per_k

    def leg_expansion_mm(self, temperature_c: float) -> float:
        """How much longer the legs are at ``temperature_c`` than at 20 degC:
        alpha L (T - 20 degC), linear expansion."""
        return self.expansion_ppm_per_k * 1e-6 * self.leg_length_mm * (
            temperature_c - REFERENCE_TEMPERATURE_C)

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
