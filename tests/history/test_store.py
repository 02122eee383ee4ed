"""The history store on a real SQLite file and a real PostgreSQL server: one schema,
the same answers; recording is idempotent and safe for stations writing at once;
a database that is not an ogacq history, or cannot be reached, is one clear error."""

from __future__ import annotations

import contextlib
import sqlite3
import threading
from pathlib import Path

import pytest

from ogacq.errors import InputError, StorageError
from ogacq.history.entries import MapsWriteBack, WriteBack
from ogacq.history.location import parse_location
from ogacq.history.store import History
from tests.history.records import contract_record


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path):
    if request.param == "sqlite":
        return parse_location(str(tmp_path / "history.sqlite"), "--history")
    return parse_location(request.getfixturevalue("postgres_url"), "--history")


def three_calibrations() -> list[dict]:
    return [contract_record(date="2026-03-02T08:30:00", offsets={"x": 0.47, "y": -0.3, "z": 0.1},
                            ambient_c=23.1, session="/runs/c/session.jsonl"),
            contract_record(date="2026-01-10T09:00:00", ambient_c=20.4),
            contract_record(date="2026-02-01T14:00:00", ambient_c=18.0, U=None, u=0.004,
                            decision="undecided", session="/runs/b/session.jsonl")]


def test_calibrations_come_back_by_date_with_their_parameters_and_record(location):
    records = three_calibrations()
    with History.open(location) as history:
        for record in records:
            assert history.record_calibration(record).new == [f"calibration:{record['id']}"]
        machine = history.find_machine("OG-1 cell 3")
        assert history.find_machine("OG-2026-0017") == machine  # by serial too
        found = history.calibrations(machine)
    assert [c.date for c in found] == ["2026-01-10T09:00:00", "2026-02-01T14:00:00",
                                       "2026-03-02T08:30:00"]
    assert [c.ambient_c for c in found] == [20.4, 18.0, 23.1]
    assert [c.acceptance_decision for c in found] == ["pass", "undecided", "pass"]
    first = found[0]
    assert list(first.parameters) == ["joint_offset.x", "joint_offset.y", "joint_offset.z"]
    x = first.parameters["joint_offset.x"]
    assert (x.value_mm, x.u_mm, x.expanded_mm, x.k) == (0.42, 0.003, 0.006, 2.0)
    assert found[1].parameters["joint_offset.x"].expanded_mm is None  # no budget: no U
    assert found[1].parameters["joint_offset.x"].std_mm == 0.0028  # but the fit's std
    assert first.operator == "J. Martin" and first.verdict["consistent"] is True
    assert first.instruments[0]["certificate"] == "DKD-K-12345 2026-0412"
    assert first.session_path == "/runs/a/session.jsonl"
    # the record is kept whole
    with History.open(location) as history:
        assert history.records(machine, records[1]["id"]) == records[1]
        # and the earlier results are what the record's history section takes
        entries = history.results_history(machine)
    assert [e["id"] for e in entries] == [c.record_id for c in found]
    assert entries[0]["results"] == records[1]["results"]


def test_the_same_record_twice_is_one_row(location):
    record = contract_record()
    with History.open(location) as history:
        assert history.record_calibration(record).new
        again = history.record_calibration(record)
        assert again.new == [] and again.present == [f"calibration:{record['id']}"]
        assert len(history.calibrations(history.find_machine("OG-1 cell 3"))) == 1


def test_stations_recording_at_once_leave_each_record_once(location):
    """Four stations (each its own connection) send the same two records and one of
    their own at the same moment: every record is there once, nothing fails."""
    shared = [contract_record(date="2026-01-10T09:00:00"),
              contract_record(date="2026-01-11T09:00:00")]
    own = [contract_record(date=f"2026-02-0{i + 1}T09:00:00") for i in range(4)]
    History.open(location).close()  # the schema exists; the race is on the rows
    start = threading.Barrier(4)
    errors: list[BaseException] = []

    def station(i: int) -> None:
        try:
            with History.open(location) as history:
                start.wait()
                for record in (*shared, own[i]):
                    history.record_calibration(record)
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=station, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    with History.open(location) as history:
        ids = [c.record_id for c in history.calibrations(history.find_machine("OG-1 cell 3"))]
    assert sorted(ids) == sorted(r["id"] for r in (*shared, *own))


