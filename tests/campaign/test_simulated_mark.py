"""A simulated campaign is said to be one wherever it is recorded and shown: the
session header, record.json, the history, the run's end summary, the report and
`ogacq history`. Sessions from before the mark read as before: simulated where
their station said so, unknown where nothing did."""

from __future__ import annotations

import json

from ogacq.cli.report_cmd import issue_report
from ogacq.record.document import simulated
from ogacq.session.header import SessionHeader
from ogacq.session.store import load_session
from tests.campaign.conftest import write_campaign
from tests.writeback.conftest import FAST_STABILITY, ogacq_here


def test_a_rehearsal_is_marked_simulated_everywhere(campaign_dir, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    path = write_campaign(campaign_dir, seed=3, extra="cycles = 1\n" + FAST_STABILITY,
                          line_at_speed=True)
    history = campaign_dir / "history.sqlite"
    ran = ogacq_here(capsys, monkeypatch, "run", path, "--history", history)
    assert ran.returncode == 0, ran.stderr
    assert "SIMULATED" in ran.stdout  # the end summary
    session = campaign_dir / "session.jsonl"
    assert load_session(session).header.simulated is True

    out = campaign_dir / "report"
    # the report as `ogacq report` writes it (its diagnosis aside)
    page_path, _ = issue_report(load_session(session), out)
    record = json.loads((out / "record.json").read_text())
    assert record["simulated"] is True
    page = page_path.read_text(encoding="utf-8")
    assert "SIMULATED" in page and "not a calibration of the machine" in page

    name = record["machine"]["name"] or record["machine"]["serial"]
    shown = ogacq_here(capsys, monkeypatch, "history", name, "--history", history)
    assert shown.returncode == 0, shown.stderr
    assert "SIMULATED" in shown.stdout
    listed = ogacq_here(capsys, monkeypatch, "history", name, "--history", history, "--json")
    assert [c["simulated"] for c in json.loads(listed.stdout)["calibrations"]] == [True]


def test_sessions_before_the_mark_read_as_they_were_recorded():
    def said(line: dict) -> bool | None:
        return simulated(SessionHeader.from_json(line))

    assert said({"station": {"simulated": True}}) is True
    assert said({"station": {"simulated": False}}) is False
    assert said({"simulator": {"seed": 3}}) is True
    assert said({}) is None  # an imported table: not said
    assert said({"simulated": False, "station": {"simulated": True}}) is False
