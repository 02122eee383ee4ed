"""The library effects a controller can compensate, as error maps.

The exact model (``ogacq/model/measurement.py``) puts joint i at
``L + q (1 + s) + drho - a b / 2``: with the encoder scale s (ppm) and the lost
motion b (mm), the joint's error for a target q approached from side a
(+1 moving toward +q) is, besides the joint offset drho,

    e(q, a) = s q - a b / 2        (actual minus commanded, AxisMap's sign)

so e+ - e- = -b, as ``AxisMap`` states for lost motion. The map is made zero at
its reference forward; the constant taken off, ``e(ref, +1)``, is part of the
joint offset, which the offsets carry: the offset to write moves by it
(``offset_shift_mm``), so that together they correct e once.

The other effects of the library are no joint error: a squareness or an axis
offset is the geometry of two axes (a per-joint table cannot correct it), a leg
length is the leg's, drift is time, and the gauge's position and gain are the
measurement's. ``COMPENSABLE`` says which are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.model.units import UM_PER_MM
from ogacq.uncertainty.reporting import headline

COMPENSABLE = ("encoder_scale", "backlash")
PPM = 1e-6
COVERAGE_K = 2.0  # the record's k (ogacq.uncertainty.budget.COVERAGE_FACTOR, JCGM 100 6.3.3)
# The grid a library effect's map is tabulated on: its errors are linear or constant
# in q, so any grid holds them exactly; this one suits the tables it is resampled to.
MAP_STEP_MM = 5.0


@dataclass(frozen=True)
class EffectValue:
    name: str  # "encoder_scale.x"
    value: float  # in the effect's unit (ppm, mm)
    std: float  # standard uncertainty, same unit

    @property
    def kind(self) -> str:
        return self.name.split(".")[0]

    @property
    def axis(self) -> str:
        return self.name.split(".")[1]


def compensable(name: str) -> bool:
    return name.split(".")[0] in COMPENSABLE


def map_positions(machine: MachineSpec, step_mm: float = MAP_STEP_MM,
                  span_mm: tuple[float, float] | None = None) -> np.ndarray:
    """The travel rho_min..rho_max (or ``span_mm``) in steps of at most ``step_mm``, both
    ends included."""
    lo, hi = (machine.rho_min_mm, machine.rho_max_mm) if span_mm is None else span_mm
    count = int(math.ceil((hi - lo) / step_mm - 1e-9)) + 1
    return np.linspace(lo, hi, count)


def _stated(value: float, std: float, unit: str, *, sign: bool = True) -> str:
    """The effect as the record states a result: ``+408 ± 35 ppm (k = 2)``, U = 2 u to
    two significant digits and the value to its decimal place (JCGM 100:2008 7.2.6,
    ``ogacq.uncertainty.reporting``); the map's u stays the std (k = 1)."""
    return str(headline(value, COVERAGE_K * std, COVERAGE_K, unit, sign=sign))


@dataclass(frozen=True)
class EffectMap:
    """One axis's map of its library effects, and the constant moved to its offset."""

    axis_map: AxisMap
    offset_shift_mm: float  # e(ref, +1): add it to the identified joint offset


def effect_maps(effects: Mapping[str, EffectValue], machine: MachineSpec, *,
                reference_mm: float = 0.0, step_mm: float = MAP_STEP_MM,
                spans: Mapping[str, tuple[float, float]] | None = None,
                references: Mapping[str, float] | None = None,
                ) -> dict[str, EffectMap]:
    """Per axis, the map of its compensable effects among ``effects`` (others are
    ignored), over the travel or the axis's span in ``spans``, zero at ``reference_mm``
    or the axis's entry in ``references``; the uncertainties propagate each effect's
    std, the effects taken as uncorrelated (the diagnosis reports a std per effect, not
    their covariance)."""
    out: dict[str, EffectMap] = {}
    for axis in AXES:
        q = map_positions(machine, step_mm, (spans or {}).get(axis))
        ref = (references or {}).get(axis, reference_mm)
        scale = effects.get(f"encoder_scale.{axis}")
        lost = effects.get(f"backlash.{axis}")
        if scale is None and lost is None:
            continue
        s, u_s = (scale.value * PPM, scale.std * PPM) if scale else (0.0, 0.0)
        b, u_b = (lost.value, lost.std) if lost else (0.0, 0.0)
        fwd_full = s * q - b / 2
        rev_full = s * q + b / 2
        shift = s * ref - b / 2  # e(ref, +1)
        dq = q - ref
        u_fwd = np.abs(dq) * u_s  # zero at the reference forward, as the map is
        u_rev = np.hypot(np.abs(dq) * u_s, u_b)
        parts = [f"encoder scale {_stated(scale.value, scale.std, 'ppm')}" if scale else "",
                 f"backlash {_stated(b * UM_PER_MM, u_b * UM_PER_MM, 'µm', sign=False)}"
                 if lost else ""]
        names = tuple(e.name for e in (scale, lost) if e is not None)
        out[axis] = EffectMap(AxisMap(
            axis=axis, positions_mm=tuple(float(v) for v in q),
            forward_mm=tuple(float(v) for v in fwd_full - shift),
            reverse_mm=tuple(float(v) for v in rev_full - shift),
            u_forward_mm=tuple(float(v) for v in u_fwd),
            u_reverse_mm=tuple(float(v) for v in u_rev),
            reference_mm=ref, source=", ".join(p for p in parts if p),
            extra={"effects": list(names)}), float(shift))
    return out
