"""``ogacq history MACHINE``: the table, the JSON, the plot and the states of a
history holding records shaped as the contract says."""

from __future__ import annotations

import json

import pytest

from ogacq.cli.app import main
from ogacq.history.entries import WriteBack
from ogacq.history.location import parse_location
from ogacq.history.store import History
from tests.history.records import contract_record


@pytest.fixture
def history_file(tmp_path):
    path = tmp_path / "history.sqlite"
    records = [contract_record(date="2026-01-10T09:00:00", ambient_c=20.4),
               # the write-back of the first's offsets, then its validation: about zero
               contract_record(date="2026-02-01T14:00:00", ambient_c=18.0,
                               offsets={"x": 0.004, "y": 0.0, "z": 0.0}),
               contract_record(date="2026-03-02T08:30:00", ambient_c=23.1, decision="fail",
                               offsets={"x": 0.05, "y": 0.001, "z": 0.0})]
    with History.open(parse_location(str(path), "--history")) as history:
        for record in records:
            history.record_calibration(record)
        history.record_writeback(records[0], WriteBack(
            "write-0001", "write", "done", dict.fromkeys("xyz", 0.0),
            {"x": -0.42, "y": 0.31, "z": -0.12}, "cia402", 1_768_100_000.0))
    return path, records


def run(capsys, *args) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_table_lists_the_calibrations_and_flags_the_drift(history_file, capsys,
                                                               monkeypatch):
    path, records = history_file
    monkeypatch.setenv("COLUMNS", "80")  # a plain terminal: wrapped, nothing cut off
    code, narrow, _ = run(capsys, "history", "OG-1 cell 3", "--history", path)
    assert code == 0 and "…" not in narrow
    assert max(len(line) for line in narrow.splitlines()) <= 80
    # every calibration whole: its record, its verdict, its acceptance, its ambient
    for record, ambient in zip(records, ("20.4 °C", "18.0 °C", "23.1 °C"), strict=True):
        assert record["id"] in narrow and ambient in narrow
    assert narrow.count("within noise") == 3 and "fail" in narrow
    assert narrow.count(" ! ") + narrow.count(" !\n") >= 1  # the drift's mark, not cut off
    monkeypatch.setenv("COLUMNS", "250")
    code, out, _ = run(capsys, "history", "OG-1 cell 3", "--history", path)
    assert code == 0
    lines = out.splitlines()
    rows = [line for line in lines if line.strip().startswith("2026-")]
    assert len(rows) == 6  # who and how, then the values: one row each per calibration
    who, values = rows[:3], rows[3:]
    assert records[2]["id"] in who[2] and "+0.0500 ± 0.0060 !" in values[2]
    assert "23.1 °C" in who[2] and "fail" in who[2] and "J. Martin" in who[2]
    # judged from the state as left by the write-back (0.42 - 0.42), not as found: 4 um
    # is within the 8.5 um of the change, and the second campaign validates the write
    assert "!" not in values[1]
    assert f"{records[1]['id']} validates the write-back made from {records[0]['id']}" in out
    assert any(line.strip().startswith("written back") and "-0.4200" in line
               for line in lines)
    assert any(line.startswith(f"! drift: joint_offset.x +0.0460 mm from {records[1]['id']}")
               for line in lines)
    assert "1 write-back" in out
    # the same by the serial; a history.sqlite in the current folder is not the
    # account's (the data folder's is): none is read
    code, again, _ = run(capsys, "history", "OG-2026-0017", "--history", path)
    assert code == 0 and again == out
    monkeypatch.chdir(path.parent)
    assert path.name == "history.sqlite"
    code, _, err = run(capsys, "history", "OG-2026-0017")
    assert code == 2 and "no history yet in" in err, err


