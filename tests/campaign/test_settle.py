"""A campaign as short as the physics allows: the gauges of a posture read at once, no
settle where nothing moved, and a settle that ends when the gauges agree, on a
simulator that rings after every move."""

import threading

import numpy as np
import pytest

from ogacq_drivers.errors import DeviceTimeout
from ogacq_drivers.indicators.concurrent import line_groups
from ogacq.campaign_file import read_campaign
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.protocol.plan import ProtocolConfig, Read, StabilityRule, reading_steps
from ogacq.protocol.runner import CampaignRunner, CampaignStopped, GaugeValue
from ogacq.session.records import FaultRecord, SettleRecord
from ogacq.session.store import SessionWriter, load_session
from ogacq.station import open_station
from tests.campaign.conftest import write_campaign

# A slow, strong ringing, so that the simulated gauges (an exchange every 16 ms of real
# time, 0.16 s of machine time at speed 10) sample it several times a period.
RINGING = "[vibration]\namplitude_mm = 0.05\ntime_constant_s = 0.5\nfrequency_hz = 2.0\n"
SETTLE = "settle_s = 5.0\nsettle_window_s = 0.5\n"


def _ringing_campaign(tmp_path, settle: str, cycles: int = 2):
    (tmp_path / "effects.toml").write_text(RINGING)
    path = write_campaign(tmp_path, seed=2, speed=10, extra=(
        f'legs = ["x"]\ncycles = {cycles}\nsettle = "{settle}"\n' + SETTLE))
    text = path.read_text().replace("settle_s = 0.5\n", "")
    path.write_text(text.replace("[simulator]\n", '[simulator]\neffects = "effects.toml"\n'))
    return read_campaign(path)


class _Clocked:
    """The station's gauges, each value logged with the simulator's time."""

    def __init__(self, station) -> None:
        self.log: dict[str, list[tuple[float, float]]] = {g: [] for g in station.indicators}
        clock = station.simulator.clock
        for gauge, indicator in station.indicators.items():
            read = indicator.read

            def logged(*args, _read=read, _gauge=gauge, **kwargs):
                reading = _read(*args, **kwargs)
                self.log[_gauge].append((clock.now(), reading.value_mm))
                return reading

            indicator.read = logged


def test_stable_settle_ends_once_the_ringing_is_within_tolerance_and_is_recorded(tmp_path):
    campaign = _ringing_campaign(tmp_path, "stable")
    tolerance = campaign.protocol.stability.tolerance_mm
    with open_station(campaign) as station:
        station.prepare()
        clocked = _Clocked(station)
        machine = station.simulator.machine
        ends: list[tuple[str, dict[str, float]]] = []
        settled = station.read_settled

        def watched(step, gauges, rule):
            out = settled(step, gauges, rule)
            stop = machine.encoders.stopped_at_s()
            # the ringing each gauge still had when its last value was read
            ends.append((step.step, {g: machine.truth.vibration.envelope_mm(
                clocked.log[g][-1][0] - stop) for g in gauges}))
            return out

        station.read_settled = watched
        with SessionWriter.create(campaign.session, {"plan": campaign.protocol.to_dict()}) \
                as writer:
            CampaignRunner(station, writer, campaign.protocol, campaign.machine).run()
    session = load_session(campaign.session)
    assert session.header["plan"]["settle"] == "stable"
    assert session.header["plan"]["settle_window_s"] == 0.5
    records = {r.step: r for r in session.of_type(SettleRecord)}
    steps = [s.step for s in reading_steps(campaign.protocol, campaign.machine)]
    assert list(records) == steps, "one settle record per reading step"
    # Zero read again at the next cycle's start: nothing moved, nothing to settle
    assert records["x/c2/p1"].rule == "none" and records["x/c2/p1"].ended == "not moved"
    stable = [r for r in records.values() if r.rule == "stable"]
    assert len(stable) == len(steps) - 1 and len(ends) == len(stable)
    for record in stable:
        assert record.ended == "stable", record
        # early: well inside the fixed wait it replaces
        assert record.waited_s < 0.8 * campaign.protocol.settle_s, record
        # the ringing was there to wait for: more values than a stable reading needs
        assert max(record.values.values()) > campaign.protocol.stability.readings, record
    for step, envelope in ends:  # never before the gauges are stable
        assert max(envelope.values()) <= tolerance, (step, envelope)
    # the ringing was visible in the values the gauges read during the settles
    spreads = [np.ptp([v for _, v in clocked.log[g][:6]]) for g in ("y_x", "z_x")]
    assert max(spreads) > 5 * tolerance


