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

from typing import Any

from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import Move, ProtocolConfig, Read, campaign_steps
from ogacq.protocol.runner import CampaignStopped


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


class DeadlineStation:
    """A station whose work stops the campaign once ``deadline_s`` of it is spent.

    Checked before each move, settling and reading, so a step under way ends within
    its own timeout. Everything else (stopping, the wizard's use of the station's
    parts) passes through unchanged.
    """

    def __init__(self, station: Any, deadline_s: float) -> None:
        self._station = station
        self.deadline_s = deadline_s
        self.spent_s = 0.0

    def move(self, *args: Any, **kwargs: Any) -> Any:
        return self._within_deadline(self._station.move, *args, **kwargs)

    def settle(self, *args: Any, **kwargs: Any) -> Any:
        return self._within_deadline(self._station.settle, *args, **kwargs)

    def read_gauge(self, *args: Any, **kwargs: Any) -> Any:
        return self._within_deadline(self._station.read_gauge, *args, **kwargs)

    def read_gauges(self, *args: Any, **kwargs: Any) -> Any:
        return self._within_deadline(self._station.read_gauges, *args, **kwargs)

    def read_settled(self, *args: Any, **kwargs: Any) -> Any:
        return self._within_deadline(self._station.read_settled, *args, **kwargs)

    def recover_axes(self) -> bool:
        return self._within_deadline(self._station.recover_axes)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._station, name)

    def _within_deadline(self, action: Any, *args: Any, **kwargs: Any) -> Any:
        if self.spent_s >= self.deadline_s:
            raise CampaignStopped(f"deadline: {self.spent_s:.0f} s of work, the campaign's "
                                  f"deadline_s is {self.deadline_s:.0f} s (a controller or "
                                  "gauge answering slowly?)")
        started = self._station.campaign_time_s()
        try:
            return action(*args, **kwargs)
        finally:
            self.spent_s += self._station.campaign_time_s() - started