def test_write_backs_give_states_to_go_back_to(location):
    first, second = contract_record(date="2026-01-10T09:00:00"), \
        contract_record(date="2026-02-10T09:00:00")
    zero = dict.fromkeys("xyz", 0.0)
    w1 = WriteBack("write-aaaa0001", "write", "done", zero,
                   {"x": -0.42, "y": 0.31, "z": -0.12}, "cia402", 1_768_100_000.0)
    w2 = WriteBack("write-aaaa0002", "write", "done", w1.new_mm,
                   {"x": -0.47, "y": 0.3, "z": -0.1}, "cia402", 1_770_800_000.0)
    with History.open(location) as history:
        for record in (first, second):
            history.record_calibration(record)
        history.record_writeback(first, w1)
        history.record_writeback(second, w2)
        assert history.record_writeback(second, w2).present  # idempotent too
        machine = history.find_machine("OG-1 cell 3")
        states = history.states(machine)
        assert [(v.stage, v.operation) for v in states] == [
            ("before", "write-aaaa0001"), ("after", "write-aaaa0001"),
            ("before", "write-aaaa0002"), ("after", "write-aaaa0002")]
        assert history.current_state(machine).offsets_mm == w2.new_mm
        # by a state's id, or by the calibration whose write-back it was
        assert history.find_state(machine, states[0].state_id).offsets_mm == zero
        assert history.find_state(machine, first["id"]).offsets_mm == w1.new_mm
        kinds = [e.kind for e in history.events(machine)]
        assert kinds == ["calibration", "write-back", "calibration", "write-back"]
        never = contract_record(date="2026-03-10T09:00:00")
        history.record_calibration(never)
        with pytest.raises(InputError, match="never written to a controller"):
            history.find_state(machine, never["id"])
        with pytest.raises(InputError, match="--states"):
            history.find_state(machine, "S-nope")


def test_unknown_machine_names_those_there_are(location):
    with History.open(location) as history:
        history.record_calibration(contract_record())
        with pytest.raises(InputError, match=r"no such machine .*OG-1 cell 3 \(serial"):
            history.find_machine("OG-9")


def test_a_database_that_is_not_an_ogacq_history_is_refused(tmp_path):
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE invoices (id INTEGER)")
    with pytest.raises(StorageError, match=r"is not an ogacq history: it holds other tables "
                                           r"\(invoices\)") as caught:
        History.open(parse_location(str(other), "--history"))
    assert caught.value.exit_code == 3
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database, not at all" * 50)
    with pytest.raises(StorageError, match="file is not a database"):
        History.open(parse_location(str(junk), "--history"))
    assert junk.read_bytes().startswith(b"this is not")  # left as it was


def test_a_newer_schema_is_refused_and_the_version_row_is_there(tmp_path):
    path = tmp_path / "h.sqlite"
    History.open(parse_location(str(path), "--history")).close()
    with contextlib.closing(sqlite3.connect(path)) as conn, conn:
        assert conn.execute("SELECT value FROM ogacq_schema WHERE key = 'version'"
                            ).fetchone() == ("2",)
        conn.execute("UPDATE ogacq_schema SET value = '7' WHERE key = 'version'")
    with pytest.raises(StorageError, match=r"newer ogacq \(schema 7; this one reads up to 2\)"):
        History.open(parse_location(str(path), "--history"))