def test_fixed_settle_waits_the_time_where_something_moved_only(tmp_path):
    campaign = _ringing_campaign(tmp_path, "fixed")
    waits = []
    with open_station(campaign) as station:
        station.prepare()
        station.settle = waits.append  # the wait itself is time.sleep: recorded, not slept
        with SessionWriter.create(campaign.session, {"plan": None}) as writer:
            CampaignRunner(station, writer, campaign.protocol, campaign.machine).run()
    records = load_session(campaign.session).of_type(SettleRecord)
    assert [r.rule for r in records] == ["fixed"] * 4 + ["none"] + ["fixed"] * 3
    assert waits == [5.0] * 7
    assert {r.waited_s for r in records if r.rule == "fixed"} == {5.0}


def test_the_gauges_of_a_posture_are_read_at_once_through_their_endpoints(tmp_path):
    """Each gauge's first exchange waits until the other's has begun: read one after
    the other, the first would wait in vain."""
    campaign = read_campaign(write_campaign(tmp_path, seed=1, speed=20))
    step = reading_steps(campaign.protocol, campaign.machine)[0]
    with open_station(campaign) as station:
        station.prepare()
        started = {g: threading.Event() for g in step.gauges}
        for gauge in step.gauges:
            indicator = station.indicators[gauge]
            read = indicator.read
            other = next(g for g in step.gauges if g != gauge)

            def meeting(*args, _read=read, _me=gauge, _other=other, **kwargs):
                started[_me].set()
                assert started[_other].wait(10.0), f"{_me} read alone: not in parallel"
                return _read(*args, **kwargs)

            indicator.read = meeting
        values = station.read_gauges(step, step.gauges, StabilityRule())
        assert all(isinstance(v, GaugeValue) for v in values.values()), values
        for event in started.values():
            event.clear()
        rule = ProtocolConfig(settle_s=1.0).settle_rule
        settled = station.read_settled(step, step.gauges, rule)
        assert all(s.value is not None for s in settled.values()), settled


def test_gauges_sharing_a_line_are_read_in_turn_on_it():
    class Driver:
        def __init__(self, link):
            self.link = link

    mux, own = object(), object()
    drivers = {"y_x": Driver(mux), "z_x": Driver(mux), "x_y": Driver(own), "usb": object()}
    assert line_groups(drivers) == [["y_x", "z_x"], ["x_y"], ["usb"]]


class _Station:
    """Answers reads at once; gauge ``failing`` times out ``failures`` times first."""

    def __init__(self, failing: str = "", failures: int = 0) -> None:
        self.failing, self.failures = failing, failures
        self.settled: list[float] = []
        self.batches: list[tuple[str, ...]] = []

    def move(self, q_mm, timeout_s):
        return q_mm

    def read_gauges(self, step: Read, gauges, rule):
        self.batches.append(tuple(gauges))
        out = {}
        for gauge in gauges:
            if gauge == self.failing and self.failures:
                self.failures -= 1
                out[gauge] = DeviceTimeout("no reply before the deadline", where=gauge)
            else:
                out[gauge] = GaugeValue(0.001 * len(self.batches), "frame", gauge)
        return out

    def read_gauge(self, step, gauge, rule):
        raise AssertionError("read_gauges reads them all")

    def campaign_time_s(self):
        return 0.0

    def settle(self, seconds):
        self.settled.append(seconds)

    def stop_axes(self):
        pass

    def recover_axes(self):
        return True


def _run(tmp_path, station, config):
    with SessionWriter.create(tmp_path / "s.jsonl", {"plan": None}) as writer:
        CampaignRunner(station, writer, config, PAPER_PROTOTYPE).run()


def test_a_failing_gauge_is_retried_alone_and_the_other_reading_kept(tmp_path):
    config = ProtocolConfig(legs=("x",), postures=("zero", "max"), cycles=1, settle="fixed")
    station = _Station("z_x", failures=2)
    _run(tmp_path, station, config)
    assert station.batches == [("y_x", "z_x"), ("z_x",), ("z_x",), ("y_x", "z_x")]
    session = load_session(tmp_path / "s.jsonl")
    assert [(r.step, r.gauge.key) for r in session.readings] == [
        ("x/c1/p1", "y_x"), ("x/c1/p1", "z_x"), ("x/c1/p2", "y_x"), ("x/c1/p2", "z_x")]
    assert [f.attempt for f in session.of_type(FaultRecord)] == [1, 2]
    assert station.settled == [1.0, 1.0]


def test_a_gauge_failing_every_attempt_stops_with_the_other_reading_on_file(tmp_path):
    config = ProtocolConfig(legs=("x",), postures=("zero",), cycles=1)
    with pytest.raises(CampaignStopped, match="gauge z_x at x/c1/p1.*3 attempts"):
        _run(tmp_path, _Station("z_x", failures=5), config)
    session = load_session(tmp_path / "s.jsonl")
    assert [(r.step, r.gauge.key) for r in session.readings] == [("x/c1/p1", "y_x")]
    # a station without a settle by the gauges' values settles by the fixed wait
    assert [r.rule for r in session.of_type(SettleRecord)] == ["fixed"]
