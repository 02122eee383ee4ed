"""A test station: the Station contract's parts a test need not change. It moves at
once, waits nothing, never faults, reads one gauge at a time (``read_gauge``, which a
test gives) and cannot judge rest by the values (it waits the bound)."""

from __future__ import annotations

from collections.abc import Sequence

from ogacq_drivers.errors import DriverError
from ogacq.protocol.plan import Read, SettleRule, StabilityRule
from ogacq.protocol.station import (
    GaugeReadings,
    GaugeValue,
    Joints,
    SettledGauge,
    read_each,
    settle_unjudged,
)


class StationDouble:
    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        return q_mm

    def read_gauge(self, step: Read, gauge: str, rule: StabilityRule) -> GaugeValue:
        raise NotImplementedError("the test's station reads its gauges")

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        return read_each(self.read_gauge, step, gauges, rule)

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> dict[str, SettledGauge | DriverError]:
        return settle_unjudged(self, gauges, rule)

    def settle(self, seconds: float) -> None:
        pass

    def campaign_time_s(self) -> float:
        return 0.0

    def stop_axes(self) -> None:
        pass

    def recover_axes(self) -> bool:
        return True

    def take_check_request(self) -> bool:
        return False