def test_json_plot_and_states(history_file, capsys, tmp_path):
    path, records = history_file
    plot = tmp_path / "history.png"
    code, out, _ = run(capsys, "history", "show", "OG-1 cell 3", "--history", path, "--json",
                       "--plot", plot)
    assert code == 0
    data = json.loads(out)
    assert [c["record"] for c in data["calibrations"]] == [r["id"] for r in records]
    assert data["calibrations"][0]["parameters"]["joint_offset.x"] == {
        "value_mm": 0.42, "u_mm": 0.003, "U_mm": 0.006, "k": 2.0, "std_mm": 0.0028}
    assert data["calibrations"][2]["acceptance"] == {"as_found": "fail",
                                                     "as_left": "not evaluated"}
    assert [(d["parameter"], d["to"]) for d in data["drifts"]] == [
        ("joint_offset.x", records[2]["id"])]
    assert data["calibrations"][2]["changes"]["joint_offset.x"]["flagged"] is True
    assert plot.read_bytes()[:4] == b"\x89PNG"
    code, out, _ = run(capsys, "history", "OG-1 cell 3", "--history", path, "--states",
                       "--json")
    states = json.loads(out)
    assert [s["stage"] for s in states["states"]] == ["before", "after"]
    assert states["in_force"] == states["states"][1]["state"]
    assert states["states"][1]["offsets_mm"] == {"x": -0.42, "y": 0.31, "z": -0.12}


def test_an_unknown_machine_and_an_unreachable_history_are_one_line(history_file, capsys):
    path, _ = history_file
    code, _, err = run(capsys, "history", "OG-9", "--history", path)
    assert code == 2 and err.count("\n") == 1 and "machines: OG-1 cell 3 (serial" in err
    code, _, err = run(capsys, "history", "OG-1", "--history",
                       "postgresql://ogacq@127.0.0.1:1/none")
    assert code == 3 and err.count("\n") == 1 and err.startswith("ogacq: error: history ")


def test_a_controller_reset_is_named_not_flagged_as_a_drift(tmp_path, capsys, monkeypatch):
    """A's offsets written (0 -> -0.42 on x), B validates them; the drive is then reset
    to 0 and C finds A's 0.42 again: by the offsets each campaign ran with, the machine
    did not move, and the history says the controller changed outside ogacq."""
    def with_force(record: dict, x: float) -> dict:
        record["method"] |= {"offsets_in_force_mm": {"x": x, "y": 0.0, "z": 0.0},
                             "offsets_in_force_consistent": True}
        return record

    path = tmp_path / "history.sqlite"
    records = [with_force(contract_record(date="2026-01-10T09:00:00"), 0.0),
               with_force(contract_record(date="2026-02-01T14:00:00",
                                          offsets={"x": 0.004, "y": -0.31, "z": 0.12}), -0.42),
               with_force(contract_record(date="2026-03-02T08:30:00",
                                          offsets={"x": 0.424, "y": -0.31, "z": 0.12}), 0.0)]
    with History.open(parse_location(str(path), "--history")) as history:
        for record in records:
            history.record_calibration(record)
        history.record_writeback(records[0], WriteBack(
            "write-0001", "write", "done", dict.fromkeys("xyz", 0.0),
            {"x": -0.42, "y": 0.0, "z": 0.0}, "cia402", 1_768_100_000.0))
    monkeypatch.setenv("COLUMNS", "250")
    code, out, _ = run(capsys, "history", "OG-1 cell 3", "--history", path)
    assert code == 0 and "! drift" not in out
    assert (f"changed outside ogacq between {records[1]['id']} and {records[2]['id']} "
            "(x +0.4200 mm beyond the recorded write-backs)") in out
    assert "judged from the offsets the controller held during the campaigns" in out
    code, out, _ = run(capsys, "history", "OG-1 cell 3", "--history", path, "--json")
    data = json.loads(out)
    assert data["drifts"] == []
    assert [(c["from"], c["to"]) for c in data["controller_changes"]] == [
        (records[1]["id"], records[2]["id"])]
    assert data["controller_changes"][0]["unexplained_mm"] == {"joint_offset.x": 0.42}
