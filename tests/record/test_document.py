"""The record document (ogacq-record/1): its id rule, a session from before the
context was recorded (nothing invented), a session with its context, and
``ogacq report`` writing record.json beside a page that shows all of it."""

from __future__ import annotations

import json
import re
import shutil

import pytest

from ogacq.cli.app import main
from ogacq.record.document import FORMAT, build_record
from ogacq.record.identity import record_id
from ogacq.session.store import load_session
from tests.record.pages import page_text, unshown
from tests.record.sessions import (
    DATE,
    INSTRUMENTS,
    MACHINE_NAME,
    MACHINE_SERIAL,
    OPERATOR,
    OVERRIDE_REASON,
    with_context,
)

ID = re.compile(r"OGQ-\d{8}-[0-9a-f]{8}")


def test_the_id_is_the_session_s_own(campaign_sessions, tmp_path):
    plain, with_context = campaign_sessions
    first = build_record(load_session(plain))
    assert ID.fullmatch(first["id"])
    assert first["id"] == build_record(load_session(plain))["id"]  # built again: same id
    moved = tmp_path / "elsewhere.jsonl"
    shutil.copyfile(plain, moved)  # the same session under another name: the same record
    assert build_record(load_session(moved))["id"] == first["id"]
    other = build_record(load_session(with_context))
    assert other["id"] != first["id"]
    assert other["id"].startswith("OGQ-20260110-")  # the campaign's date, not today's
    header = plain.read_bytes().split(b"\n", 1)[0]
    assert first["id"] == record_id(header, first["date"])
    # one byte more in the header (another station, another start time) is another id
    assert record_id(header.replace(b'"seed":3', b'"seed":4'), first["date"]) != first["id"]


def test_a_session_from_before_gives_nulls_and_says_so(campaign_sessions, tmp_path):
    plain, _ = campaign_sessions
    session = load_session(plain)
    record = build_record(session)
    assert record["format"] == FORMAT
    assert record["machine"]["name"] is None and record["machine"]["serial"] is None
    assert record["operator"] is None and record["overrides"] is None
    assert record["environment"] == {"start": None, "end": None}
    # the gauges' serials are in the station description; nothing else is known of them
    assert [i["serial"] for i in record["instruments"]] == [
        g["serial"] for g in session.header.station["gauges"].values()]
    assert all(i["certificate"] is None and i["due"] is None and i["expired"] is None
               for i in record["instruments"])
    assert record["date"].startswith(session.header.created[:19])
    for key in ("operator", "machine serial", "certificates", "environment", "overrides",
                "uncertainty budget"):
        assert key in record["missing"], key
    # results: the recorded identification's values and std; the budget without the
    # certificates and temperatures is incomplete and says which sources it lacks
    refit = session.result.refit
    for axis, result in record["results"]["joint_offset"].items():
        assert result["value_mm"] == pytest.approx(refit["parameters"]["joint_offset"][axis])
        assert result["std_mm"] == pytest.approx(refit["std"]["joint_offset"][axis])
        assert result["complete"] is False
        assert result["U_mm"] == pytest.approx(2 * result["u_mm"], abs=2e-9)
    assert record["budget_complete"] is False
    rows = record["budget"]["joint_offset.x"]
    not_evaluated = {r["source"].split(" ")[0] for r in rows if not r["evaluated"]}
    assert {"gauge", "temperature"} <= not_evaluated
    assert all(r["u_mm"] is None for r in rows if not r["evaluated"])  # not a zero
    assert "gauge calibration" in record["missing"]["uncertainty budget"]
    assert record["acceptance"]["as_found"]["decision"] == "not evaluated"
    assert record["acceptance"]["as_found"]["why"] == "the machine file states no tolerances"
    assert record["acceptance"]["as_left"]["why"] == "no as-left measurement"
    assert record["verdict"]["state"] == "consistent"
    assert record["session"]["sha256"] == __import__("hashlib").sha256(
        plain.read_bytes()).hexdigest()

    assert main(["report", str(plain), "--out", str(tmp_path / "old")]) == 0
    text = page_text((tmp_path / "old" / "report.html").read_text(encoding="utf-8"))
    assert "machine not recorded" in text and "operator not recorded" in text
    assert "the session does not record the temperatures" in text
    assert "budget incomplete u and U leave out the sources that were not evaluated" in text
    assert "No earlier calibration is known: no history database yet in ogacq's data folder" in text


