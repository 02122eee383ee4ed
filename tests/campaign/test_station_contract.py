"""The Station contract: every method required, wrappers that forward it and nothing
else, and a runner that never asks a station what it has (mypy's side of it:
tests/test_types.py)."""

from __future__ import annotations

import ast
from collections.abc import Sequence
from pathlib import Path

import pytest

from ogacq_drivers.errors import DeviceTimeout, DriverError
from ogacq.protocol.deadline import DeadlineStation
from ogacq.protocol.plan import Read, SettleRule, StabilityRule
from ogacq.protocol.runner import CampaignStopped
from ogacq.protocol.station import (
    GaugeReadings,
    GaugeValue,
    Joints,
    SettledGauge,
    StationWrapper,
)

ROOT = Path(__file__).resolve().parents[2]
SETTLE = SettleRule("stable", bound_s=1.0, window_s=0.1)
STEP = Read("x/c1/p1", "x", ("y_x", "z_x"), 1, "zero", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
            (0, 0, 0))


class _Clocked:
    """A station whose every action takes ``cost_s`` of its clock."""

    def __init__(self, cost_s: float) -> None:
        self.now_s = 0.0
        self.cost_s = cost_s
        self.calls: list[str] = []

    def _work(self, name: str) -> None:
        self.calls.append(name)
        self.now_s += self.cost_s

    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        self._work("move")
        return q_mm

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        for gauge in gauges:  # one after the other, each taking its time
            self._work(f"read {gauge}")
            yield gauge, (GaugeValue(0.0, "frame", gauge) if gauge != "z_x"
                          else DeviceTimeout("silent", where=gauge))

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> dict[str, SettledGauge | DriverError]:
        self._work("read_settled")
        return {g: SettledGauge(GaugeValue(0.0, "frame", g), 0.1, 3) for g in gauges}

    def settle(self, seconds: float) -> None:
        self._work("settle")

    def campaign_time_s(self) -> float:
        return self.now_s

    def stop_axes(self) -> None:
        self.calls.append("stop_axes")

    def recover_axes(self) -> bool:
        self._work("recover_axes")
        return True

    def take_check_request(self) -> bool:
        self.calls.append("take_check_request")
        return True


def test_a_wrapper_forwards_every_method_of_the_contract():
    inner = _Clocked(0.0)
    wrapped = StationWrapper(inner)
    assert wrapped.move((1.0, 2.0, 3.0), 5.0) == (1.0, 2.0, 3.0)
    assert [g for g, _ in wrapped.read_gauges(STEP, STEP.gauges, StabilityRule())] == \
        ["y_x", "z_x"]
    assert set(wrapped.read_settled(STEP, STEP.gauges, SETTLE)) == {"y_x", "z_x"}
    wrapped.settle(1.0)
    wrapped.stop_axes()
    assert wrapped.recover_axes() and wrapped.take_check_request()
    assert inner.calls == ["move", "read y_x", "read z_x", "read_settled", "settle",
                           "stop_axes", "recover_axes", "take_check_request"]
    assert not hasattr(wrapped, "cost_s")  # nothing but the contract passes through


def test_the_deadline_counts_the_work_and_stops_the_campaign_past_it():
    inner = _Clocked(1.0)
    station = DeadlineStation(inner, deadline_s=4.0)
    station.move((0.0, 0.0, 0.0), 5.0)
    settled = station.read_settled(STEP, STEP.gauges, SETTLE)
    assert all(isinstance(s, SettledGauge) for s in settled.values())
    readings = dict(station.read_gauges(STEP, STEP.gauges, StabilityRule()))
    assert isinstance(readings["y_x"], GaugeValue)
    assert isinstance(readings["z_x"], DeviceTimeout)  # an error is a value, as it comes
    assert station.spent_s == 4.0  # each value of a read at once counted as it came
    assert station.take_check_request()  # neither work nor bounded: passes through
    with pytest.raises(CampaignStopped, match="deadline: 4 s of work"):
        station.move((1.0, 0.0, 0.0), 5.0)
    station.stop_axes()  # stopping is never refused
    assert inner.calls[-1] == "stop_axes"


def _station_modules() -> list[Path]:
    """The runner and every station: the device's, the deadline, the wizard's."""
    return [*sorted((ROOT / "ogacq" / "protocol").glob("*.py")),
            ROOT / "ogacq" / "campaign" / "station.py", ROOT / "ogacq" / "campaign" / "run.py",
            ROOT / "ogacq" / "cli" / "wizard" / "guided_station.py"]


@pytest.mark.parametrize("path", _station_modules(), ids=lambda p: p.name)
def test_no_station_is_asked_what_it_has(path):
    """No ``hasattr``/``getattr`` whose object names a station, and no ``__getattr__``
    forwarding: the contract says what a station has."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                and node.func.id in ("hasattr", "getattr") and node.args
                and "station" in ast.unparse(node.args[0]).lower()):
            found.append(f"{path.name}:{node.lineno}: {ast.unparse(node)}")
        if isinstance(node, ast.FunctionDef) and node.name in ("__getattr__",
                                                               "__getattribute__"):
            found.append(f"{path.name}:{node.lineno}: def {node.name}")
    assert not found, found
