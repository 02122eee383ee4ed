"""An overall deadline on a campaign's working time.

Every step of a campaign is bounded on its own (a move by ``move_timeout_s``, a
stable reading by the stability rule's ``timeout_s``), but a controller that
answers every request slowly, just inside its timeout, keeps each step alive and
the campaign going for ever. The deadline bounds the whole: the time spent in
the station's work (moves, settling, readings, recoveries), in the station's own
clock; the operator's time (setting gauges, a paused wizard) does not count. Past
it, the campaign stops safely and can be resumed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import ParamSpec, TypeVar

from ogacq_drivers.errors import DriverError
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import (
    Move,
    ProtocolConfig,
    Read,
    SettleRule,
    StabilityRule,
    campaign_steps,
)
from ogacq.protocol.runner import CampaignStopped
from ogacq.protocol.station import (
    GaugeValue,
    Joints,
    SettledGauge,
    Station,
    StationWrapper,
)

P = ParamSpec("P")
T = TypeVar("T")


def default_deadline_s(config: ProtocolConfig, machine: MachineSpec) -> float:
    """Every step of the plan taking its whole timeout once: each move its
    ``move_timeout_s``, each reading step its settling and a stability timeout per
    gauge. A campaign that goes right takes a small fraction of this; one whose
    steps all drag at their limits is stopped here."""
    total = 0.0
    for step in campaign_steps(config, machine):
        if isinstance(step, Move):
            total += config.move_timeout_s
        elif isinstance(step, Read):
            total += config.settle_s + config.stability.timeout_s * len(step.gauges)
    return total


class DeadlineStation(StationWrapper):
    """A station whose work stops the campaign once ``deadline_s`` of it is spent.

    Checked before each move, settling and reading (the values of a read at once are
    counted as each comes), so a step under way ends within its own timeout.
    Stopping the axes and the clock pass through unchanged.
    """

    def __init__(self, station: Station, deadline_s: float) -> None:
        super().__init__(station)
        self.deadline_s = deadline_s
        self.spent_s = 0.0

    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        return self._within_deadline(self.inner.move, q_mm, timeout_s)

    def settle(self, seconds: float) -> None:
        self._within_deadline(self.inner.settle, seconds)

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> Iterator[tuple[str, GaugeValue | DriverError]]:
        readings = iter(self._within_deadline(self.inner.read_gauges, step, gauges, rule))
        while True:  # the reading under way goes on: its values' time is counted
            try:
                yield self._counted(next, readings)
            except StopIteration:
                return

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> Mapping[str, SettledGauge | DriverError]:
        return self._within_deadline(self.inner.read_settled, step, gauges, rule)

    def recover_axes(self) -> bool:
        return self._within_deadline(self.inner.recover_axes)

    def _within_deadline(self, action: Callable[P, T], *args: P.args, **kwargs: P.kwargs,
                         ) -> T:
        if self.spent_s >= self.deadline_s:
            raise CampaignStopped(f"deadline: {self.spent_s:.0f} s of work, the campaign's "
                                  f"deadline_s is {self.deadline_s:.0f} s (a controller or "
                                  "gauge answering slowly?)")
        return self._counted(action, *args, **kwargs)

    def _counted(self, action: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
        started = self.inner.campaign_time_s()
        try:
            return action(*args, **kwargs)
        finally:
            self.spent_s += self.inner.campaign_time_s() - started
