"""Maps written like offsets: planned, audited (intent fsynced before the file is
touched), read back by checksum, restorable; a file edited by hand is refused; a
campaign resumed with other maps than it started with is refused."""

from __future__ import annotations

import json
import os
import stat

import pytest

from ogacq.campaign.run import check_same_maps
from ogacq.errors import InputError
from ogacq.session.records import MapsRecord, StationRecord
from ogacq.session.store import SessionWriter, load_session
from ogacq.writeback.audit import AuditLog
from ogacq.writeback.maps import MapsFile
from ogacq.writeback.maps_table import maps_checksum, read_maps_table, write_maps_table
from tests.compensation.maps import screw_map


def _session(tmp_path, maps=None):
    path = tmp_path / "s.jsonl"
    station = {"controller": {"profile": "cia402", "maps_file": str(tmp_path / "maps.json"),
                              **({"maps": maps} if maps is not None else {})}}
    with SessionWriter.create(path, {"station": station}):
        pass
    return load_session(path)


def test_the_file_round_trip_and_a_hand_edit_refused(tmp_path):
    path = tmp_path / "maps.json"
    assert read_maps_table(path).maps == {} and not read_maps_table(path).exists
    back = write_maps_table(path, {"x": screw_map("x"), "z": screw_map("z")}, session="s")
    assert back.maps["x"] == screw_map("x") and back.checksum == maps_checksum(back.maps)
    data = json.loads(path.read_text())
    data["maps"][0]["forward_mm"][3] += 0.001  # a hand changed one value
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match="does not match its checksum"):
        read_maps_table(path)


def test_write_audited_read_back_and_restored(tmp_path):
    path = tmp_path / "maps.json"
    old = write_maps_table(path, {"y": screw_map("y")})
    session = _session(tmp_path)
    target = MapsFile(path)
    plan = target.plan_write({"x": screw_map("x")}, in_force_checksum=old.checksum)
    assert not plan.refused and set(plan.new_maps) == {"x", "y"}  # y kept
    assert "the maps of y stay" in plan.notes[0]
    with AuditLog(session) as audit:
        target.execute(plan, audit, confirmed_by="--yes")
    assert target.held() == read_maps_table(path).checksum == plan.new_checksum
    stages = [r.stage for r in load_session(session.path).of_type(MapsRecord)]
    assert stages == ["intent", "done"]
    (op,) = MapsFile.operations(load_session(session.path))
    assert op.status == "done" and op.old_checksum == old.checksum
    assert set(op.old_maps) == {"y"}  # what restore needs is in the intent
    back = target.plan_restore(op, target.held())
    assert not back.refused
    with AuditLog(load_session(session.path)) as audit:
        target.execute(back, audit, confirmed_by="--yes")
    assert read_maps_table(path).checksum == old.checksum


def test_a_file_changed_since_the_campaign_is_stale(tmp_path):
    path = tmp_path / "maps.json"
    write_maps_table(path, {"y": screw_map("y")})
    plan = MapsFile(path).plan_write({"x": screw_map("x")}, in_force_checksum=maps_checksum({}))
    assert [r.code for r in plan.refusals] == ["stale"]


def test_a_campaign_resumed_with_other_maps_is_refused(tmp_path):
    path = tmp_path / "maps.json"
    first = write_maps_table(path, {"x": screw_map("x")})
    session = _session(tmp_path, first.identity())
    check_same_maps(session, first)  # the same maps: fine
    other = write_maps_table(path, {"x": screw_map("x", lost_mm=0.0)})
    with pytest.raises(InputError, match="changed since .* was started"):
        check_same_maps(session, other)
    # a campaign started without maps, resumed with some, mixes two compensations too
    bare = _session(tmp_path / "bare")
    with pytest.raises(InputError, match="changed since .* was started"):
        check_same_maps(bare, other)
    # and the last station's record decides (a resume recorded the maps it ran with)
    with SessionWriter.append_to(session.path) as writer:
        writer.write(StationRecord(description={"controller": {"maps": other.identity()}}))
    check_same_maps(load_session(session.path), other)


