"""Each session of a report is identified once: ``ogacq report``'s data hands its
identifications to the record (``build_record(fit=..., validation_fit=...)``), and the
record is the same as one built from the files alone."""

from __future__ import annotations

import json

import ogacq.record.document as document
import ogacq.report.data as report_data
from ogacq.cli.report_cmd import issue_report
from ogacq.record.document import build_record
from ogacq.session.identification import recorded_identification
from ogacq.session.store import load_session

ISSUED = "2026-01-10T10:41:07+01:00"


def test_a_fit_given_is_the_record_s_fit(campaign_sessions):
    plain, with_context = campaign_sessions
    session, validation = load_session(with_context), load_session(plain)
    alone = build_record(session, validation=validation, issued=ISSUED)
    given = build_record(session, validation=validation, issued=ISSUED,
                         fit=recorded_identification(session),
                         validation_fit=recorded_identification(validation))
    for record in (alone, given):  # the Monte-Carlo check's run time: not the content
        record["monte_carlo"].pop("seconds")
    assert json.dumps(given) == json.dumps(alone)


def test_the_report_identifies_each_session_once(campaign_sessions, tmp_path, monkeypatch):
    plain, with_context = campaign_sessions
    identified: list[str] = []

    def counted(session):
        identified.append(session.path.name + ":" + session.path.parent.name)
        return recorded_identification(session)

    monkeypatch.setattr(document, "recorded_identification", counted)
    monkeypatch.setattr(report_data, "recorded_identification", counted)
    issue_report(load_session(with_context), tmp_path, validation=load_session(plain))
    assert sorted(identified) == ["session.jsonl:before", "session.jsonl:with-context"]
    record = json.loads((tmp_path / "record.json").read_text(encoding="utf-8"))
    assert record["results"] and record["validation_results"]
