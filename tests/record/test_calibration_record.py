"""The calibration record as a type (ogacq.record.calibration_record): record.json read
and written back exactly, unknown keys and unexpected types included; its sections
read typed, one of another shape refused naming its key."""

from __future__ import annotations

import json
import re
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


EDITED = {
    "format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
    "machine": {"name": " OG-1 ", "serial": "17", "leg_length_mm": 310.25},
    "results": {"joint_offset": {"x": {"value_mm": 0.25, "u_mm": 0.01, "U_mm": 0.02, "k": 2,
                                       "std_mm": None, "note": "edited"},
                                 "z": {"value_mm": None}}},
    "acceptance": {"rule": "guard-band", "as_found": {"decision": "pass", "rows": [],
                                                      "rule": "guard-band"}},
    "environment": {"start": {"ambient_c": 20.5, "machine_c": None}, "end": None},
    "history": [{"id": "OGQ-20250101-00000002", "date": "2025-01-01",
                 "results": {"joint_offset": {"x": {"value_mm": 0.2, "U_mm": 0.03}}}}],
}


def test_the_typed_sections_of_a_record_and_what_they_keep_as_written():
    record = CalibrationRecord.from_json(EDITED)
    assert json.dumps(record.to_json()) == json.dumps(EDITED)
    x, z = record.result_entries
    assert (x.name, x.entry.value_mm, x.entry.u_mm, x.entry.U_mm, x.entry.k) == (
        "joint_offset.x", 0.25, 0.01, 0.02, 2)
    assert x.entry.extra == {"note": "edited"} and (z.name, z.entry.value_mm) == (
        "joint_offset.z", None)
    assert record.verdict_section is None
    acceptance = record.acceptance_section
    assert (acceptance.rule, acceptance.as_found.decision, acceptance.as_found.extra) == (
        "guard-band", "pass", {"rule": "guard-band"})
    assert acceptance.as_left.decision is None and acceptance.as_left.rows == ()
    (earlier,) = record.history_entries
    assert (earlier.id, earlier.date, earlier.results["joint_offset"]["x"].U_mm) == (
        "OGQ-20250101-00000002", "2025-01-01", 0.03)
    assert (record.machine_section.name, record.machine_section.serial) == (" OG-1 ", "17")
    assert record.machine_section.extra == {"leg_length_mm": 310.25}
    assert record.environment_stages["start"].ambient_c == 20.5  # type: ignore[union-attr]
    assert record.validation_session_file is None and record.session_file.path is None


# a section of another shape than the record writes (a hand-edited record.json): its key
SHAPES = [
    ({"machine": {"name": "OG-1", "serial": 17}}, "machine.serial",
     "must be text, got a number"),
    ({"results": {"joint_offset": {"y": "not an entry"}}}, "results.joint_offset.y",
     "must be an object, got text"),
    ({"results": {"joint_offset": {"z": {"value_mm": "0.3"}}}}, "results.joint_offset.z.value_mm",
     "must be a number, got text"),
    ({"acceptance": {"as_left": "not an object"}}, "acceptance.as_left",
     "must be an object, got text"),
    ({"environment": {"start": {"ambient_c": "warm"}}}, "environment.start.ambient_c",
     "must be a number, got text"),
    ({"history": ["not an entry"]}, "history[0]", "must be an object, got text"),
    ({"session": {"records": "12"}}, "session.records", "must be a whole number, got text"),
]


@pytest.mark.parametrize(("edit", "key", "problem"), SHAPES)
def test_the_history_and_the_page_refuse_a_section_of_another_shape_naming_its_key(
        edit, key, problem):
    from ogacq.history.entries import check_record
    from ogacq.record.declared import RecordSectionError
    from ogacq.report.record_view import record_view

    record = EDITED | edit
    assert json.dumps(CalibrationRecord.from_json(record).to_json()) == json.dumps(record)
    said = f"the calibration record's {key} {problem}"
    with pytest.raises(RecordSectionError) as raised:
        record_view(CalibrationRecord.from_json(record))
    assert str(raised.value).startswith(said) and raised.value.exit_code == 2
    if key.split(".")[0].split("[")[0] in ("machine", "results", "acceptance", "environment",
                                          "session"):
        with pytest.raises(RecordSectionError, match=re.escape(said)):
            check_record(record)


def test_the_history_and_the_page_read_an_edited_record():
    from ogacq.history.entries import (
        RecordError,
        acceptance_decision,
        ambient_of,
        check_record,
        machine_of,
        parameters_of,
        record_columns,
    )
    from ogacq.history.plot import recorded_calibrations
    from ogacq.report.record_view import record_view

    assert check_record(EDITED) == EDITED
    assert machine_of(EDITED) == ("OG-1", "17")
    assert [(p.name, p.value_mm, p.expanded_mm) for p in parameters_of(EDITED)] == [
        ("joint_offset.x", 0.25, 0.02)]
    assert acceptance_decision(EDITED) == "pass" and ambient_of(EDITED) == 20.5
    assert record_columns(EDITED)["acceptance"] == EDITED["acceptance"]  # kept as recorded
    assert [c.record_id for c in recorded_calibrations(EDITED)] == [
        "OGQ-20250101-00000002", "OGQ-20260110-00000001"]
    view = record_view(CalibrationRecord.from_json(EDITED))
    assert view["verdict"] is None and view["results"] is not None
    assert view["acceptance"]["stages"][0]["why"] is None
    for edit, message in (({"format": 1}, "not an ogacq-record/1 record (format 1)"),
                          ({"id": 17}, "the record has no id"),
                          ({"machine": {"name": "  "}},
                           "record OGQ-20260110-00000001 names no machine")):
        with pytest.raises(RecordError) as raised:
            check_record(EDITED | edit)
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
