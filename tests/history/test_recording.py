"""A history that cannot be reached, or is not an ogacq history, never costs the
campaign: the session is complete, the command succeeds, and one warning says how
to add the session later."""

from __future__ import annotations

import json
import shutil
import socket
import sqlite3
import subprocess
import sys
from pathlib import Path

from ogacq.history.database import Json
from ogacq.history.entries import event_key
from ogacq.history.location import parse_location
from ogacq.history.recording import record_diagnosis
from ogacq.history.store import History
from ogacq.record.identity import session_record_id
from ogacq.session.store import load_session
from tests.history.test_e2e import campaign
from tests.writeback.conftest import ogacq_here

GOLDEN_SESSION = Path(__file__).resolve().parents[1] / "golden" / "session.jsonl"


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_an_unreachable_history_only_warns_and_the_session_is_whole(tmp_path, capsys,
                                                                     monkeypatch, caplog):
    url = f"postgresql://ogacq@127.0.0.1:{closed_port()}/site"
    path = campaign(tmp_path / "cal", 0)
    ran = ogacq_here(capsys, monkeypatch, "run", path, "--json", "--history", url)
    assert ran.returncode == 0, ran.stderr
    assert json.loads(ran.stdout)["parameters"]["joint_offset"]  # the result, as ever
    session_path = tmp_path / "cal" / "session.jsonl"
    assert load_session(session_path).finished and load_session(session_path).result
    # (the command line prints each warning as one line "ogacq: warning: ...")
    warnings = [r.getMessage() for r in caplog.records if r.name == "ogacq.history"]
    assert len(warnings) == 1 and caplog.records[-1].levelname == "WARNING"
    assert warnings[0].startswith("the campaign not recorded in the history: history "
                                  "postgresql+psycopg://ogacq@127.0.0.1:")
    assert "\n" not in warnings[0] and "Connection refused" in warnings[0]
    assert f"add it later with `ogacq history add {session_path} --history " \
           "postgresql+psycopg://ogacq@127.0.0.1:" in warnings[0]


def test_adding_to_a_database_of_another_application_is_refused_untouched(tmp_path, capsys,
                                                                          monkeypatch):
    other = tmp_path / "erp.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE orders (id INTEGER)")
    before = other.read_bytes()
    session = tmp_path / "s.jsonl"
    from ogacq.session.records import EndRecord
    from ogacq.session.store import SessionWriter

    machine = {"name": "OG-1", "leg_length_mm": 310.25, "rho_min_mm": -100.0,
               "rho_max_mm": 60.0, "gauge_resolution_mm": 0.001}
    with SessionWriter.create(session, {"machine": machine, "plan": None}) as writer:
        writer.write(EndRecord(status="complete"))  # a finished one: partial is refused
    ran = ogacq_here(capsys, monkeypatch, "history", "add", session, "--history", other)
    assert ran.returncode == 3
    assert ran.stderr.strip() == (f"ogacq: error: history {other}: is not an ogacq history: it "
                                  "holds other tables (orders); give an empty database or an "
                                  "ogacq history")
    assert other.read_bytes() == before


# `diagnose` of a session run as a user runs it, saying afterwards whether the record's
# uncertainty evaluation was imported (it is, whenever the record is built).
DIAGNOSE_PROBE = (
    "import sys\n"
    "from ogacq.cli.app import main\n"
    "code = main(sys.argv[1:])\n"
    "built = 'ogacq.record.evaluation' in sys.modules\n"
    "print('record built' if built else 'record not built', file=sys.stderr)\n"
    "sys.exit(code)\n")


def test_a_session_diagnosed_again_is_found_recorded_without_building_its_record(tmp_path):
    session, history = tmp_path / "session.jsonl", tmp_path / "history.sqlite"
    shutil.copy(GOLDEN_SESSION, session)

    def diagnose() -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-c", DIAGNOSE_PROBE, "diagnose", str(session),
                               "--history", str(history), "--json"],
                              capture_output=True, text=True, timeout=300, check=False)

    first, again = diagnose(), diagnose()
    assert first.returncode == 0 and again.returncode == 0, first.stderr + again.stderr
    assert "history: 1 calibration, 1 diagnosis recorded" in first.stderr
    assert "record built" in first.stderr.splitlines()
    assert "history: nothing new recorded" in again.stderr
    assert "record not built" in again.stderr.splitlines()
    assert json.loads(again.stdout) == json.loads(first.stdout)
    record_id = session_record_id(load_session(session))
    keys = [event_key("calibration", record_id), event_key("diagnosis", record_id)]
    with History.open(parse_location(str(history), "the test")) as opened:
        assert opened.present([*keys, event_key("diagnosis", "OGQ-none")]) == keys


