"""ISO 230-2 positioning test of one actuator by an axis scale: its targets, its cycle
and the figures of its readings.

ISO 230-2:2014 ("Determination of accuracy and repeatability of positioning of
numerically controlled axes") measures an axis with a length-measuring instrument
along it, here a scale along the actuator (``[axis_scale.x]``): it reads the joint's
actual displacement up to a constant, whatever the legs' kinematics make of it.

* Targets (4.3.2): at least five, at irregular intervals "to ensure that periodic
  errors are adequately sampled". The targets here are the fewest stratified ones
  (``ogacq.protocol.scan_design.stratified_targets``: both ends, one jittered in each
  stratum) whose phases leave no gap wider than a quarter period (four phases at
  least) for every lead the machine file states and its second harmonic, and for
  every lead from 2 to 40 mm (``UNSTATED_BAND_MM``): a screw of any common lead is
  sampled at several phases, so that its cyclic error shows in the deviations.
* Cycle (4.3, its linear cycle): each run goes past the lowest target by the overrun,
  reads every target upward, goes past the highest by the overrun and reads every
  target downward; ``runs`` runs (the standard's five; a setting). The other joints
  stay at their zero.
* Figures (clause 3, ``ogacq.compensation.iso230.iso230_figures``): at each target the
  mean deviation per direction and its s from the runs' scatter, then A, E, M, R, B.
  The scale reads up to a constant, so the deviations are taken about their mean over
  every reading (a constant is the joint offset's, which the legs' campaign
  identifies): E, M, A, R and B do not depend on it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.compensation.iso230 import Iso230Figures, iso230_figures
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.protocol.scan_design import (
    LARGEST_PHASE_GAP,
    UNSTATED_BAND_MM,
    jitters,
    stated_periods,
    worst_gap,
)
from ogacq.session.records import PositionRecord
from ogacq.session.store import LoadedSession

# ISO 230-2:2014 4.3 (its standard test cycle): five runs in each direction at each target.
ISO_RUNS = 5
FEWEST_TARGETS = 5  # ISO 230-2:2014 4.3.2: at least five targets
MOST_TARGETS = 400  # no source: beyond it a typo (a travel in um), refused
# Past the end targets before each run turns (ISO 230-2 4.3: the overrun at a
# reversal, "to ensure normal behaviour of the machine"): 2 mm, a few times any lost
# motion of a ball screw (no source: a choice within the travel's margin).
OVERRUN_MM = 2.0
SESSION_KIND = "positioning"  # its session header's "kind": not a campaign of the legs
S_SOURCE = "the scatter of the runs at each target (ISO 230-2's s), the scale's reading"


@dataclass(frozen=True)
class PositioningStep:
    """One move of the test: ``target_mm`` read (``read``) or passed (an overrun at a
    reversal), approached in ``direction`` (+1 upward, -1 downward) in run ``run``."""

    run: int
    direction: int
    target_mm: float
    read: bool

    @property
    def key(self) -> tuple[int, int, float]:
        return self.run, self.direction, round(self.target_mm, 6)


@dataclass(frozen=True)
class PositioningPlan:
    axis: str
    targets_mm: tuple[float, ...]
    runs: int = ISO_RUNS
    overrun_mm: float = OVERRUN_MM

    def q_of(self, target_mm: float) -> tuple[float, float, float]:
        """The joints' coordinates at a target: this axis there, the others at zero."""
        q = [0.0, 0.0, 0.0]
        q[AXES.index(self.axis)] = target_mm
        return q[0], q[1], q[2]

    def steps(self) -> Iterator[PositioningStep]:
        """Every move of the test in order (ISO 230-2 4.3's linear cycle)."""
        lo, hi = min(self.targets_mm), max(self.targets_mm)
        up = sorted(self.targets_mm)
        for run in range(1, self.runs + 1):
            yield PositioningStep(run, 1, lo - self.overrun_mm, False)
            yield from (PositioningStep(run, 1, t, True) for t in up)
            yield PositioningStep(run, -1, hi + self.overrun_mm, False)
            yield from (PositioningStep(run, -1, t, True) for t in reversed(up))

    @property
    def readings(self) -> int:
        return 2 * self.runs * len(self.targets_mm)

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "targets_mm": list(self.targets_mm), "runs": self.runs,
                "overrun_mm": self.overrun_mm, "standard": "ISO 230-2:2014, 4.3"}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> PositioningPlan:
        return cls(str(d["axis"]), tuple(float(t) for t in d["targets_mm"]), int(d["runs"]),
                   float(d["overrun_mm"]))


