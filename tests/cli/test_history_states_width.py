"""``ogacq history MACHINE --states`` on an 80-column terminal: every state's offsets
and status are printed (rich squeezed the table's x, y, z and status columns to
nothing there)."""

from __future__ import annotations

import pytest

from ogacq.cli.app import main
from ogacq.history.entries import MapsWriteBack, WriteBack
from ogacq.history.location import parse_location
from ogacq.history.store import History
from tests.compensation.maps import screw_map

RECORD = {"format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
          "machine": {"name": "OG-1 cell 3", "serial": "OG-2026-0017"},
          "date": "2026-01-10T09:00:00"}


@pytest.mark.parametrize("columns", ["80", "200"])
def test_every_state_is_shown_whole_at_any_width(tmp_path, capsys, monkeypatch, columns):
    monkeypatch.setenv("COLUMNS", columns)
    path = tmp_path / "history.sqlite"
    with History.open(parse_location(str(path), "--history")) as db:
        db.record_writeback(RECORD, WriteBack(
            "write-1", "write", "done", {"x": 0.0, "y": 0.0, "z": 0.0},
            {"x": -0.0312, "y": -1.3547, "z": 1.0718}, "cia402", 1000.0))
        db.record_maps_writeback(RECORD, MapsWriteBack(
            "maps-write-1", "write", "done", "maps.json", (), "e3b0",
            (screw_map("x").to_json(),), "abcdef123456", 1001.0))
    assert main(["history", "OG-1 cell 3", "--history", str(path), "--states"]) == 0
    out = capsys.readouterr().out
    assert max(len(line) for line in out.splitlines()) <= int(columns)
    words = " ".join(out.split())  # a block's line may wrap where the terminal ends
    for value in ("-0.0312", "-1.3547", "+1.0718", "+0.0000", "in force",
                  "write write-1", "OGQ-20260110-00000001", "abcdef123456",
                  "maps-write-1"):
        assert value in words, (value, out)
