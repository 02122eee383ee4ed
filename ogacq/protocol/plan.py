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

Scan: instead of a few postures, readings at many intermediate postures along
each leg's axis, ``scan_step_mm`` apart from ``scan_from_mm`` to ``scan_to_mm``
(the whole travel rho_min..rho_max when not given), to map a lead screw. Each
cycle runs the targets up (ascending) and back down, so every target is read
once from each side: ISO 230-2:2014 section 3.14 ("bidirectional") and its
linear test cycle, 4.3. ``approach`` says how the two runs start: ``both`` goes
past the first target of each run by ``overshoot_mm`` (ISO 230-2 4.3: the
reversal beyond the end targets), ``sequence`` turns straight round at the
ends, ``from_below``/``from_above`` keep one run only (unidirectional). The
gauges are set at Zero and a Zero reading starts each leg (the gauges' setting
posture), since a gauge is set where it first reads.

Settling: after a move, ``settle = "stable"`` (the default) reads the leg's gauges
from the moment the axes are in position and takes each one's reading once its
values show rest against its own noise and display step (:class:`SettleRule`),
``settle_s`` being the longest it waits; ``"fixed"`` waits ``settle_s``. Where
nothing moved (a posture read again), there is nothing to settle.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from typing import Any

import numpy as np

from ogacq.errors import InputError
from ogacq.model.gauges import Gauge, gauges_on
from ogacq.model.kinematics import nominal_q
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, posture_tcp
from ogacq.model.parameters import AXES

APPROACHES = ("sequence", "from_below", "from_above", "both")
SETTLES = ("stable", "fixed")
# A guard against a typo (a step in um written as mm), no source: a scan of more
# postures per leg than this is refused before anything moves.
MAX_SCAN_POSTURES = 100_000