def positioning_plan(machine: MachineSpec, axis: str, *, runs: int = ISO_RUNS,
                     overrun_mm: float = OVERRUN_MM, drive_step_mm: float = 0.0,
                     ) -> PositioningPlan:
    """The test of ``axis``: targets over its travel less the overrun at each end, the
    fewest that sample every stated lead (and its second harmonic) and every lead from
    2 to 40 mm at four phases at least, each a whole count of the drive's
    ``drive_step_mm`` (a target the drive cannot take would be rounded where it is
    sent: the deviation would carry that rounding)."""
    if axis not in AXES:
        raise ValueError(f"no axis {axis!r}; axes are {', '.join(AXES)}")
    if runs < 1:
        raise ValueError(f"runs must be 1 or more, got {runs}")
    lo, hi = machine.rho_min_mm + overrun_mm, machine.rho_max_mm - overrun_mm
    if hi - lo <= 0:
        raise ValueError(f"the overrun of {overrun_mm:g} mm at each end leaves no travel")
    band = (UNSTATED_BAND_MM[0], min(UNSTATED_BAND_MM[1], hi - lo))
    periods = stated_periods(machine, (axis,))
    targets = _targets(lo, hi, band, periods)
    if drive_step_mm > 0:
        targets = np.unique(np.round(np.round(targets / drive_step_mm) * drive_step_mm, 9))
    return PositioningPlan(axis, tuple(float(t) for t in targets), runs, overrun_mm)


def _targets(lo: float, hi: float, band: tuple[float, float],
             periods: tuple[float, ...]) -> np.ndarray:
    """The fewest stratified targets (of the separating scan's jitters each count)
    leaving no phase gap beyond a quarter period over ``band`` and at ``periods``: the
    count found by doubling, then halving the interval (more targets sample at least as
    well)."""

    def sampling(n: int) -> np.ndarray | None:
        return next((t for t in jitters(lo, hi, n)
                     if worst_gap(t, band, periods) <= LARGEST_PHASE_GAP), None)

    low, high = FEWEST_TARGETS - 1, FEWEST_TARGETS
    found = sampling(high)
    while found is None:
        if high >= MOST_TARGETS:
            raise ValueError("no targets within the travel sample the leads from "
                             f"{band[0]:g} to {band[1]:g} mm")
        low, high = high, min(2 * high, MOST_TARGETS)
        found = sampling(high)
    while high - low > 1:
        middle = (low + high) // 2
        fewer = sampling(middle)
        low, high, found = (low, middle, fewer) if fewer is not None else (middle, high, found)
    assert found is not None
    return found


# --------------------------------------------------------------------------- figures


@dataclass(frozen=True)
class PositioningResult:
    """The test's readings reduced: per target, the mean deviation and s per direction
    (mm, about the mean of every reading), and the ISO 230-2 figures."""

    axis: str
    targets_mm: np.ndarray
    up_mm: np.ndarray
    down_mm: np.ndarray
    s_up_mm: np.ndarray
    s_down_mm: np.ndarray
    runs: int
    figures: Iso230Figures
    display_step_mm: float = 0.0  # the scale's

    @property
    def mean_mm(self) -> np.ndarray:
        """The mean bidirectional deviation at each target."""
        return (self.up_mm + self.down_mm) / 2.0

    @property
    def pooled_s_mm(self) -> float:
        """The runs' scatter pooled over every target and direction (one target's s of
        two runs has one degree of freedom; pooled, as many as the targets)."""
        return float(np.sqrt(np.mean(np.concatenate([self.s_up_mm, self.s_down_mm]) ** 2)))

    @property
    def noise_dof(self) -> int:
        return 2 * len(self.targets_mm) * (self.runs - 1)

    @property
    def u_mm(self) -> float:
        """The standard uncertainty of a mean deviation at a target: the pooled scatter
        over the square root of the runs, and the display step's rounding (a
        rectangular distribution of its width, JCGM 100:2008 F.2.2.1), not reduced by
        the runs: a scale whose noise is below its step repeats its rounding, and its
        runs then agree to the digit (s nought) about a value up to half a step off."""
        return math.hypot(self.pooled_s_mm / math.sqrt(self.runs),
                          self.display_step_mm / math.sqrt(12.0))

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "runs": self.runs,
                "targets_mm": [round(float(t), 6) for t in self.targets_mm],
                "deviation_up_mm": _rounded(self.up_mm),
                "deviation_down_mm": _rounded(self.down_mm),
                "s_up_mm": _rounded(self.s_up_mm), "s_down_mm": _rounded(self.s_down_mm),
                "iso230_2": self.figures.to_json()}


