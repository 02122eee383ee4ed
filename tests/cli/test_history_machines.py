"""``ogacq history`` with no machine lists the machines the history holds (it printed
the group's help and exited 2): the technician who forgot a machine's exact name."""

from __future__ import annotations

import json
from pathlib import Path

from ogacq.cli.app import main
from ogacq.history.entries import WriteBack
from ogacq.history.location import parse_location
from ogacq.history.store import History

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "session.jsonl"
RECORD = {"format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
          "machine": {"name": "OG-1 cell 3", "serial": "OG-2026-0017"},
          "date": "2026-01-10T09:00:00"}


def test_the_machines_are_listed_with_their_calibrations(tmp_path, capsys):
    path = tmp_path / "history.sqlite"
    with History.open(parse_location(str(path), "--history")) as db:
        db.record_writeback(RECORD, WriteBack(
            "write-1", "write", "done", {"x": 0.0, "y": 0.0, "z": 0.0},
            {"x": -0.03, "y": -1.35, "z": 1.07}, "cia402", 1000.0))
    assert main(["history", "add", str(GOLDEN), "--history", str(path)]) == 0
    # its machine has no serial: filed by its name, said the first time (issue 38.1)
    assert "has no serial: filed as" in " ".join(capsys.readouterr().out.split())
    assert main(["history", "--history", str(path), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    by_name = {m["name"]: m for m in listed["machines"]}
    assert by_name["OG-1 cell 3"] == {"name": "OG-1 cell 3", "serial": "OG-2026-0017",
                                      "calibrations": 0, "last": None}
    [golden] = [m for name, m in by_name.items() if name != "OG-1 cell 3"]
    assert golden["calibrations"] == 1 and golden["last"]
    assert main(["history", "--history", str(path)]) == 0
    out = capsys.readouterr().out
    # wrapped between words at 80 columns (it was cut mid-word by the terminal)
    assert [line for line in out.splitlines() if len(line) > 80] == [], out
    text = " ".join(out.split())
    # a path longer than the line is folded where it must be: read without the breaks
    assert f"machinesinhistory{path}" in "".join(out.split())
    assert "OG-1 cell 3 (serial OG-2026-0017): 0 calibrations" in text
    assert f"{golden['name']}" in text and "1 calibration, the last " in text
    # the last date as the machine's table writes it, not in ISO's T form
    assert f"the last {golden['last'][:10]} " in text
    # the golden session's machine has no serial: its label says so, and what gives one
    assert f"{golden['name']} (no serial): 1 calibration" in text
    assert "a machine with no serial is filed by its name alone" in text
    assert main(["history", "--history", str(path), "--states"]) == 2
    assert "is about one machine" in capsys.readouterr().err
