"""Typed session records: what is written is what is read back, a reading carries its
step, gauge and posture, and the recorded result is what later stages use."""

from __future__ import annotations

import dataclasses
import json

import pytest

from ogacq.model.gauges import GAUGE_KEYS, GAUGES, Gauge
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, Read, StabilityRule, planned_layout
from ogacq.protocol.runner import CampaignRunner
from ogacq.protocol.station import GaugeValue
from ogacq.session.identification import identify_session, recorded_identification
from ogacq.session.records import (
    EndRecord,
    FaultRecord,
    GaugesSetRecord,
    MoveRecord,
    OffsetsRecord,
    OperatorRecord,
    OtherRecord,
    OverrideRecord,
    PositionRecord,
    ReadingRecord,
    ResultRecord,
    ResumeRecord,
    SettleRecord,
    StationRecord,
    record_from_json,
)
from ogacq.session.store import SessionWriter, load_session
from tests.campaign.station_double import StationDouble

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
READING = ReadingRecord(step="x/c1/p2", gauge=Gauge("y", "x"), cycle=1, posture="max",
                        t_s=12.5, q_mm=(60.2, -1.0, -1.0), tcp_mm=(60.0, 0.0, 0.0),
                        approach=(1, -1, -1), reading_mm=-0.3211, raw="01A+00.3211",
                        source="/dev/ttyUSB0")


# a reading that averaged 16 gauge values, as a stable settle records it (issue 37.7)
AVERAGED = dataclasses.replace(READING, averaged=16, averaged_sd_mm=0.0004)


@pytest.mark.parametrize("record", [
    READING,
    AVERAGED,
    ReadingRecord(step="import/1", gauge=Gauge("z", "y"), cycle=2, posture=None, t_s=0.0,
                  q_mm=(0.0, 0.0, 0.0), tcp_mm=(0.0, 0.0, 0.0), approach=(0, 0, 0),
                  reading_mm=1.0),
    MoveRecord(q_mm=(1.0, 2.0, 3.0), purpose="posture"),
    GaugesSetRecord(leg="y", gauges=("x_y", "z_y")),
    FaultRecord(during="read", attempt=2, error="DeviceTimeout", message="no reply",
                step="x/c1/p1", gauge="z_x"),
    FaultRecord(during="move", attempt=1, error="DeviceFault", message="alarm",
                q_mm=(0.0, 1.0, 0.0)),
    EndRecord(status="stopped", reason="gauge z_x silent", axes_stopped=True, readings=30),
    EndRecord(status="complete"),
    ResultRecord(params="offsets", refit={"parameters": {"joint_offset": {"x": 0.1}}},
                 noise_mm=0.001, noise_source="repeated readings"),
    ResumeRecord(software="ogacq 0.1.0", after_records=12),
    StationRecord(description={"controller": {"profile": "cia402"}}),
    OperatorRecord(action="dial_set", details={"gauge": "y_x", "value_mm": 0.5}),
    OffsetsRecord(stage="intent", details={"operation": "write-1", "new_mm": {"x": 0.1}}),
    OtherRecord(kind="note", content={"text": "from another tool"}),
    SettleRecord(step="x/c1/p1", rule="stable", ended="bound", waited_s=1.0042,
                 values={"y_x": 63, "z_x": 61}, reference=("y_x", "z_x"),
                 u_mm={"y_x": 0.0011, "z_x": 0.0009}),
    SettleRecord(step="x/c1/p2", rule="stable", ended="bound", waited_s=1.0,
                 values={"y_x": 64, "z_x": 20}, unsettled=("y_x",),
                 u_mm={"y_x": 0.0011, "z_x": 0.0009}),
    SettleRecord(step="x/c2/p1", rule="none", ended="not moved", waited_s=0.0),
    PositionRecord(axis="x", run=2, direction=-1, target_mm=-41.23, commanded_mm=-41.24,
                   meant_mm=-41.2339, scale_mm=-40.8122, t_s=31.5, raw="01A-040.8122", averaged=12,
                   averaged_sd_mm=0.0002),
])
def test_every_record_reads_back_as_written(record):
    on_disk = json.loads(json.dumps({**record.to_json(), "wall": 1.5}))
    again = record_from_json(on_disk)
    assert type(again) is type(record) and again.to_json() == {**record.to_json(), "wall": 1.5}