class PlanError(InputError, ValueError):
    """A plan no campaign can run (its approach, cycles, legs, settle, postures or scan):
    an input error, which a caller names with the option or the key it came from; a
    ValueError as well, as every caller took it before it was typed."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass(frozen=True)
class StabilityRule:
    """A gauge value counts once ``readings`` consecutive values agree within
    ``tolerance_mm``, read after stale input was flushed."""

    readings: int = 3
    tolerance_mm: float = 0.002
    timeout_s: float = 10.0


@dataclass(frozen=True)
class ProtocolConfig:
    """How a campaign reads: legs, postures, cycles, approach, settling and scan."""

    legs: tuple[str, ...] = AXES
    postures: tuple[str | float, ...] = ("zero", "max", "min", "zero")
    cycles: int = 3
    approach: str = "sequence"
    overshoot_mm: float = 1.0
    settle_s: float = 1.0
    move_timeout_s: float = 60.0
    stability: StabilityRule = field(default_factory=StabilityRule)
    # stable by default: it ends when each gauge's values are at rest against the
    # gauge's own noise and display step, leaving a ringing under a third of its
    # uncertainty in the reading (ogacq_drivers.indicators.rest), settle_s its bound
    settle: str = "stable"
    settle_window_s: float = 0.1  # a period of the slowest ringing covered: 10 Hz
    scan_step_mm: float | None = None  # None: the postures above, no scan
    scan_from_mm: float | None = None  # None: the machine's rho_min
    scan_to_mm: float | None = None  # None: the machine's rho_max
    # a designed scan's targets (joint mm, ascending), instead of every scan_step_mm:
    # irregular, so that a periodic error is sampled at many phases (ISO 230-2:2014
    # 4.3.2; ``ogacq.protocol.scan_design``)
    scan_targets_mm: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.approach not in APPROACHES:
            raise PlanError(f"approach must be one of {', '.join(APPROACHES)}, "
                            f"got {self.approach!r}")
        if self.cycles < 1:
            raise PlanError(f"cycles must be at least 1, got {self.cycles}")
        bad = [leg for leg in self.legs if leg not in AXES]
        if bad:
            raise PlanError(f"legs must be among x, y, z, got {bad}")
        if self.settle not in SETTLES:
            raise PlanError(f"settle must be one of {', '.join(SETTLES)}, got {self.settle!r}")
        if self.scan_step_mm is not None and not self.scan_step_mm > 0:
            raise PlanError(f"scan_step_mm must be positive, got {self.scan_step_mm:g}")
        if self.scan_targets_mm and self.scan_step_mm is not None:
            raise PlanError("scan_targets_mm and scan_step_mm exclude each other")
        if any(b <= a for a, b in zip(self.scan_targets_mm[:-1], self.scan_targets_mm[1:],
                                       strict=True)):
            raise PlanError("scan_targets_mm must be ascending, each target once")

    @property
    def is_scan(self) -> bool:
        return self.scan_step_mm is not None or bool(self.scan_targets_mm)

    def at_targets(self, targets_mm: tuple[float, ...]) -> ProtocolConfig:
        """The same scan read at ``targets_mm`` instead of its step or targets."""
        return replace(self, scan_step_mm=None, scan_from_mm=None, scan_to_mm=None,
                       scan_targets_mm=targets_mm)

    @property
    def settle_rule(self) -> SettleRule:
        return SettleRule(self.settle, self.settle_s, self.settle_window_s)

    def to_dict(self) -> dict:
        out = {"legs": list(self.legs), "postures": list(self.postures),
               "cycles": self.cycles, "approach": self.approach,
               "overshoot_mm": self.overshoot_mm, "settle": self.settle,
               "settle_s": self.settle_s, "settle_window_s": self.settle_window_s,
               "move_timeout_s": self.move_timeout_s, "stability": asdict(self.stability)}
        if self.scan_targets_mm:  # a designed scan replaces the postures
            del out["postures"]
            out["scan_targets_mm"] = list(self.scan_targets_mm)
        elif self.is_scan:  # a scan replaces the postures
            del out["postures"]
            out.update(scan_step_mm=self.scan_step_mm, scan_from_mm=self.scan_from_mm,
                       scan_to_mm=self.scan_to_mm)
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> ProtocolConfig:
        d = dict(d)
        stability = StabilityRule(**d.pop("stability", {}))
        return cls(legs=tuple(d.pop("legs", AXES)), postures=tuple(d.pop("postures", ())),
                   stability=stability,
                   scan_targets_mm=tuple(d.pop("scan_targets_mm", ())), **d)


@dataclass(frozen=True)
class SettleRule:
    """How a reading step waits for the machine to come to rest after a move.

    ``fixed``: ``bound_s`` of machine time. ``stable``: the gauges are read from
    the moment the axes report in position; a gauge is at rest once the values of
    its last two windows, each spanning ``window_s`` (a whole period of any ringing
    of 1 / ``window_s`` Hz or faster), scatter no more than its rest scatter allows
    (a chi-square test against its standard uncertainty from noise and display
    step, ``display_step_mm`` the machine file's gauge resolution); its reading is
    the mean of both windows, which leaves under a third of that uncertainty of
    any ringing (the rule and its physics: ``ogacq_drivers.indicators.rest``).
    ``bound_s``: the longest a stable settle waits; a gauge not at rest by then is
    read afresh as after a fixed wait, and so is each gauge's first settle of a
    run, which measures its rest scatter over the bound's second half.
    """

    kind: str  # "stable" or "fixed"
    bound_s: float
    window_s: float
    display_step_mm: float = 0.0


@dataclass(frozen=True)
class SetGauges:
    """The gauges of ``leg`` are set (by hand, or confirmed pre-mounted) at its Zero."""

    leg: str
    gauges: tuple[str, ...]  # Gauge keys: "y_x" is along y on the x leg


@dataclass(frozen=True)
class Move:
    """Move all three joints to ``q_mm`` (controller coordinates)."""

    q_mm: tuple[float, float, float]
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


def scan_targets(config: ProtocolConfig, machine: MachineSpec) -> list[float]:
    """The scan's targets in ascending order, ``scan_step_mm`` apart from its start
    (rounded to 1e-6 mm, so that repeats of a target are the same number); the end
    is a target when it falls on the grid; a designed scan's own targets."""
    if config.scan_targets_mm:
        return list(config.scan_targets_mm)
    assert config.scan_step_mm is not None
    start, end = scan_range(config, machine)
    count = int(np.floor((end - start) / config.scan_step_mm + 1e-9)) + 1
    return [round(start + k * config.scan_step_mm, 6) + 0.0 for k in range(count)]  # no -0


def scan_range(config: ProtocolConfig, machine: MachineSpec) -> tuple[float, float]:
    """The scan's first and last target: as stated, else the whole travel, less the
    overshoot at each end when the approach goes past the targets."""
    if config.scan_targets_mm:
        return config.scan_targets_mm[0], config.scan_targets_mm[-1]
    inset = 0.0 if config.approach == "sequence" else config.overshoot_mm
    start = machine.rho_min_mm + inset if config.scan_from_mm is None else config.scan_from_mm
    end = machine.rho_max_mm - inset if config.scan_to_mm is None else config.scan_to_mm
    return start, end


def _check_scan(config: ProtocolConfig, machine: MachineSpec) -> None:
    start, end = scan_range(config, machine)
    keys = ("scan_targets_mm",) * 2 if config.scan_targets_mm else ("scan_from_mm", "scan_to_mm")
    for key, value in zip(keys, (start, end), strict=True):
        if not machine.rho_min_mm <= value <= machine.rho_max_mm:
            raise PlanError(f"{key} {value:g} mm is outside the workspace "
                            f"{machine.rho_min_mm:g}..{machine.rho_max_mm:g} mm")
    if config.scan_targets_mm:
        return
    assert config.scan_step_mm is not None
    if not start < end:
        raise PlanError(f"scan_from_mm {start:g} mm must be below scan_to_mm {end:g} mm")
    count = (end - start) / config.scan_step_mm + 1
    if count > MAX_SCAN_POSTURES:
        raise PlanError(f"scan_step_mm {config.scan_step_mm:g} mm makes {count:.0f} postures "
                        f"per leg (at most {MAX_SCAN_POSTURES}); is the step in mm?")


def check_postures(config: ProtocolConfig, machine: MachineSpec) -> None:
    """Refuse postures the machine cannot take, before anything moves."""
    if config.is_scan:
        _check_scan(config, machine)
    for posture in () if config.is_scan else config.postures:
        if isinstance(posture, str):
            if posture not in ("zero", "max", "min"):
                raise PlanError(f"posture {posture!r} is not zero, max, min or a number in mm")
            continue
        if not machine.rho_min_mm <= posture <= machine.rho_max_mm:
            raise PlanError(f"posture {posture:g} mm is outside the workspace "
                            f"{machine.rho_min_mm:g}..{machine.rho_max_mm:g} mm")
    if config.approach != "sequence":
        reach = max(abs(machine.rho_min_mm), abs(machine.rho_max_mm)) + config.overshoot_mm
        if reach >= machine.leg_length_mm:
            raise PlanError("overshoot_mm takes the postures beyond the workspace")
        _check_overshoot(config, machine)


def _check_overshoot(config: ProtocolConfig, machine: MachineSpec) -> None:
    """A posture approached from below (above) needs ``overshoot_mm`` of travel below
    (above) it: the controller refuses a move past its soft limits."""
    below = config.approach in ("from_below", "both")
    above = config.approach in ("from_above", "both")
    if config.is_scan:
        targets = scan_range(config, machine)
        lowest, highest = targets if config.approach == "both" else (targets[0], targets[0]) \
            if below else (targets[1], targets[1])
    else:
        along = [float(posture_tcp(0, p, machine)[0]) for p in config.postures]
        lowest, highest = min(along), max(along)
    if below and lowest - config.overshoot_mm < machine.rho_min_mm - 1e-9:
        raise PlanError(f"approach {config.approach}: the posture {lowest:g} mm is approached "
                        f"from {lowest - config.overshoot_mm:g} mm, below rho_min "
                        f"{machine.rho_min_mm:g} mm (overshoot_mm {config.overshoot_mm:g})")
    if above and highest + config.overshoot_mm > machine.rho_max_mm + 1e-9:
        raise PlanError(f"approach {config.approach}: the posture {highest:g} mm is approached "
                        f"from {highest + config.overshoot_mm:g} mm, above rho_max "
                        f"{machine.rho_max_mm:g} mm (overshoot_mm {config.overshoot_mm:g})")


def campaign_steps(config: ProtocolConfig, machine: MachineSpec) -> Iterator[Step]:
    """Every step of the campaign, in order."""
    check_postures(config, machine)
    if config.is_scan:
        yield from _scan_steps(config, machine)
        return
    last_q = _ORIGIN
    side = [0, 0, 0]
    for leg in config.legs:
        i = AXES.index(leg)
        gauges = tuple(g.key for g in gauges_on(leg))
        # each posture's joints and TCP, computed once for all the cycles
        poses = _poses(i, config.postures, machine)
        # Gauges are set at the leg's first posture: go there first.
        first_q = poses[0][0]
        yield from _approach(first_q, config, last_q, side, config.approach)
        last_q = first_q
        yield SetGauges(leg, gauges)
        labels = [posture_label(posture) for posture in config.postures]
        for cycle in range(1, config.cycles + 1):
            for k in range(len(config.postures)):
                q, tcp = poses[k]
                sides = ("from_below", "from_above") if config.approach == "both" \
                    else (config.approach,)
                for how in sides:
                    yield from _approach(q, config, last_q, side, how)
                    last_q = q
                    tag = "" if len(sides) == 1 else f"/{how}"
                    yield Read(f"{leg}/c{cycle}/p{k + 1}{tag}", leg, gauges, cycle,
                               labels[k], q, tcp, (side[0], side[1], side[2]))


# A scan's runs per cycle, by approach: (name, direction, how its first target is reached).
_SCAN_RUNS = {
    "both": (("up", 1, "from_below"), ("down", -1, "from_above")),
    "sequence": (("up", 1, "sequence"), ("down", -1, "sequence")),
    "from_below": (("up", 1, "from_below"),),
    "from_above": (("down", -1, "from_above"),),
}

# The plan's joint coordinates and TCPs are tuples of Python floats (what the steps
# carry), sides a list of Python ints: a 1 mm scan walks thousands of moves, where a
# numpy call or conversion per move made its layout several times slower.
Pose = tuple[tuple[float, float, float], tuple[float, float, float]]
_ORIGIN = (0.0, 0.0, 0.0)


def _poses(leg: int, postures: Sequence[str | float], machine: MachineSpec) -> list[Pose]:
    """(joints, TCP) of each posture of a leg's test, the joints from one
    ``nominal_q`` of them all (row by row the same arithmetic)."""
    tcps = np.array([posture_tcp(leg, posture, machine) for posture in postures],
                    dtype=float).reshape(-1, 3)
    qs = nominal_q(tcps, machine.leg_length_mm)
    return [((q[0], q[1], q[2]), (tcp[0], tcp[1], tcp[2]))
            for q, tcp in zip(qs.tolist(), tcps.tolist(), strict=True)]


def _scan_steps(config: ProtocolConfig, machine: MachineSpec) -> Iterator[Step]:
    """Each leg: set the gauges at Zero and read them there, then ``cycles`` times
    the runs of the scan (up and back down for both directions)."""
    targets = scan_targets(config, machine)
    last_q = _ORIGIN
    side = [0, 0, 0]
    for leg in config.legs:
        i = AXES.index(leg)
        gauges = tuple(g.key for g in gauges_on(leg))
        # the Zero posture, then each target's joints and TCP, computed once for all
        # the runs that visit it
        (zero_q, zero_tcp), *poses = _poses(i, ["zero", *targets], machine)
        yield from _approach(zero_q, config, last_q, side, "sequence")
        last_q = zero_q
        yield SetGauges(leg, gauges)
        yield Read(f"{leg}/set", leg, gauges, 1, "zero", zero_q, zero_tcp,
                   (side[0], side[1], side[2]))
        labels = [posture_label(target) for target in targets]
        for cycle in range(1, config.cycles + 1):
            for run, direction, first in _SCAN_RUNS[config.approach]:
                order = range(len(targets)) if direction > 0 else \
                    range(len(targets) - 1, -1, -1)
                for n, k in enumerate(order):
                    q, tcp = poses[k]
                    yield from _approach(q, config, last_q, side,
                                         first if n == 0 else "sequence")
                    last_q = q
                    yield Read(f"{leg}/c{cycle}/{run}/p{k + 1}", leg, gauges, cycle,
                               labels[k], q, tcp, (side[0], side[1], side[2]))


def _approach(q: tuple[float, float, float], config: ProtocolConfig,
              last_q: tuple[float, float, float], side: list[int], how: str) -> Iterator[Move]:
    """Moves that bring the joints to ``q`` from the side ``how`` asks; updates ``side``."""
    if how in ("from_below", "from_above"):
        sign = 1 if how == "from_below" else -1
        before = q[0] - sign * config.overshoot_mm, q[1] - sign * config.overshoot_mm, \
            q[2] - sign * config.overshoot_mm
        yield Move(before, "approach")
        side[:] = [sign] * 3
    else:
        # np.sign(np.round(q - last_q, 9)) where not zero, in Python floats: np.round is
        # rint(d * 1e9) / 1e9, positive exactly when d * 1e9 exceeds 0.5 (as
        # approach_from_sequence has it)
        for k, (to, since) in enumerate(zip(q, last_q, strict=True)):
            nanometres = (to - since) * 1e9
            if nanometres > 0.5:
                side[k] = 1
            elif nanometres < -0.5:
                side[k] = -1
    yield Move(q, "posture")


def reading_steps(config: ProtocolConfig, machine: MachineSpec) -> list[Read]:
    return [s for s in campaign_steps(config, machine) if isinstance(s, Read)]


def planned_layout(config: ProtocolConfig, machine: MachineSpec, *,
                   seconds_per_posture: float = 20.0) -> ReadingsLayout:
    """The readings the plan takes, in order, laid out for the model: each reading
    step's gauges at its joints, approach and posture, the clock advancing
    ``seconds_per_posture`` from one posture to the next.

    Its arrays are read-only: the same plan on the same machine is laid out once and
    shared (a diagnosis weighs the same candidate plans and scans every time, each a
    walk through thousands of steps)."""
    try:
        hash((config, machine))
    except TypeError:  # a field that does not hash by value: laid out afresh
        return _layout(config, machine, float(seconds_per_posture))
    # the postures' types too: 30 and 30.0 compare equal but may be labelled apart
    kinds = tuple(type(p) for p in config.postures)
    return _shared_layout(config, machine, float(seconds_per_posture), kinds)


@lru_cache(maxsize=16)  # a diagnosis weighs 6; a 1 mm scan's, with its evaluation plans, ~0.5 MiB
def _shared_layout(config: ProtocolConfig, machine: MachineSpec, seconds_per_posture: float,
                   kinds: tuple[type, ...]) -> ReadingsLayout:
    """A pure function of frozen inputs (both dataclasses hash by value)."""
    layout = _layout(config, machine, seconds_per_posture)
    for value in vars(layout).values():
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return layout


def _layout(config: ProtocolConfig, machine: MachineSpec,
            seconds_per_posture: float) -> ReadingsLayout:
    reads = reading_steps(config, machine)
    keys = [gauge for step in reads for gauge in step.gauges]
    parsed = {key: Gauge.parse(key) for key in set(keys)}
    gauges = [parsed[key] for key in keys]
    # a reading step's values converted once and repeated for each of its gauges (a
    # scan reads hundreds of postures): the same values as converting every row
    count = [len(step.gauges) for step in reads]

    def each(values: list, dtype: type) -> np.ndarray:
        return np.repeat(np.array(values, dtype=dtype), count, axis=0)

    return ReadingsLayout.build(
        q_mm=each([step.q_mm for step in reads], float).reshape(-1, 3),
        leg=[AXES.index(g.leg) for g in gauges], gauge_axis=[AXES.index(g.axis) for g in gauges],
        t_s=each([k * seconds_per_posture for k in range(len(reads))], float),
        cycle=each([step.cycle for step in reads], int),
        tcp_mm=each([step.tcp_mm for step in reads], float).reshape(-1, 3),
        approach=each([step.approach for step in reads], int).reshape(-1, 3),
        posture=each([step.posture for step in reads], object))