def test_a_server_that_does_not_answer_is_one_line(tmp_path):
    import socket

    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    location = parse_location(f"postgresql://ogacq@127.0.0.1:{port}/h", "--history")
    with pytest.raises(StorageError) as caught:
        History.open(location)
    message = str(caught.value)
    assert message.startswith(f"history postgresql+psycopg://ogacq@127.0.0.1:{port}/h: "
                              "cannot open (")
    assert "\n" not in message and "refused" in message


def test_reading_a_missing_file_does_not_create_it(tmp_path):
    path = tmp_path / "none.sqlite"
    with pytest.raises(StorageError, match="no history here"):
        History.open(parse_location(str(path), "--history"), create=False)
    assert not path.exists()
    with pytest.raises(StorageError, match="there is no folder"):
        History.open(parse_location(str(tmp_path / "no" / "h.sqlite"), "--history"))


@pytest.mark.parametrize(("value", "words"), [
    ("mysql://u@h/db", "'mysql' is not supported"),
    ("sqlite://", "needs a file"),
    ("", "is empty")])
def test_bad_locations_are_input_errors(value, words):
    with pytest.raises(InputError, match=words):
        parse_location(value, "--history")


def test_a_path_is_an_sqlite_file_and_postgres_gets_psycopg(tmp_path):
    assert parse_location("h.sqlite", "--history").path == Path("h.sqlite").absolute()
    pg = parse_location("postgresql://u:secret@db.site/ogacq", "--history")
    assert pg.url.drivername == "postgresql+psycopg"
    assert "secret" not in pg.describe()


def test_a_url_s_options_reach_libpq(tmp_path):
    """``?host=/socket/folder`` (a server on a Unix socket) is the host libpq tries, as
    SQLAlchemy's psycopg dialect passed the URL's options."""
    folder = tmp_path / "no-server-here"
    location = parse_location(f"postgresql://ogacq@/h?host={folder}", "--history")
    with pytest.raises(StorageError) as caught:
        History.open(location)
    assert "cannot open (" in str(caught.value) and str(folder) in str(caught.value)


EARLIER = Path(__file__).with_name("earlier_history.sql")


def test_a_history_an_earlier_ogacq_wrote_is_read_and_recorded_into(tmp_path):
    """A history as ogacq wrote it through SQLAlchemy Core (``earlier_history.sql``, the
    SQLite dump of one: a calibration, an offsets write-back, an interrupted maps write)
    reads as it did and takes new records: the tables are the same, the JSON the
    same text (``null`` for None)."""
    path = tmp_path / "h.sqlite"
    with sqlite3.connect(path) as conn:
        conn.executescript(EARLIER.read_text())
    with History.open(parse_location(str(path), "--history")) as db:
        machine = db.find_machine("machine (no serial)")
        [calibration] = db.calibrations(machine)
        assert calibration.parameters["joint_offset.x"].value_mm == -1.242616
        assert calibration.verdict["state"] == "consistent"
        assert [(v.stage, v.offsets_mm["x"]) for v in db.states(machine)] == \
            [("before", 0.0), ("after", -1.2426)]
        assert [(v.stage, v.status, len(v.maps)) for v in db.map_states(machine)] == \
            [("before", "interrupted", 0), ("after", "interrupted", 1)]
        assert [(v.kind, v.details and v.details["action"]) for v in db.events(machine)] == \
            [("calibration", None), ("write-back", "write"), ("map-write", "write")]
        record = db.records(machine, calibration.record_id)
        assert record is not None and db.calibration_record(calibration.record_id) == record
        assert db.record_diagnosis(record, {"effects": []}).new == \
            [f"diagnosis:{calibration.record_id}"]
        maps = MapsWriteBack("maps-write-1", "write", "done", "maps.json", (), "e3b0",
                             ({"format": "ogacq-axis-map/1", "axis": "x"},), "abcd",
                             1768039300.0)
        assert db.record_maps_writeback(record, maps).present  # found done: said so
        assert {v.status for v in db.map_states(machine)} == {"done"}
