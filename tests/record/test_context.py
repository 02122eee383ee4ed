"""calibration_context reads who, what, with which instruments, when and at what
temperature from a session; a session written before these were recorded reads
with what it does not say unknown, never an error."""

from __future__ import annotations

import datetime

from ogacq.model.instrument import Instrument
from ogacq.record.context import Environment, Override, Temperatures, calibration_context
from ogacq.session.records import EnvironmentRecord, OverrideRecord, record_from_json
from ogacq.session.store import SessionWriter, load_session

MACHINE = {"leg_length_mm": 310.25, "rho_min_mm": -100.0, "rho_max_mm": 60.0,
           "gauge_resolution_mm": 0.001}
Y_X = Instrument("y_x", "Mitutoyo", "543-790B", "12345678", "DKD-K-12345 2026-0412",
                 datetime.date(2025, 1, 1), datetime.date(2026, 1, 1), 0.0015, 2.0, 0.001)


def test_a_session_with_its_context_reads_it_back(tmp_path):
    header = {"machine": {**MACHINE, "name": "OG-1 cell 3", "serial": "OG-2026-0017"},
              "identity": {"machine": "OG-1 cell 3", "serial": "OG-2026-0017",
                           "operator": "J. Martin"},
              "instruments": [Y_X.to_json(), Instrument("z_x", serial="77").to_json()],
              "date": "2026-01-10T09:00:00",
              "simulator": {"seed": 3, "date": "2026-01-10T09:00:00", "simulated_date": True}}
    with SessionWriter.create(tmp_path / "s.jsonl", header) as writer:
        writer.write(EnvironmentRecord(stage="start", ambient_c=20.4, machine_c=None,
                                       source="typed"))
        writer.write(OverrideRecord(what="expired-gauge", subject="y_x 12345678",
                                    due="2026-01-01", reason="checked on gauge blocks",
                                    operator="J. Martin"))
        writer.write(EnvironmentRecord(stage="start", ambient_c=25.0, source="typed"))  # resume
        writer.write(EnvironmentRecord(stage="end", ambient_c=21.0, machine_c=21.5,
                                       source="sensor"))
    context = calibration_context(load_session(tmp_path / "s.jsonl"))
    assert (context.machine_name, context.machine_serial, context.operator) == (
        "OG-1 cell 3", "OG-2026-0017", "J. Martin")
    assert context.date == datetime.datetime(2026, 1, 10, 9, 0) and context.simulated_date
    assert context.instruments == (Y_X, Instrument("z_x", serial="77"))
    assert context.expired(Y_X) is True and context.expired(context.instruments[1]) is None
    assert context.environment == Environment(Temperatures(20.4, None, "typed"),
                                              Temperatures(21.0, 21.5, "sensor"))
    assert context.environment.temperature_c == (20.4 + 21.5) / 2
    assert context.overrides == (Override("expired-gauge", "y_x 12345678",
                                          "checked on gauge blocks",
                                          datetime.date(2026, 1, 1), "J. Martin"),)


def test_a_session_from_before_reads_with_unknowns(tmp_path):
    header = {"machine": MACHINE, "station": {"gauges": {"y_x": {"serial": "SN 1"},
                                                         "z_x": {"serial": ""}}}}
    with SessionWriter.create(tmp_path / "old.jsonl", header):
        pass
    context = calibration_context(load_session(tmp_path / "old.jsonl"))
    assert (context.machine_name, context.machine_serial, context.operator) == (None,) * 3
    assert context.date is not None  # when the session was created
    assert context.instruments == (Instrument("y_x", serial="SN 1"), Instrument("z_x"))
    assert context.environment == Environment(None, None)
    assert context.environment.temperature_c is None and context.overrides == ()
    assert not context.simulated_date


def test_records_refuse_what_later_stages_cannot_read():
    for bad in ({"type": "environment", "stage": "middle", "ambient_c": 20.0},
                {"type": "environment", "stage": "end", "ambient_c": "warm"},
                {"type": "override", "subject": "y_x"}):
        try:
            record_from_json(bad)
        except ValueError:
            continue
        raise AssertionError(f"accepted {bad}")