def test_report_writes_the_record_the_page_shows(campaign_sessions, tmp_path, capsys):
    _, with_context = campaign_sessions
    out = tmp_path / "out"
    assert main(["report", str(with_context), "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[0] == str(out / "report.html")
    record = json.loads((out / "record.json").read_text(encoding="utf-8"))
    page = (out / "report.html").read_text(encoding="utf-8")
    text = page_text(page)

    assert record["id"] == build_record(load_session(with_context))["id"]
    assert record["machine"]["name"] == MACHINE_NAME and record["operator"] == OPERATOR
    assert record["machine"]["serial"] == MACHINE_SERIAL and record["date"] == DATE
    assert [i["certificate"] for i in record["instruments"]] == [
        i["certificate"] for i in INSTRUMENTS]
    expired = [i["gauge"] for i in record["instruments"] if i["expired"]]
    assert expired == ["y_x"]
    assert record["overrides"][0]["reason"] == OVERRIDE_REASON
    assert record["environment"]["end"]["ambient_c"] == 21.1
    assert set(record["missing"]) == {"history"}  # all else recorded and evaluated
    # the budget from the certificates and temperatures, checked by Monte-Carlo
    assert record["budget_complete"] is True
    for result in record["results"]["joint_offset"].values():
        assert result["complete"] and 0 < result["std_mm"] < result["u_mm"]
        assert result["U_mm"] == pytest.approx(2 * result["u_mm"])
    assert record["monte_carlo"]["agrees_within_10_percent"] is True
    # as found against the machine file's 0.02 mm: the offsets of a few tenths fail
    found = record["acceptance"]["as_found"]
    assert record["acceptance"]["rule"] == found["rule"] == "guard-band"
    assert found["decision"] == "fail" and len(found["rows"]) == 12
    for row in found["rows"]:
        d, U, T = abs(row["value_mm"]), row["U_mm"], row["tolerance_mm"]
        assert T == 0.02 and U > 0
        assert row["decision"] == ("pass" if d <= T - U else "fail" if d > T + U
                                   else "undecided")
    assert record["acceptance"]["as_left"]["decision"] == "not evaluated"

    # every value of record.json is on the page, as record.json holds it
    assert unshown(record, text) == []
    assert f"Calibration record {record['id']}" in text
    assert f'content:"Calibration record {record["id"]}"' in page  # the printed pages' margin
    # the expired gauge stands out, with its override
    row = re.search(r'<tr class="row-bad">(.*?)</tr>', page)
    assert row and "12340000" in row.group(1) and "EXPIRED, used under override" in row.group(1)
    assert f"expired-gauge y_x 12340000 2026-01-01 {OVERRIDE_REASON} {OPERATOR}" in text
    assert not (out / "history.png").exists()  # no history given: no plot
    assert "No earlier calibration is known: no history database yet in ogacq's data folder" in text


def test_report_takes_the_earlier_calibrations_from_the_history(campaign_sessions, tmp_path,
                                                                capsys):
    """Earlier calibrations of the same machine recorded in an SQLite history: the
    report plots those before this one, not this one, not later ones."""
    from ogacq.history.location import parse_location
    from ogacq.history.store import History

    ran = campaign_sessions[0].parent.parent / "campaign" / "session.jsonl"
    database = tmp_path / "history.sqlite"
    records = {}
    with History.open(parse_location(str(database), "test")) as history:
        for date in ("2025-06-01T10:00:00", DATE, "2026-06-01T10:00:00"):
            session = load_session(with_context(ran, tmp_path / date[:10] / "s.jsonl", date))
            records[date] = build_record(session)
            history.record_calibration(records[date], session_path=str(session.path))
    out = tmp_path / "out"
    assert main(["report", str(tmp_path / DATE[:10] / "s.jsonl"), "--history", str(database),
                 "--out", str(out)]) == 0
    capsys.readouterr()
    record = json.loads((out / "record.json").read_text(encoding="utf-8"))
    earlier = records["2025-06-01T10:00:00"]
    assert [(h["id"], h["date"]) for h in record["history"]] == [(earlier["id"],
                                                                 earlier["date"])]
    assert record["history"][0]["results"]["joint_offset"]["x"]["U_mm"] == \
        earlier["results"]["joint_offset"]["x"]["U_mm"]
    assert (out / "history.png").stat().st_size > 10_000
    assert "history" not in record["missing"]
    # a history named but not there is an error, not an empty plot
    assert main(["report", str(tmp_path / DATE[:10] / "s.jsonl"), "--history",
                 str(tmp_path / "nowhere.sqlite"), "--out", str(tmp_path / "o2")]) == 3
    assert "no history here" in capsys.readouterr().err


def test_as_left_is_judged_from_the_validation_campaign(campaign_sessions, tmp_path):
    """The as-left stage takes the validation campaign's own deviations and budget
    (here a copy of the same campaign: the same decisions)."""
    _, with_context = campaign_sessions
    copy = tmp_path / "validation.jsonl"
    shutil.copyfile(with_context, copy)
    record = build_record(load_session(with_context), validation=load_session(copy))
    found, left = record["acceptance"]["as_found"], record["acceptance"]["as_left"]
    assert left["decision"] == found["decision"] and left["rows"] == found["rows"]
    assert record["validation_session"]["path"] == str(copy.resolve())


def test_a_history_entry_without_a_date_is_refused(campaign_sessions):
    plain, _ = campaign_sessions
    with pytest.raises(ValueError, match="history entry"):
        build_record(load_session(plain), history=[{"id": "OGQ-x"}])


def test_a_session_without_readings_still_gives_a_record(tmp_path):
    """Nothing identified: no results, no verdict, acceptance not evaluated and why."""
    from ogacq.session.store import SessionWriter

    machine = {"leg_length_mm": 310.25, "rho_min_mm": -100.0, "rho_max_mm": 60.0,
               "gauge_resolution_mm": 0.001, "name": MACHINE_NAME,
               "tolerances": {"deviation_mm": 0.02, "decision_rule": "simple"}}
    with SessionWriter.create(tmp_path / "empty.jsonl", {"machine": machine}):
        pass
    record = build_record(load_session(tmp_path / "empty.jsonl"))
    assert record["results"] is None and record["verdict"] is None
    assert record["budget"] is None and record["monte_carlo"] is None
    assert record["acceptance"]["rule"] == "simple"
    assert record["acceptance"]["as_found"] == {
        "decision": "not evaluated", "rule": "simple", "rows": [],
        "why": "nothing was identified"}
    assert record["missing"]["results"] == ("the session holds no readings: nothing was "
                                            "identified")
    assert main(["report", str(tmp_path / "empty.jsonl"), "--out", str(tmp_path / "r")]) == 4
    assert main(["report", str(tmp_path / "empty.jsonl"), "--out", str(tmp_path / "r"),
                 "--partial"]) == 0  # no end record: a partial campaign, said
    text = page_text((tmp_path / "r" / "report.html").read_text(encoding="utf-8"))
    written = json.loads((tmp_path / "r" / "record.json").read_text(encoding="utf-8"))
    assert unshown(written, text) == []
    assert "no result the session holds no readings: nothing was identified" in text