def test_a_settle_record_of_the_earlier_rule_still_loads():
    """Before the rest rule a stable settle recorded no reference and no u."""
    old = {"type": "settle", "step": "x/c1/p2", "rule": "stable", "ended": "stable",
           "waited_s": 0.31, "values": {"y_x": 21, "z_x": 19}}
    record = record_from_json(old)
    assert isinstance(record, SettleRecord)
    assert (record.ended, record.reference, record.u_mm, record.unsettled) == \
        ("stable", (), None, ())
    assert record.to_json() == old


def test_a_reading_keeps_the_wire_keys_of_the_session_format():
    assert list(READING.to_json()) == ["type", "step", "gauge", "leg", "gauge_axis", "cycle",
                                       "posture", "t_s", "q_mm", "tcp_mm", "approach",
                                       "reading_mm", "raw", "source"]


def test_an_averaged_reading_adds_its_count_and_scatter_after_the_keys_it_had():
    """Two optional keys: a session without them (written before, or a value typed by
    eye) reads as before, with nothing averaged said."""
    assert list(AVERAGED.to_json())[-2:] == ["averaged", "averaged_sd_mm"]
    assert (AVERAGED.to_json()["averaged"], AVERAGED.to_json()["averaged_sd_mm"]) == \
        (16, 0.0004)
    old = ReadingRecord.from_json(READING.to_json())
    assert (old.averaged, old.averaged_sd_mm) == (None, None)


@pytest.mark.parametrize(("change", "named"), [
    ({"gauge": "x_x"}, "gauge"), ({"leg": "y"}, "disagree"), ({"cycle": 1.5}, "cycle"),
    ({"posture": 3}, "posture"), ({"reading_mm": float("nan")}, "reading_mm"),
    ({"averaged": 0}, "averaged"), ({"averaged": 2.5}, "averaged"),
    ({"averaged_sd_mm": -0.001}, "averaged_sd_mm"),
])
def test_a_reading_missing_what_later_stages_need_is_refused(change, named):
    with pytest.raises(ValueError, match=f"reading without a valid .*{named}"):
        ReadingRecord.from_json({**READING.to_json(), **change})


def test_one_gauge_type_spells_and_orders_every_gauge():
    assert GAUGE_KEYS == ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")
    assert sorted(reversed(GAUGES)) == list(GAUGES)
    assert [Gauge.parse(k) for k in GAUGE_KEYS] == list(GAUGES)
    assert Gauge.parse("z_y").indices == (2, 1) and Gauge.at(2, 1).key == "z_y"
    for bad in ("x_x", "y", "y_x_z", "q_x", ""):
        with pytest.raises(ValueError, match="is not a gauge; gauges are y_x"):
            Gauge.parse(bad)


class _Station(StationDouble):
    """A station that answers every read and remembers the step it was read for."""

    def __init__(self) -> None:
        self.reads: list[tuple[str, str]] = []

    def read_gauge(self, step: Read, gauge: str, rule: StabilityRule) -> GaugeValue:
        assert gauge in step.gauges
        self.reads.append((step.step, gauge))
        return GaugeValue(0.01 * len(self.reads), "frame", "test")


def test_the_runner_hands_the_station_each_step_and_the_reading_keeps_its_posture(tmp_path):
    config = ProtocolConfig(legs=("x",), postures=("zero", 30.0, "max"), cycles=1)
    station = _Station()
    with SessionWriter.create(tmp_path / "s.jsonl", {"plan": config.to_dict()}) as writer:
        CampaignRunner(station, writer, config, MACHINE).run()
    readings = load_session(tmp_path / "s.jsonl").readings
    assert [(r.step, r.gauge.key) for r in readings] == station.reads
    assert [r.posture for r in readings] == ["zero", "zero", "+30mm", "+30mm", "max", "max"]
    layout = planned_layout(config, MACHINE)
    assert list(layout.posture) == [r.posture for r in readings]


