"""What a campaign needs from a station, and the one way to wrap one.

``Station`` is the runner's whole contract: every method required, none found by
``hasattr``. The device station (``ogacq.campaign.station``), the deadline
(``ogacq.protocol.deadline``), the wizard's guided station and the tests' doubles
implement all of it; mypy rejects a station that misses one where the runner is
given it (tests/test_types.py shows it does).

A station that changes what another does derives from ``StationWrapper``: every
method of the contract forwards to the wrapped station, and a subclass overrides
the ones it changes. Nothing else passes through (no ``__getattr__``): what a
wrapper offers besides the contract, it declares.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from ogacq_drivers.errors import DriverError
from ogacq.protocol.plan import Read, SettleRule, StabilityRule

Joints = tuple[float, float, float]


@dataclass(frozen=True)
class GaugeValue:
    value_mm: float
    raw: str  # the frame as received, for the record
    where: str  # port/channel the value came from
    # the gauge values ``value_mm`` is the mean of (the settle's two windows at rest,
    # or a stable reading's agreeing values) and their sample standard deviation (mm;
    # None for one value): what the noise of an averaged reading is derived from
    # (ogacq/identify/noise_averaged.py). None where nothing was averaged by ogacq
    # (a value typed by eye).
    averaged: int | None = None
    averaged_sd_mm: float | None = None


@dataclass(frozen=True)
class SettledGauge:
    """A gauge read from the end of a move until its values showed rest (SettleRule)."""

    value: GaugeValue | None  # None: not at rest within the rule's bound
    waited_s: float  # machine seconds from in position to its last value
    values: int  # values read meanwhile
    u_mm: float | None = None  # the uncertainty its values were judged against
    measured_rest: bool = False  # it waited the bound to measure its rest scatter
    # judged and not at rest by the bound: the mean of its last two windows all the same
    unjudged: GaugeValue | None = None


# Each gauge's value or the error it raised, as each comes.
GaugeReadings = Iterable[tuple[str, GaugeValue | DriverError]]


class Station(Protocol):
    """What a campaign needs from the hardware (or the simulator)."""

    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        """Move the three joints and return once in position (raise DriverError),
        with the coordinates really commanded (rounded to the controller's resolution)."""
        ...

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        """A stable value of each of ``gauges`` (``y_x``: along y on the x leg) for the
        plan's reading step ``step``, or the error each raised; read at once where
        the station can, yielded as each comes (one read by eye is on file before
        the next is asked for). :func:`read_each` reads them one after the other."""
        ...

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> Mapping[str, SettledGauge | DriverError]:
        """The gauges read from now (the axes in position) until each is at rest by
        ``rule``, at most ``rule.bound_s`` of machine time. A station that cannot judge
        rest by values waits the bound and returns each gauge unsettled (value None):
        the runner then reads them afresh."""
        ...

    def settle(self, seconds: float) -> None:
        """Wait ``seconds`` of machine time."""
        ...

    def campaign_time_s(self) -> float:
        """Machine seconds since the campaign's homing."""
        ...

    def stop_axes(self) -> None: ...

    def recover_axes(self) -> bool:
        """Try to clear an axis alarm; True when the axes are ready again."""
        ...

    def take_check_request(self) -> bool:
        """True once after the station homed the axes again (recovering them): the
        runner then checks a posture. False for a station that never re-homes."""
        ...


def read_each(read_one: _ReadOne, step: Read, gauges: Sequence[str], rule: StabilityRule,
              ) -> Iterator[tuple[str, GaugeValue | DriverError]]:
    """``read_gauges`` of a station that reads one gauge at a time (``read_one``)."""
    for gauge in gauges:
        try:
            yield gauge, read_one(step, gauge, rule)
        except DriverError as exc:
            yield gauge, exc


class _ReadOne(Protocol):
    def __call__(self, step: Read, gauge: str, rule: StabilityRule) -> GaugeValue: ...


def settle_unjudged(station: Station, gauges: Sequence[str], rule: SettleRule,
                    ) -> dict[str, SettledGauge | DriverError]:
    """``read_settled`` of a station that cannot judge rest by values: it waits the
    bound, and no gauge is said to be at rest."""
    station.settle(rule.bound_s)
    return {g: SettledGauge(None, rule.bound_s, 0) for g in gauges}


class StationWrapper:
    """A station around ``inner``: each method of the contract forwards to it."""

    def __init__(self, inner: Station) -> None:
        self.inner = inner

    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        return self.inner.move(q_mm, timeout_s)

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        return self.inner.read_gauges(step, gauges, rule)

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> Mapping[str, SettledGauge | DriverError]:
        return self.inner.read_settled(step, gauges, rule)

    def settle(self, seconds: float) -> None:
        self.inner.settle(seconds)

    def campaign_time_s(self) -> float:
        return self.inner.campaign_time_s()

    def stop_axes(self) -> None:
        self.inner.stop_axes()

    def recover_axes(self) -> bool:
        return self.inner.recover_axes()

    def take_check_request(self) -> bool:
        return self.inner.take_check_request()