def test_a_diagnosis_the_history_holds_already_does_not_open_it_to_write(tmp_path, capsys,
                                                                        monkeypatch):
    """Found by the history opened to read: not checked as one written to is (its every
    stored record read, ~0.1 s in a history of 600 events), since nothing is written."""
    session, history = tmp_path / "session.jsonl", tmp_path / "history.sqlite"
    shutil.copy(GOLDEN_SESSION, session)
    record_diagnosis(session, {"effects": []}, str(history))
    assert "history: 1 calibration, 1 diagnosis recorded" in capsys.readouterr().err

    def opened_to_write(_history: History) -> None:
        raise AssertionError("opened to write")

    monkeypatch.setattr(History, "_check_sqlite", opened_to_write)
    record_diagnosis(session, {"effects": []}, str(history))
    assert capsys.readouterr().err.splitlines() == \
        [f"history: nothing new recorded in {history}"]


def test_a_diagnosis_takes_the_record_the_history_holds_of_the_same_file(tmp_path):
    """The session's calibration recorded before (``history add``, as ``run`` records
    it): its first diagnosis stores that record beside its findings, not one built
    again; a record stored of another state of the file (its SHA-256) is built afresh."""
    session, history = tmp_path / "session.jsonl", tmp_path / "history.sqlite"
    shutil.copy(GOLDEN_SESSION, session)
    added = subprocess.run([sys.executable, "-m", "ogacq", "history", "add", str(session),
                            "--history", str(history)], capture_output=True, text=True,
                           timeout=300, check=False)
    assert added.returncode == 0, added.stderr

    def diagnose() -> subprocess.CompletedProcess[str]:
        done = subprocess.run([sys.executable, "-c", DIAGNOSE_PROBE, "diagnose", str(session),
                               "--history", str(history), "--json"],
                              capture_output=True, text=True, timeout=300, check=False)
        assert done.returncode == 0, done.stderr
        assert "history: 1 diagnosis recorded" in done.stderr
        return done

    assert "record not built" in diagnose().stderr.splitlines()
    record_id = session_record_id(load_session(session))
    location = parse_location(str(history), "the test")
    with History.open(location) as opened:
        stored = opened.calibration_record(record_id)
        machine = opened.find_machine("machine (no serial)")
        assert stored is not None and opened.records(machine, record_id) == stored
        # the record of another state of the file: its diagnosis builds its own
        opened.db.execute("DELETE FROM ogacq_events WHERE kind = 'diagnosis'")
        opened.db.execute("UPDATE ogacq_events SET record = :record WHERE kind = "
                          "'calibration'", {"record": Json({**stored, "session": {
                              **stored["session"], "sha256": "0" * 64}})})
    assert "record built" in diagnose().stderr.splitlines()


def test_a_machine_without_a_serial_is_told_its_identity_the_first_time(tmp_path):
    """Issue 38.1: a machine file without a serial is filed by its name. The first
    campaign the history meets of it says so, and how a serial tells it from another of
    that name; later campaigns file under the same label, unsaid. The user's machine
    file is not rewritten."""
    from ogacq.history.recording import record_campaign
    from tests.writeback.conftest import synthetic_session

    machine = {"leg_length_mm": 310.25, "rho_min_mm": -100.0, "rho_max_mm": 60.0,
               "gauge_resolution_mm": 0.001, "name": "OG-1 cell 3"}
    (tmp_path / "campaign.toml").write_text("")
    history = tmp_path / "history.sqlite"
    said: list[list[str]] = []
    for n, header in enumerate(({"machine": machine, "machine_file": "cell3.toml"},
                                {"machine": machine},
                                {"machine": {**machine, "serial": "OG-2026-0017"}})):
        path = synthetic_session(tmp_path / f"s{n}.jsonl", tmp_path / "campaign.toml",
                                 offsets_mm={"x": 0.1, "y": 0.0, "z": 0.0}, seed=n,
                                 header_extra=header)
        said.append([])
        record_campaign(path, str(history), say=said[-1].append)
    first, again, with_serial = said
    assert first[-1] == ("history: 'OG-1 cell 3' has no serial: filed as 'OG-1 cell 3 (no "
                         "serial)', its identity in this history from now on; `serial = "
                         "\"...\"` in cell3.toml tells it from another machine of that name "
                         "(filed then as a new machine)")
    assert len(again) == 1 and len(with_serial) == 1  # met before; a serial of its own
    with History.open(parse_location(str(history), "--history")) as db:
        assert [m.label for m in db.machines()] == ["OG-1 cell 3 (no serial)",
                                                    "OG-1 cell 3 (serial OG-2026-0017)"]


def test_a_session_diagnosed_twice_into_postgresql(tmp_path, postgres_url):
    """The same SQL on PostgreSQL: recorded once (calibration and diagnosis), found the
    second time with the history opened to read."""
    session = tmp_path / "session.jsonl"
    shutil.copy(GOLDEN_SESSION, session)
    said = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", DIAGNOSE_PROBE, "diagnose", str(session),
                               "--history", postgres_url, "--json"],
                              capture_output=True, text=True, timeout=300, check=False)
        assert done.returncode == 0, done.stderr
        said.append(done.stderr.splitlines())
    assert said[0][0].startswith("history: 1 calibration, 1 diagnosis recorded in postgresql")
    assert said[1][0].startswith("history: nothing new recorded in postgresql")
    assert said[1][-1] == "record not built"
