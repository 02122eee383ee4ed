"""What an uncertainty budget is built from: plain values, checked once.

Callers build :class:`BudgetInputs` from whatever they hold (a fit, a session's
instruments and environment, a controller profile); :meth:`BudgetInputs.from_fit`
fills what the fit and the machine file already say.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from ogacq.identify.fit import FitResult
from ogacq.model.gauges import Gauge
from ogacq.model.machine import STEEL_EXPANSION_PPM_PER_K

# The ambient temperature is typed from a shop thermometer whose maker typically
# states +/-0.5 degC: taken as rectangular limits, u = 0.5 / sqrt(3) = 0.29 degC
# (JCGM 100:2008 4.3.7), rounded up to 0.3 degC. A calibrated thermometer's
# certificate gives a smaller one: pass it.
DEFAULT_THERMOMETER_U_C = 0.3
# Ambient temperatures outside this are a typing error, not a workshop.
PLAUSIBLE_AMBIENT_C = (-40.0, 80.0)


def standard_uncertainty(expanded_mm: float, coverage_factor: float) -> float:
    """A certificate's expanded uncertainty ``U`` with coverage factor ``k`` as a standard
    uncertainty ``U / k`` (JCGM 100:2008 4.3.3)."""
    if not expanded_mm >= 0:
        raise ValueError(f"certificate uncertainty must be >= 0 mm, got {expanded_mm}")
    if not coverage_factor > 0:
        raise ValueError(f"certificate coverage factor k must be > 0, got {coverage_factor}")
    return expanded_mm / coverage_factor


@dataclass(frozen=True)
class BudgetInputs:
    """Every input of the budget, in mm, degC and ppm/K. ``None`` means not known:
    the source is then listed as "not evaluated" (never as zero) and the budget is
    incomplete; except ``register_step_mm``, whose ``None`` means nothing is written
    to a controller (no rounding to account for).

    - ``gauge_noise_mm``: a reading's scatter, display rounding excluded (the fit's
      ``noise.scatter_mm``); ``gauge_noise_dof`` its degrees of freedom when it was
      measured from repeats (type A), ``None`` when stated (type B, infinite dof).
    - ``calibration_u_mm``: per gauge key (``"y_x"``) the certificate's ``U / k``,
      ``None`` for a gauge without a certificate; a gauge not listed is unknown too.
    - ``resolution_mm``: the gauges' display step.
    - ``ambient_start_c``/``ambient_end_c``: the temperatures recorded at the start and
      end of the campaign; ``thermometer_u_c`` the thermometer's standard uncertainty.
    - ``leg_expansion_ppm_per_k`` and ``leg_length_mm``: the legs' linear expansion
      coefficient and nominal length (their length error is ``alpha L (T - 20)``).
    - ``register_step_mm``: the controller's offset register step (``ControllerFacts
      .resolution_mm``), ``None`` when no write-back follows.
    """

    gauge_noise_mm: float | None
    resolution_mm: float | None
    leg_length_mm: float
    calibration_u_mm: Mapping[str, float | None] = field(default_factory=dict)
    gauge_noise_dof: int | None = None
    ambient_start_c: float | None = None
    ambient_end_c: float | None = None
    thermometer_u_c: float = DEFAULT_THERMOMETER_U_C
    leg_expansion_ppm_per_k: float | None = STEEL_EXPANSION_PPM_PER_K
    register_step_mm: float | None = None

    def __post_init__(self) -> None:
        _finite_number("gauge_noise_mm", self.gauge_noise_mm)
        _finite_number("resolution_mm", self.resolution_mm, zero_allowed=False)
        _finite_number("leg_length_mm", self.leg_length_mm, zero_allowed=False)
        _finite_number("thermometer_u_c", self.thermometer_u_c)
        _finite_number("leg_expansion_ppm_per_k", self.leg_expansion_ppm_per_k)
        _finite_number("register_step_mm", self.register_step_mm, zero_allowed=False)
        if self.gauge_noise_dof is not None and not (
                isinstance(self.gauge_noise_dof, int) and self.gauge_noise_dof >= 1):
            raise ValueError(f"gauge_noise_dof must be a whole number >= 1 (or None when the "
                             f"noise is stated), got {self.gauge_noise_dof!r}")
        for name in ("ambient_start_c", "ambient_end_c"):
            value = getattr(self, name)
            if value is None:
                continue
            low, high = PLAUSIBLE_AMBIENT_C
            if not (isinstance(value, int | float) and low <= value <= high):
                raise ValueError(f"{name} must be a temperature in degC between {low:g} and "
                                 f"{high:g}, got {value!r}")
        checked: dict[str, float | None] = {}
        for key, u in self.calibration_u_mm.items():
            try:
                Gauge.parse(key)
            except ValueError as exc:
                raise ValueError(f"calibration_u_mm: {exc}") from None
            _finite_number(f"calibration_u_mm[{key!r}]", u)
            checked[key] = None if u is None else float(u)
        object.__setattr__(self, "calibration_u_mm", MappingProxyType(checked))

    @classmethod
    def from_fit(cls, result: FitResult, **given: Any) -> BudgetInputs:
        """The inputs the fit and its machine file already hold (the gauge scatter and
        its dof when measured from repeats, the display step, the nominal leg length),
        completed by ``given`` (certificates, temperatures, register step...)."""
        noise = result.noise
        machine = result.observations.machine
        # An assumed noise (tabulated deviations without a stated repeatability) is
        # the display step standing in for the unknown scatter: not an evaluation.
        scatter = None if noise.assumed else noise.scatter_mm
        values: dict = {"gauge_noise_mm": scatter,
                        "gauge_noise_dof": noise.dof if noise.measured else None,
                        "resolution_mm": machine.gauge_resolution_mm,
                        "leg_length_mm": machine.leg_length_mm}
        values.update(given)
        return cls(**values)

    @property
    def ambient_range_c(self) -> tuple[float, float] | None:
        """The lowest and highest of the temperatures recorded; None unless both were."""
        if self.ambient_start_c is None or self.ambient_end_c is None:
            return None
        low, high = sorted((self.ambient_start_c, self.ambient_end_c))
        return low, high

    @property
    def alpha_l_mm_per_k(self) -> float | None:
        """``alpha L``: how much a leg grows per kelvin, mm/K."""
        if self.leg_expansion_ppm_per_k is None:
            return None
        return self.leg_expansion_ppm_per_k * 1e-6 * self.leg_length_mm


def _finite_number(name: str, value: float | None, *, zero_allowed: bool = True) -> None:
    """``value`` (None: not known) a finite number >= 0, or > 0 unless ``zero_allowed``."""
    if value is None:
        return
    if not (isinstance(value, int | float) and math.isfinite(value)
            and (value >= 0 if zero_allowed else value > 0)):
        raise ValueError(f"{name} must be a finite number {'>=' if zero_allowed else '>'} 0, "
                         f"got {value!r}")
