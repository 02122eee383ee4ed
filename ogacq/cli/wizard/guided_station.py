"""The station as the wizard runs it: the campaign's own, plus Ctrl-C checkpoints,
gauges read by eye, and single reads for live values; each reading feeds the ranges
the next ones are checked against."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators.base import read_stable
from ogacq.campaign.station import DeviceStation
from ogacq.cli.wizard.pause import InterruptGate, closed_is_quit
from ogacq.model.expected_readings import ReadingExpectations
from ogacq.protocol.plan import Read, SettleRule, StabilityRule
from ogacq.protocol.station import (
    GaugeValue,
    Joints,
    SettledGauge,
    Station,
    StationWrapper,
    settle_unjudged,
)

# Asks for one reading of a gauge read by eye, at a plan step; returns its value.
AskReading = Callable[[str, Read], GaugeValue]


class GuidedStation(StationWrapper):
    """The runner's ``Station`` around the campaign's (``inner``: the open
    ``DeviceStation`` within its deadline), with pause checkpoints and gauges read by
    eye; ``device``: the station's parts the wizard reads live."""

    def __init__(self, inner: Station, device: DeviceStation, gate: InterruptGate, *,
                 expectations: ReadingExpectations,
                 by_eye: set[str], ask_reading: AskReading,
                 on_pause: Callable[[], None]) -> None:
        super().__init__(inner)
        self.device = device
        self.gate = gate
        self.by_eye = by_eye  # shared with the wizard: a gauge can switch to by-eye mid-way
        self.expectations = expectations
        self._ask_reading = ask_reading
        self._on_pause = on_pause
        self._moved = True  # since the last settle: a person waits only after a move

    # ------------------------------------------------------------ runner's Station
    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        self._checkpoint()
        self._moved = True
        return self.inner.move(q_mm, timeout_s)

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> Iterator[tuple[str, GaugeValue | DriverError]]:
        """The gauges the station reads, at once; then those read by eye, each handed
        over as typed (so it is on file before the next is asked for)."""
        self._checkpoint()
        read = [g for g in gauges if g not in self.by_eye]
        for gauge, value in (self.inner.read_gauges(step, read, rule) if read else ()):
            if isinstance(value, GaugeValue):
                self.expectations.observe(gauge, step.q_mm, value.value_mm)
            yield gauge, value
        for gauge in gauges:
            if gauge in self.by_eye:
                with self.gate.immediate(), closed_is_quit():
                    typed = self._ask_reading(gauge, step)
                self.expectations.observe(gauge, step.q_mm, typed.value_mm)
                yield gauge, typed

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> Mapping[str, SettledGauge | DriverError]:
        """Settled by the gauges' values; with a gauge read by eye, by the fixed wait
        (a person reads the dial once the machine is at rest), none where nothing moved
        since the last settle (the runner settles such a step too, so that gauges read
        by values average as many as at every other)."""
        self._checkpoint()
        moved, self._moved = self._moved, False
        if any(g in self.by_eye for g in gauges):
            if not moved:
                return {g: SettledGauge(None, 0.0, 0) for g in gauges}
            return settle_unjudged(self.inner, gauges, rule)
        out = self.inner.read_settled(step, gauges, rule)
        for gauge, settled in out.items():
            if isinstance(settled, SettledGauge) and settled.value is not None:
                self.expectations.observe(gauge, step.q_mm, settled.value.value_mm)
        return out

    def settle(self, seconds: float) -> None:
        self._checkpoint()
        self.inner.settle(seconds)

    # ------------------------------------------------------------ for the wizard
    @property
    def description(self) -> dict[str, Any]:
        return self.device.description

    def can_read(self, gauge: str) -> bool:
        return gauge in self.device.indicators and gauge not in self.by_eye

    def read_once(self, gauge: str, timeout_s: float = 0.5) -> float:
        """One value, for the live display; DriverError when the gauge does not answer."""
        with self.gate.deferred():
            return self.device.indicators[gauge].read(timeout_s=timeout_s).value_mm

    def read_steady(self, gauge: str, rule: StabilityRule) -> float:
        with self.gate.deferred():
            stable = read_stable(self.device.indicators[gauge], rule.readings,
                                 rule.tolerance_mm, rule.timeout_s)
        return stable.value_mm

    def _checkpoint(self) -> None:
        """Where a deferred Ctrl-C takes effect: between actions, axes at rest."""
        if self.gate.take_pending():
            with self.gate.immediate():
                self._on_pause()
