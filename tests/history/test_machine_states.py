"""The machine's states: offsets and maps together, what calibrate made of each write,
any two compared; a history of schema 1 read as it is and migrated when recorded to."""

from __future__ import annotations

import json

import pytest

from ogacq.cli.app import main
from ogacq.history import schema as s
from ogacq.history.database import postgresql_database, sqlite_database
from ogacq.history.entries import MapsWriteBack, WriteBack
from ogacq.history.location import parse_location
from ogacq.history.states import diff, find, timeline
from ogacq.history.store import History
from tests.compensation.maps import screw_map

RECORD = {"format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
          "machine": {"name": "Ortho", "serial": "7"}, "date": "2026-01-10T09:00:00"}


def schema_1(location) -> None:
    """A history as ogacq wrote it before the maps states (schema 1)."""
    db = sqlite_database(location.path) if location.path is not None \
        else postgresql_database(location.url)
    with db.transaction(write=True):
        for statement in s.ddl(db.backend, tuple(t for t in s.TABLES if t is not s.map_states)):
            db.execute(statement)
        db.insert(s.schema_info.name, [{"key": "application", "value": s.APPLICATION},
                                       {"key": "version", "value": "1"}])
    db.close()


def record_a_procedure(db: History, *, outcome: str) -> None:
    db.record_writeback(RECORD, WriteBack("write-1", "write", "done", {"x": 0.0, "y": 0.0,
                                                                     "z": 0.0},
                                          {"x": -0.03, "y": -1.35, "z": 1.07}, "cia402",
                                          1000.0))
    old, new = (), (screw_map("x").to_json(),)
    db.record_maps_writeback(RECORD, MapsWriteBack("maps-write-1", "write", "done", "maps.json",
                                                   old, "e3b0", new, "abcd", 1001.0))
    details = {"procedure": "C-1", "outcome": outcome, "reason": "the fit got worse",
               "writes": {"offsets": "write-1", "maps": "maps-write-1"},
               "restores": {"maps": "maps-restore-1"} if outcome == "restored" else {}}
    if outcome == "restored":
        db.record_maps_writeback(RECORD, MapsWriteBack("maps-restore-1", "restore", "done",
                                                       "maps.json", new, "abcd", old, "e3b0",
                                                       1002.0, "maps-write-1"))
    db.record_calibrate(RECORD, "C-1", details)


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_schema_1_read_as_it_is_then_migrated(tmp_path, request, backend):
    where = str(tmp_path / "h.sqlite") if backend == "sqlite" \
        else request.getfixturevalue("postgres_url")
    location = parse_location(where, "--history")
    schema_1(location)
    with History.open(location, create=False) as db:  # reading does not change it
        assert db.version == 1 and db.machines() == []
    with History.open(location) as db:  # recording brings it to schema 2
        record_a_procedure(db, outcome="validated")
        machine = db.find_machine("Ortho")
        assert [v.stage for v in db.map_states(machine)] == ["before", "after"]
    with History.open(location, create=False) as db:
        assert db.version == s.SCHEMA_VERSION == 2


def test_the_states_say_what_calibrate_made_of_each_write_and_compare(tmp_path):
    location = parse_location(str(tmp_path / "h.sqlite"), "--history")
    with History.open(location) as db:
        record_a_procedure(db, outcome="restored")
        machine = db.find_machine("Ortho")
        states = timeline(db.states(machine), db.map_states(machine),
                          db.calibrate_events(machine))
    kinds = [(v.kind, v.stage, v.action) for v in states]
    assert kinds == [("offsets", "before", "write"), ("offsets", "after", "write"),
                     ("maps", "before", "write"), ("maps", "after", "write"),
                     ("maps", "before", "restore"), ("maps", "after", "restore")]
    written, restored = states[3], states[5]
    assert written.fate == "restored by calibrate C-1: the fit got worse"
    assert restored.fate == "restore by calibrate C-1: the fit got worse"
    assert states[1].offsets_mm == {"x": -0.03, "y": -1.35, "z": 1.07}
    assert written.offsets_mm == states[1].offsets_mm  # the offsets held meanwhile
    # from before anything to the maps written: offsets and the x map changed
    d = diff(states[0], written)
    assert d["offsets_mm"]["y"]["change"] == pytest.approx(-1.35)
    assert d["maps"]["x"]["change"] == "added"
    assert d["maps"]["x"]["max_reverse_change_mm"] == pytest.approx(
        max(abs(v) for v in screw_map("x").reverse_mm), abs=1e-6)
    assert diff(written, restored)["maps"]["x"]["change"] == "removed"
    assert diff(states[0], states[0])["maps"]["x"]["change"] == "none"
    assert find(states, restored.state_id) is restored


def test_history_states_on_the_command_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    path = tmp_path / "h.sqlite"
    with History.open(parse_location(str(path), "--history")) as db:
        record_a_procedure(db, outcome="restored")
    assert main(["history", "Ortho", "--history", str(path), "--states"]) == 0
    out = capsys.readouterr().out
    assert "maps states" in out and "restored by calibrate C-1" in out
    assert main(["history", "Ortho", "--history", str(path), "--states", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    ids = [v["state"] for v in listed["machine_states"]]
    assert listed["states"] and len(ids) == 6  # the offsets states as before, and all
    assert main(["history", "Ortho", "--history", str(path), "--states", "--diff", ids[0],
                 ids[3]]) == 0
    out = capsys.readouterr().out
    assert "added" in out and "-1.3500" in out
    assert main(["history", "Ortho", "--history", str(path), "--diff", ids[0], ids[3]]) == 2
    assert main(["history", "Ortho", "--history", str(path), "--states", "--diff", "S-nope",
                 ids[3]]) == 2


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_a_write_recorded_failed_then_found_done_is_in_force(tmp_path, request, backend):
    """A Ctrl-C between the write and its audit's 'done' records it failed; the resumed
    procedure reads it back in force and records it done: the history's current state
    is then that write's (it kept the first status and named the state before)."""
    where = str(tmp_path / "h.sqlite") if backend == "sqlite" \
        else request.getfixturevalue("postgres_url")
    old, new = {"x": 0.0, "y": 0.0, "z": 0.0}, {"x": -0.03, "y": -1.35, "z": 1.07}
    old_maps, new_maps = (), (screw_map("x").to_json(),)
    with History.open(parse_location(where, "--history")) as db:
        db.record_writeback(RECORD, WriteBack("write-1", "write", "failed", old, new,
                                              "cia402", 1000.0))
        db.record_maps_writeback(RECORD, MapsWriteBack("maps-write-1", "write", "failed",
                                                       "maps.json", old_maps, "e3b0",
                                                       new_maps, "abcd", 1001.0))
        machine = db.machines()[0]
        assert db.current_state(machine) is None
        db.record_writeback(RECORD, WriteBack("write-1", "write", "done", old, new,
                                              "cia402", 1000.0))
        db.record_maps_writeback(RECORD, MapsWriteBack("maps-write-1", "write", "done",
                                                       "maps.json", old_maps, "e3b0",
                                                       new_maps, "abcd", 1001.0))
        held = db.current_state(machine)
        assert held is not None and held.operation == "write-1" and held.offsets_mm == new
        maps_after = [m for m in db.map_states(machine) if m.stage == "after"]
        assert [m.status for m in maps_after] == ["done"]
        # a later word of failure does not undo what was read back in force
        db.record_writeback(RECORD, WriteBack("write-1", "write", "failed", old, new,
                                              "cia402", 1000.0))
        assert db.current_state(machine) == held
