"""Faults injected into the rehearsal simulator (hidden option, for tests and
training): ``GAUGE:KIND@N`` makes gauge GAUGE show fault KIND once N readings
are recorded, for COUNT replies with ``xCOUNT`` (else until the run ends).
KIND is one of the simulator's faults: silence, error, busy, garbled, unplug...
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from ogacq.model.gauges import GAUGE_KEYS

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack


class ReadingsDone(Protocol):
    """How far a run is: the runner's ``Progress`` is one (the simulator sits below the
    runner and does not import it)."""

    @property
    def done(self) -> int: ...


_SPEC = re.compile(r"(?P<gauge>[xyz]_[xyz]):(?P<kind>[a-z]+)@(?P<after>\d+)(x(?P<count>\d+))?")


@dataclass
class FaultPlan:
    gauge: str
    kind: str
    after_readings: int
    count: int | None = None
    fired: bool = False


def parse_fault(text: str) -> FaultPlan:
    from ogacq_drivers.sim.gauges import Fault

    match = _SPEC.fullmatch(text.strip())
    if match is None:
        raise ValueError(f"{text!r}: expected GAUGE:KIND@N[xCOUNT], e.g. y_x:silence@10x3")
    gauge, kind = match["gauge"], match["kind"]
    if gauge not in GAUGE_KEYS:
        raise ValueError(f"{gauge!r} is not one of {', '.join(GAUGE_KEYS)}")
    if kind not in {f.value for f in Fault}:
        raise ValueError(f"{kind!r} is not a simulator fault ({', '.join(f.value for f in Fault)})")
    return FaultPlan(gauge, kind, int(match["after"]),
                     int(match["count"]) if match["count"] else None)


class FaultInjector:
    """Switches the planned faults on in the simulator as readings are recorded."""

    def __init__(self, plans: Sequence[FaultPlan], stack: SimulatorStack) -> None:
        self.plans = list(plans)
        self.stack = stack

    def check(self, readings_done: int) -> None:
        for plan in self.plans:
            if not plan.fired and readings_done >= plan.after_readings:
                self.stack.gauges[plan.gauge].set_fault(plan.kind, count=plan.count)
                plan.fired = True

    def observe(self, progress: ReadingsDone) -> None:
        self.check(progress.done)
