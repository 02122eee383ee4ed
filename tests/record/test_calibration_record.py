"""The calibration record as a type (ogacq.record.calibration_record): record.json read
and written back exactly, unknown keys and unexpected types included."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ogacq.record.calibration_record import CalibrationRecord

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "record.json"


def test_an_issued_record_reads_as_it_was_written():
    for name, document in json.loads(GOLDEN.read_text(encoding="utf-8")).items():
        record = CalibrationRecord.from_json(document)
        assert json.dumps(record.to_json()) == json.dumps(document), name
        assert record.id == document["id"] and record.format == "ogacq-record/1"
        assert record.results is not None and set(record.results) == {"joint_offset"}
        assert record.session is not None and record.session["sha256"]
        assert record.extra == {}, name  # every section this version writes is named
        assert record.monte_carlo is not None and record.budget_complete is not None


def test_unknown_keys_and_unexpected_types_are_kept_where_they_were():
    document = {"format": "ogacq-record/1", "id": 17, "revision": True, "future": [1],
                "results": None, "history": [{"id": "OGQ-1"}]}
    record = CalibrationRecord.from_json(document)
    assert json.dumps(record.to_json()) == json.dumps(document)
    assert record.id is None and record.extra["id"] == 17  # not what this version writes
    assert record.revision is None and record.extra["revision"] is True  # not a number
    assert record.results is None and "results" in record and "operator" not in record
    assert record.history == [{"id": "OGQ-1"}]


HAND_EDITED = {
    "format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
    "machine": {"name": " OG-1 ", "serial": 17},
    "results": {"joint_offset": {"x": {"value_mm": 0.25, "u_mm": 0.01, "U_mm": 0.02, "k": 2,
                                       "std_mm": None, "note": "edited"},
                                 "y": "not an entry", "z": {"value_mm": "0.3"}},
                "broken_group": [1, 2]},
    "verdict": ["consistent"],  # not an object: kept as written, not read as a verdict
    "acceptance": {"rule": "guard-band", "as_found": {"decision": "pass", "rows": [3]},
                   "as_left": "not an object"},
    "history": [{"id": "OGQ-20250101-00000002", "date": "2025-01-01",
                 "results": {"joint_offset": {"x": {"value_mm": 0.2, "U_mm": 0.03}}}},
                "not an entry"],
}


def test_the_typed_sections_of_a_hand_edited_record():
    """What is not of the shape the record writes reads as absent, as the readers
    read it by hand; the rest is read."""
    record = CalibrationRecord.from_json(HAND_EDITED)
    assert json.dumps(record.to_json()) == json.dumps(HAND_EDITED)
    x, z = record.result_entries
    assert (x.name, x.value_mm, x.u_mm, x.U_mm, x.k, x.std_mm) == (
        "joint_offset.x", 0.25, 0.01, 0.02, 2.0, None)
    assert x.fields["note"] == "edited" and (z.name, z.value_mm) == ("joint_offset.z", None)
    assert record.verdict is None and record.verdict_read is None
    assert record.as_written("verdict") == ["consistent"]
    acceptance = record.acceptance_read
    assert (acceptance.rule, acceptance.as_found.decision, acceptance.as_found.rows) == (
        "guard-band", "pass", ())
    assert acceptance.as_left.decision is None and acceptance.as_left.rows == ()
    (earlier,) = record.history_entries
    assert (earlier.id, earlier.date, [r.U_mm for r in earlier.results]) == (
        "OGQ-20250101-00000002", "2025-01-01", [0.03])
    assert (record.machine_named.name, record.machine_named.serial) == (" OG-1 ", "17")
    assert record.validation_reference is None and record.session_reference.path is None


def test_the_history_and_the_page_read_a_hand_edited_record():
    from ogacq.history.entries import (
        RecordError,
        acceptance_decision,
        check_record,
        machine_of,
        parameters_of,
        record_columns,
    )
    from ogacq.history.plot import recorded_calibrations
    from ogacq.report.record_view import record_view

    assert check_record(HAND_EDITED) == HAND_EDITED
    assert machine_of(HAND_EDITED) == ("OG-1", "17")
    assert [(p.name, p.value_mm, p.expanded_mm) for p in parameters_of(HAND_EDITED)] == [
        ("joint_offset.x", 0.25, 0.02)]
    assert acceptance_decision(HAND_EDITED) == "pass"
    assert record_columns(HAND_EDITED)["verdict"] == ["consistent"]  # kept as recorded
    assert [c.record_id for c in recorded_calibrations(HAND_EDITED)] == [
        "OGQ-20250101-00000002", "OGQ-20260110-00000001"]
    view = record_view(CalibrationRecord.from_json(HAND_EDITED))
    assert view["verdict"] is None and view["results"] is not None
    assert view["acceptance"]["stages"][0]["why"] is None
    for edit, message in (({"format": 1}, "not an ogacq-record/1 record (format 1)"),
                          ({"id": 17}, "the record has no id"),
                          ({"machine": {"name": "  "}},
                           "record OGQ-20260110-00000001 names no machine")):
        with pytest.raises(RecordError) as raised:
            check_record(HAND_EDITED | edit)
        assert str(raised.value) == message


def test_the_page_says_a_p_value_as_the_terminal_does():
    """One quantity, one face (issue 38.6): the verdict's p read 0.00000000000000028 on
    the page where the terminal said 2.8e-16."""
    from ogacq.report.record_view import verdict

    found = verdict(CalibrationRecord.from_json(
        {"verdict": {"state": "inconsistent", "p": 2.8e-16, "p_overall": 0.5,
                     "chi2_dof": 3.2}}))
    assert found is not None
    rows = dict((str(a), str(b)) for a, b in found.rows)
    assert rows["combined p (overall and worst cell, Bonferroni)"] == "2.8e-16"
    assert rows["overall p"] == "0.5" and rows["χ² per dof"] == "3.2"
