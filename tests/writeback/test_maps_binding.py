"""The maps file against the history's last maps state of its machine: deleted, a
link to nothing, emptied, or another calibration's file copied in, each ran silently
(uncompensated, or with maps never validated here); refused with both checksums."""

from __future__ import annotations

import pytest

from ogacq.campaign.campaign_file import read_campaign
from ogacq.errors import InputError
from ogacq.history.entries import MapsWriteBack
from ogacq.history.location import parse_location
from ogacq.history.store import History
from ogacq.writeback.maps_binding import check_maps_in_force
from ogacq.writeback.maps_table import maps_checksum, read_maps_table, write_maps_table
from tests.compensation.maps import screw_map
from tests.writeback.conftest import ogacq_here, sim_campaign, simulator

RECORD = {"format": "ogacq-record/1", "id": "OGQ-20260110-00000001",
          "machine": {"name": "Ortho", "serial": "7"}, "date": "2026-01-10T09:00:00"}
OWNER = ("Ortho", "7")


def test_a_maps_file_not_what_the_history_says_is_refused(tmp_path):
    path = tmp_path / "maps.json"
    ours = write_maps_table(path, {"x": screw_map("x")}, owner=OWNER)
    location = parse_location(str(tmp_path / "h.sqlite"), "--history")
    with History.open(location) as db:
        db.record_maps_writeback(RECORD, MapsWriteBack(
            "maps-write-1", "write", "done", str(path), (), maps_checksum({}),
            (screw_map("x").to_json(),), ours.checksum, 1000.0))
    check_maps_in_force(read_maps_table(path, owner=OWNER), *OWNER, location)  # the same

    other = tmp_path / "other.json"  # another calibration's maps, copied in
    write_maps_table(other, {"x": screw_map("x", lost_mm=0.0)}, owner=OWNER)
    path.write_bytes(other.read_bytes())
    with pytest.raises(InputError, match=rf"holds maps {read_maps_table(path).checksum[:12]}"
                                         rf".*left {ours.checksum[:12]}"):
        check_maps_in_force(read_maps_table(path, owner=OWNER), *OWNER, location)
    write_maps_table(path, {}, owner=OWNER)  # emptied
    with pytest.raises(InputError, match="holds no maps"):
        check_maps_in_force(read_maps_table(path, owner=OWNER), *OWNER, location)
    path.unlink()  # deleted
    with pytest.raises(InputError, match=rf"holds no file \(checksum "
                                         rf"{maps_checksum({})[:12]}\).*maps-write-1"):
        check_maps_in_force(read_maps_table(path, owner=OWNER), *OWNER, location)
    # another machine's history, or another file of this one: nothing to compare with
    check_maps_in_force(read_maps_table(path), "Other", "8", location)
    check_maps_in_force(read_maps_table(tmp_path / "elsewhere.json"), *OWNER, location)
    check_maps_in_force(read_maps_table(path), *OWNER, None)


def test_a_run_with_its_maps_file_gone_is_refused_before_anything_moves(
        tmp_path, capsys, monkeypatch):
    """``ogacq run`` of a campaign whose maps file the history says holds a map: the
    file deleted, the campaign ran uncompensated with exit 0."""
    with simulator(tmp_path, "cia402", 3) as info:
        campaign = sim_campaign(tmp_path, info, name="c", maps_file="maps.json")
        location = parse_location(str(tmp_path / "h.sqlite"), "--history")
        name = read_campaign(campaign).machine.name
        with History.open(location) as db:
            db.record_maps_writeback({**RECORD, "machine": {"name": name, "serial": ""}},
                                     MapsWriteBack("maps-write-1", "write", "done",
                                                   str(tmp_path / "maps.json"), (),
                                                   maps_checksum({}),
                                                   (screw_map("x").to_json(),), "abcd",
                                                   1000.0))
        ran = ogacq_here(capsys, monkeypatch, "run", campaign, "--history",
                         tmp_path / "h.sqlite")
        assert ran.returncode == 2, ran.stderr
        assert "holds no file" in ran.stderr and "maps-write-1" in ran.stderr
        assert not (tmp_path / "c.jsonl").exists()  # nothing ran