def test_a_maps_file_saved_in_another_encoding_or_cut_short_is_named_by_line(tmp_path):
    """A cp1252 byte (an editor's save) raised UnicodeDecodeError, a traceback; a file
    cut short named its line only inside json's words."""
    path = tmp_path / "maps.json"
    write_maps_table(path, {"x": screw_map("x")}, session="s")
    written = path.read_bytes()
    edited = written.replace(b'"session": "s"', '"session": "Jürgen"'.encode("cp1252"))
    path.write_bytes(edited)
    at = edited.index(b"\xfc")  # the file is ASCII: a byte is a column
    line, column = edited.count(b"\n", 0, at) + 1, at - edited.rfind(b"\n", 0, at)
    with pytest.raises(InputError) as caught:
        read_maps_table(path)
    assert str(caught.value) == (f"{path}:{line}: not UTF-8 text (byte 0xfc at column "
                                 f"{column}); save the file as UTF-8")
    path.write_bytes(written[:40])
    with pytest.raises(InputError, match=rf"^{path}:\d+: the maps file is not JSON: "):
        read_maps_table(path)


def forged(path, maps, **extra):
    """A maps file as anyone can write one: its checksums recomputed."""
    document = {"format": "ogacq-maps/1", "machine": {"name": "M", "serial": "1"},
                "maps": [m.to_json() for m in maps], "checksums": {m.axis: m.checksum()
                                                                for m in maps}, **extra}
    path.write_text(json.dumps(document))
    return path


def scaled(m, by):
    from dataclasses import replace

    return replace(m, forward_mm=tuple(v * by for v in m.forward_mm),
                   reverse_mm=tuple(v * by for v in m.reverse_mm))


def test_a_maps_file_is_bounded_bound_to_its_machine_and_read_only_as_ogacq_writes_it(
        tmp_path):
    """Each of these was applied or hung (issue 36.2): a 5 mm map (the zero posture
    moved to -5 mm, exit 0), a duplicated key, a map under another axis's checksum,
    another machine's file, a FIFO (hung), /dev/zero (MemoryError after 49 s), deep
    nesting (RecursionError), a link to nothing (silently uncompensated)."""
    owner = ("M", "1")
    x = screw_map("x")
    refused = {
        "reaches 5": forged(tmp_path / "big.json", [scaled(x, 5.0 / max(
            abs(v) for v in (*x.forward_mm, *x.reverse_mm)))]),
        "given twice": tmp_path / "twice.json",
        "unknown key 'note'": forged(tmp_path / "note.json", [x], note="hi"),
        "checksums of axes x, y for maps of x": tmp_path / "renamed.json",
        "those of N, serial 1": forged(tmp_path / "other.json", [x],
                                        machine={"name": "N", "serial": "1"}),
        "not a regular file": tmp_path / "fifo.json",
        "nested too deep": tmp_path / "deep.json",
        "does not exist": tmp_path / "dangling.json",
        "more than any maps file": tmp_path / "huge.json",
    }
    good = forged(tmp_path / "good.json", [x]).read_text()
    (tmp_path / "twice.json").write_text(good[:-1] + ', "maps": []}')
    renamed = json.loads(good)
    renamed["checksums"]["y"] = x.checksum()  # x's map said to be y's too
    (tmp_path / "renamed.json").write_text(json.dumps(renamed))
    os.mkfifo(tmp_path / "fifo.json")
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    (tmp_path / "dangling.json").symlink_to(tmp_path / "gone.json")
    with open(tmp_path / "huge.json", "wb") as fh:
        fh.truncate(5 * 2**20)
    for said, path in refused.items():
        with pytest.raises(InputError, match=said):
            read_maps_table(path, owner=owner)
    with pytest.raises(InputError, match="not a regular file"):
        read_maps_table("/dev/zero")
    assert read_maps_table(tmp_path / "good.json", owner=owner).maps == {"x": x}
    # planned: refused with the value, before the file is touched
    plan = MapsFile(tmp_path / "new.json").plan_write({"x": scaled(x, 1e6)},
                                                      in_force_checksum=None)
    assert [r.code for r in plan.refusals] == ["too_large"] and "x " in plan.refusals[0].message


def test_the_maps_file_has_the_mode_of_every_other_file(tmp_path):
    old = os.umask(0o022)
    try:
        write_maps_table(tmp_path / "maps.json", {"x": screw_map("x")})
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "maps.json").stat().st_mode) == 0o644