def _finished_session(tmp_path, *, result: ResultRecord | None):
    layout = planned_layout(ProtocolConfig(), MACHINE)
    path = tmp_path / "s.jsonl"
    with SessionWriter.create(path, {"machine": {"leg_length_mm": 310.25, "rho_min_mm": -100.0,
                                                 "rho_max_mm": 60.0,
                                                 "gauge_resolution_mm": 0.001},
                                     "plan": None}) as writer:
        for k in range(len(layout)):
            # a joint offset of the x leg shows as a tilt of its readings, plus some scatter
            value = 0.002 * layout.q_mm[k][0] + 0.001 * ((k * 7) % 5 - 2)
            writer.write(ReadingRecord(
                step=f"r/{k}", gauge=Gauge.at(layout.gauge_axis[k], layout.leg[k]),
                cycle=int(layout.cycle[k]), posture=layout.posture[k], t_s=float(k),
                q_mm=tuple(layout.q_mm[k]), tcp_mm=tuple(layout.tcp_mm[k]),
                approach=tuple(int(a) for a in layout.approach[k]), reading_mm=value))
        writer.write(EndRecord(status="complete"))
        if result is not None:
            writer.write(result)
    return load_session(path)


def test_the_recorded_result_is_used_and_a_session_without_one_is_fitted(tmp_path):
    fitted = identify_session(_finished_session(tmp_path / "a", result=None))
    assert recorded_identification(_finished_session(tmp_path / "b", result=None)).iterations \
        == fitted.iterations > 0
    recorded = ResultRecord(params="offsets", refit=fitted.to_json("offsets"),
                            noise_mm=fitted.noise.sigma_mm, noise_source=fitted.noise.source)
    session = _finished_session(tmp_path / "c", result=recorded)
    assert session.result is not None and session.result.fields() == recorded.fields()
    used = recorded_identification(session)
    assert used.iterations == 0  # not fitted again: evaluated at the recorded values
    assert used.values.tolist() == recorded.values(used.names)
    assert used.residual_rms_mm == pytest.approx(fitted.residual_rms_mm, rel=1e-6)
    assert used.std == pytest.approx(fitted.std, rel=1e-6)


@pytest.mark.parametrize(("line", "named"), [
    # each of these was read as something else before the records were declared once
    ({"type": "end"}, "end without a valid status: it is missing"),
    ({"type": "move", "q_mm": [1.0, 2.0], "purpose": "posture"}, "move without a valid q_mm"),
    ({"type": "fault", "during": "read", "attempt": "2", "error": "E", "message": "m"},
     "fault without a valid attempt: must be a whole number"),
    ({"type": "environment", "stage": "start", "ambient_c": 20.0, "source": None},
     "environment without a valid source"),
    ({"type": "settle", "step": "s", "rule": "stable", "ended": "stable", "waited_s": 1.0,
      "u_mm": {"y_x": 1e400}}, r"settle without a valid u_mm\.y_x: must be a finite number"),
    ({"type": "override", "what": "w", "reason": "r", "subject": "y_x", "due": 20270101},
     "override without a valid due: must be text"),
    ({"type": "offsets", "stage": 3}, "offsets without a valid stage"),
    ({"type": "salvage", "source": "a", "left_out": [{"line": "1", "problem": "p"}]},
     r"salvage without a valid left_out\[0\]\.line"),
    ({"type": "gauges_set", "leg": "x", "gauges": ["y_x"], "wall": "noon"},
     "gauges_set without a valid wall"),
])
def test_a_value_of_another_type_is_refused_naming_its_key(line, named):
    with pytest.raises(ValueError, match=named):
        record_from_json(line)


def test_the_pairs_are_written_together_and_the_nulls_where_declared():
    assert EndRecord(status="stopped", reason="r").to_json() == {
        "type": "end", "status": "stopped", "reason": "r", "axes_stopped": None}
    assert list(FaultRecord(during="read", attempt=None, error="E", message="m",
                            step="s").to_json()) == [
        "type", "during", "step", "gauge", "attempt", "error", "message"]
    assert OverrideRecord(what="w", subject="s", reason="r").to_json() == {
        "type": "override", "what": "w", "subject": "s", "due": None, "reason": "r",
        "operator": None}


@pytest.mark.parametrize(("change", "named"), [
    ({"direction": 0}, "direction"), ({"axis": "w"}, "axis"), ({"run": 0}, "run"),
    ({"scale_mm": "1.0"}, "scale_mm")])
def test_a_positioning_reading_out_of_its_kind_is_refused(change, named):
    good = PositionRecord(axis="y", run=1, direction=1, target_mm=3.0, scale_mm=3.001,
                          t_s=1.0).to_json()
    with pytest.raises(ValueError, match=f"valid {named}"):
        record_from_json({**good, **change})
