"""What a gauge should read: the ranges the wizard checks readings against.

Two sources, the closer one first:
- earlier readings of the same gauge at the same posture (later cycles must
  repeat them within the gauge's repeatability);
- the measurement model: from the gauge's reading at its setting posture, a
  posture moves the reading by the nominal deviation plus at most
  ``sum_k |d reading / d offset_k| * max_offset`` for joint offsets up to
  ``max_offset_mm`` (the papers' deviations are linear in the offsets, eq. 7).

The same bound says how much travel a gauge needs on each side of where it is
set, which is the wizard's "mid-range" check.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, predict_coordinates
from ogacq.model.parameters import AXES, vector

_STEP_MM = 1e-3  # finite-difference step on the joint offsets


class PlannedReading(Protocol):
    """What a planned reading says here: its posture and the gauges read there (the
    plan's ``Read`` is one; the model sits below the plan and does not import it)."""

    @property
    def gauges(self) -> Sequence[str]: ...

    @property
    def q_mm(self) -> Sequence[float]: ...


def deviation_model(machine: MachineSpec, gauge: str, q_set_mm: Sequence[float],
                    q_mm: Sequence[float]) -> tuple[float, np.ndarray]:
    """Nominal change of the reading from ``q_set_mm`` to ``q_mm``, and its
    sensitivity to the three joint offsets (mm per mm)."""
    axis, leg = Gauge.parse(gauge).indices  # y_x: (1, 0), the axis read along, the leg
    layout = ReadingsLayout.build([list(q_set_mm), list(q_mm)], [leg, leg], [axis, axis])
    thetas = [vector()] + [vector({f"joint_offset.{a}": _STEP_MM}) for a in AXES]
    coords = predict_coordinates(np.array(thetas), layout, machine)
    deviations = coords[:, 1] - coords[:, 0]
    return float(deviations[0]), (deviations[1:] - deviations[0]) / _STEP_MM


def travel_needed_mm(machine: MachineSpec, gauge: str, steps: Iterable[PlannedReading],
                     max_offset_mm: float) -> float:
    """Largest move of this gauge's reading over the plan's postures."""
    mine = [s for s in steps if gauge in s.gauges]
    if not mine:
        return 0.0
    q_set = mine[0].q_mm
    worst = 0.0
    for step in mine:
        nominal, slope = deviation_model(machine, gauge, q_set, step.q_mm)
        worst = max(worst, abs(nominal) + float(np.abs(slope).sum()) * max_offset_mm)
    return worst


@dataclass(frozen=True)
class ExpectedRange:
    low_mm: float
    high_mm: float
    basis: str  # said to the technician: where the range comes from

    def contains(self, value_mm: float) -> bool:
        return self.low_mm <= value_mm <= self.high_mm

    def describe(self, decimals: int = 3) -> str:
        return f"{self.low_mm:.{decimals}f} … {self.high_mm:.{decimals}f} mm ({self.basis})"


@dataclass
class ReadingExpectations:
    """Expected range of each next reading, from the model and earlier readings."""

    machine: MachineSpec
    max_offset_mm: float = 2.0
    repeat_tolerance_mm: float = 0.05
    gauge_range_mm: float = 12.7
    _history: dict[str, list[tuple[tuple[float, ...], float]]] = field(default_factory=dict)
    _reference: dict[str, tuple[tuple[float, ...], float]] = field(default_factory=dict)

    def observe(self, gauge: str, q_mm: Sequence[float], value_mm: float) -> None:
        """A reading of ``gauge`` at ``q_mm``; the first one is its reference."""
        q = tuple(float(v) for v in q_mm)
        self._history.setdefault(gauge, []).append((q, float(value_mm)))
        self._reference.setdefault(gauge, (q, float(value_mm)))

    def set_reference(self, gauge: str, q_mm: Sequence[float], value_mm: float) -> None:
        """What the gauge read when it was set (before the first recorded reading)."""
        if not self._history.get(gauge):
            self._reference[gauge] = (tuple(float(v) for v in q_mm), float(value_mm))

    def expected(self, gauge: str, q_mm: Sequence[float]) -> ExpectedRange:
        q = np.asarray(q_mm, dtype=float)
        same = [v for p, v in self._history.get(gauge, []) if np.allclose(p, q, atol=1e-6)]
        if same:
            centre = float(np.mean(same))
            tol = self.repeat_tolerance_mm
            return ExpectedRange(centre - tol, centre + tol,
                                 f"{len(same)} earlier reading{'s' * (len(same) > 1)} "
                                 "at this posture")
        if gauge in self._reference:
            q_ref, value = self._reference[gauge]
            if np.allclose(q_ref, q, atol=1e-6):
                tol = self.repeat_tolerance_mm
                return ExpectedRange(value - tol, value + tol, "its value when it was set")
            nominal, slope = deviation_model(self.machine, gauge, q_ref, q_mm)
            half = float(np.abs(slope).sum()) * self.max_offset_mm + self.repeat_tolerance_mm
            centre = value + nominal
            return ExpectedRange(centre - half, centre + half,
                                 f"model, joint offsets up to ±{self.max_offset_mm:g} mm")
        span = self.gauge_range_mm
        return ExpectedRange(-span, span, "the gauge's range: no reference yet")
