"""The calibration record as a type (ogacq.record.calibration_record): record.json read
and written back exactly, unknown keys and unexpected types included."""

from __future__ import annotations

import json
from pathlib import Path

from ogacq.record.calibration_record import CalibrationRecord

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "record.json"


def test_an_issued_record_reads_as_it_was_written():
    for name, document in json.loads(GOLDEN.read_text(encoding="utf-8")).items():
        record = CalibrationRecord.from_json(document)
        assert json.dumps(record.to_json()) == json.dumps(document), name
        assert record.id == document["id"] and record.format == "ogacq-record/1"
        assert record.results is not None and set(record.results) == {"joint_offset"}
        assert record.session is not None and record.session["sha256"]
        assert "monte_carlo" in record.extra and "results" not in record.extra


def test_unknown_keys_and_unexpected_types_are_kept_where_they_were():
    document = {"format": "ogacq-record/1", "id": 17, "revision": True, "future": [1],
                "results": None, "history": [{"id": "OGQ-1"}]}
    record = CalibrationRecord.from_json(document)
    assert json.dumps(record.to_json()) == json.dumps(document)
    assert record.id is None and record.extra["id"] == 17  # not what this version writes
    assert record.revision is None and record.extra["revision"] is True  # not a number
    assert record.results is None and "results" in record and "operator" not in record
    assert record.history == [{"id": "OGQ-1"}]
