"""The measurement protocol as a plan: a generator of typed steps.

A plan says what to do, not how: move, settle, read the gauges of a leg, ask
the operator. One runner executes it for the wizard, for unattended campaigns
and in the tests (``list(campaign_steps(...))`` is the whole campaign). Each
reading step carries a stable id, so a resumed campaign knows what is done.
It is the only enumeration of the protocol: the readings a plan would take,
laid out for the model (:func:`planned_layout`), serve the accuracy and
separation analyses and the tabulated deviations alike.

Approach: how each posture is approached, which matters when the drives have
backlash. ``sequence`` goes straight from posture to posture (the papers');
``from_below``/``from_above`` first go past the target by ``overshoot_mm`` and
come back, so every reading is approached from the same side; ``both`` takes
every reading twice, once from each side, to reveal lost motion.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from ogacq.model.gauges import Gauge, gauges_on
from ogacq.model.kinematics import nominal_q
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, posture_tcp
from ogacq.model.parameters import AXES

APPROACHES = ("sequence", "from_below", "from_above", "both")


@dataclass(frozen=True)
class StabilityRule:
    """A gauge value counts once ``readings`` consecutive values agree within
    ``tolerance_mm``, read after stale input was flushed."""

    readings: int = 3
    tolerance_mm: float = 0.002
    timeout_s: float = 10.0


@dataclass(frozen=True)
class ProtocolConfig:
    legs: tuple[str, ...] = ("x", "y", "z")
    postures: tuple[str | float, ...] = ("zero", "max", "min", "zero")
    cycles: int = 3
    approach: str = "sequence"
    overshoot_mm: float = 1.0
    settle_s: float = 1.0
    move_timeout_s: float = 60.0
    stability: StabilityRule = field(default_factory=StabilityRule)

    def __post_init__(self) -> None:
        if self.approach not in APPROACHES:
            raise ValueError(f"approach must be one of {', '.join(APPROACHES)}, "
                             f"got {self.approach!r}")
        if self.cycles < 1:
            raise ValueError(f"cycles must be at least 1, got {self.cycles}")
        bad = [leg for leg in self.legs if leg not in AXES]
        if bad:
            raise ValueError(f"legs must be among x, y, z, got {bad}")

    def to_dict(self) -> dict:
        return {"legs": list(self.legs), "postures": list(self.postures),
                "cycles": self.cycles, "approach": self.approach,
                "overshoot_mm": self.overshoot_mm, "settle_s": self.settle_s,
                "move_timeout_s": self.move_timeout_s,
                "stability": {"readings": self.stability.readings,
                              "tolerance_mm": self.stability.tolerance_mm,
                              "timeout_s": self.stability.timeout_s}}

    @classmethod
    def from_dict(cls, d: dict) -> ProtocolConfig:
        d = dict(d)
        stability = StabilityRule(**d.pop("stability", {}))
        return cls(legs=tuple(d.pop("legs", AXES)), postures=tuple(d.pop("postures", ())),
                   stability=stability, **d)


@dataclass(frozen=True)
class SetGauges:
    """The gauges of ``leg`` are set (by hand, or confirmed pre-mounted) at its Zero."""

    leg: str
    gauges: tuple[str, ...]  # Gauge keys: "y_x" is along y on the x leg


@dataclass(frozen=True)
class Move:
    """Move all three joints to ``q_mm`` (controller coordinates)."""

    q_mm: tuple[float, float, float]
    tcp_mm: tuple[float, float, float]
    purpose: str  # "posture" or "approach" (an overshoot before the posture)


@dataclass(frozen=True)
class Read:
    """Read every gauge of the leg, stable, after settling. ``step`` is its id."""

    step: str
    leg: str
    gauges: tuple[str, ...]
    cycle: int
    posture: str
    q_mm: tuple[float, float, float]
    tcp_mm: tuple[float, float, float]
    approach: tuple[int, int, int]  # side each joint came from: +1 below, -1 above


Step = SetGauges | Move | Read


def posture_label(posture: str | float) -> str:
    return posture if isinstance(posture, str) else f"{posture:+g}mm"


def check_postures(config: ProtocolConfig, machine: MachineSpec) -> None:
    """Refuse postures the machine cannot take, before anything moves."""
    for posture in config.postures:
        if isinstance(posture, str):
            if posture not in ("zero", "max", "min"):
                raise ValueError(f"posture {posture!r} is not zero, max, min or a number in mm")
            continue
        if not machine.rho_min_mm <= posture <= machine.rho_max_mm:
            raise ValueError(f"posture {posture:g} mm is outside the workspace "
                             f"{machine.rho_min_mm:g}..{machine.rho_max_mm:g} mm")
    if config.approach != "sequence":
        reach = max(abs(machine.rho_min_mm), abs(machine.rho_max_mm)) + config.overshoot_mm
        if reach >= machine.leg_length_mm:
            raise ValueError("overshoot_mm takes the postures beyond the workspace")


def campaign_steps(config: ProtocolConfig, machine: MachineSpec) -> Iterator[Step]:
    """Every step of the campaign, in order."""
    check_postures(config, machine)
    last_q = np.zeros(3)
    side = np.zeros(3, dtype=int)
    for leg in config.legs:
        i = AXES.index(leg)
        gauges = tuple(g.key for g in gauges_on(leg))
        first_tcp = posture_tcp(i, config.postures[0], machine)
        first_q = nominal_q(first_tcp, machine.leg_length_mm)
        # Gauges are set at the leg's first posture: go there first.
        yield from _approach(first_q, first_tcp, config, last_q, side, config.approach)
        last_q = first_q
        yield SetGauges(leg, gauges)
        for cycle in range(1, config.cycles + 1):
            for k, posture in enumerate(config.postures):
                tcp = posture_tcp(i, posture, machine)
                q = nominal_q(tcp, machine.leg_length_mm)
                sides = ("from_below", "from_above") if config.approach == "both" \
                    else (config.approach,)
                for how in sides:
                    yield from _approach(q, tcp, config, last_q, side, how)
                    last_q = q
                    tag = "" if len(sides) == 1 else f"/{how}"
                    yield Read(f"{leg}/c{cycle}/p{k + 1}{tag}", leg, gauges, cycle,
                               posture_label(posture), _t(q), _t(tcp), _t(side))


def _approach(q, tcp, config: ProtocolConfig, last_q, side, how: str) -> Iterator[Move]:
    """Moves that bring the joints to ``q`` from the side ``how`` asks; updates ``side``."""
    if how in ("from_below", "from_above"):
        sign = 1 if how == "from_below" else -1
        before = q - sign * config.overshoot_mm
        yield Move(_t(before), _t(tcp), "approach")
        side[:] = sign
    else:
        step = np.sign(np.round(q - last_q, 9)).astype(int)
        side[:] = np.where(step != 0, step, side)
    yield Move(_t(q), _t(tcp), "posture")


def _t(v: Sequence[float] | np.ndarray) -> tuple:
    return tuple(float(x) if isinstance(x, float | np.floating) else int(x) for x in v)


def reading_steps(config: ProtocolConfig, machine: MachineSpec) -> list[Read]:
    return [s for s in campaign_steps(config, machine) if isinstance(s, Read)]


def planned_layout(config: ProtocolConfig, machine: MachineSpec, *,
                   seconds_per_posture: float = 20.0) -> ReadingsLayout:
    """The readings the plan takes, in order, laid out for the model: each reading
    step's gauges at its joints, approach and posture, the clock advancing
    ``seconds_per_posture`` from one posture to the next."""
    rows = [(k, step, gauge) for k, step in enumerate(reading_steps(config, machine))
            for gauge in step.gauges]
    gauges = [Gauge.parse(gauge) for _, _, gauge in rows]
    return ReadingsLayout.build(
        q_mm=[step.q_mm for _, step, _ in rows], leg=[AXES.index(g.leg) for g in gauges],
        gauge_axis=[AXES.index(g.axis) for g in gauges],
        t_s=[k * seconds_per_posture for k, _, _ in rows],
        cycle=[step.cycle for _, step, _ in rows], tcp_mm=[step.tcp_mm for _, step, _ in rows],
        approach=[step.approach for _, step, _ in rows],
        posture=[step.posture for _, step, _ in rows])