def _rounded(values: np.ndarray) -> list[float]:
    return [round(float(v), 7) for v in values]


@dataclass(frozen=True)
class ScaleReading:
    """One reading of the test: the scale at ``target_mm`` approached in ``direction``;
    ``meant_mm`` where the joint was meant to land there (the target, corrected by the
    maps in force and rounded by the drive to its step, less the maps' correction:
    ``TargetCorrection.nominal``)."""

    run: int
    direction: int
    target_mm: float
    scale_mm: float
    meant_mm: float | None = None


def positioning_result(axis: str, readings: Sequence[ScaleReading], *,
                       net_of_drive: bool = False, display_step_mm: float = 0.0,
                       ) -> PositioningResult:
    """The figures of a test's readings (every target read in both directions; two runs
    at least, for the s): actual minus target, or (``net_of_drive``) minus where the
    drive's rounding meant the joint to land: what the axis and its maps leave, not the
    drive's step. ValueError naming what is missing."""
    if not readings:
        raise ValueError("no readings of the axis scale")
    targets = np.array(sorted({round(r.target_mm, 6) for r in readings}))
    runs = {r.run for r in readings}
    if len(runs) < 2:
        raise ValueError("one run only: ISO 230-2's s needs two runs at least (five)")
    deviations = [r.scale_mm - (r.meant_mm if net_of_drive and r.meant_mm is not None
                                else r.target_mm) for r in readings]
    reference = float(np.mean(deviations))
    cells: dict[tuple[float, int], list[float]] = {}
    for r, deviation in zip(readings, deviations, strict=True):
        cells.setdefault((round(r.target_mm, 6), r.direction), []).append(
            deviation - reference)
    missing = [f"{t:+g} mm {'up' if d > 0 else 'down'}" for t in targets for d in (1, -1)
               if len(cells.get((float(t), d), ())) < 2]
    if missing:
        raise ValueError("targets read fewer than twice in a direction: "
                         + ", ".join(missing[:4]) + (", ..." if len(missing) > 4 else ""))

    def mean_s(d: int) -> tuple[np.ndarray, np.ndarray]:
        values = [np.asarray(cells[(float(t), d)]) for t in targets]
        return (np.array([v.mean() for v in values]),
                np.array([v.std(ddof=1) for v in values]))

    (up, s_up), (down, s_down) = mean_s(1), mean_s(-1)
    figures = iso230_figures(axis, targets, up, down, s_up, s_down, s_source=S_SOURCE)
    return PositioningResult(axis, targets, up, down, s_up, s_down, len(runs), figures,
                             display_step_mm)


def session_result(session: LoadedSession, *, net_of_drive: bool = False,
                   ) -> PositioningResult:
    """The figures of a positioning test's session (``positioning_result``; ValueError:
    what is missing)."""
    readings = [ScaleReading(r.run, r.direction, r.target_mm, r.scale_mm, r.meant_mm)
                for r in session.of_type(PositionRecord)]
    plan = PositioningPlan.from_json(dict(session.header.positioning or {}))
    scales = (session.header.station or {}).get("axis_scales") or {}
    step = float((scales.get(plan.axis) or {}).get("resolution_mm") or 0.0)
    return positioning_result(plan.axis, readings, net_of_drive=net_of_drive,
                              display_step_mm=step)
