"""The write targets (the controller's offsets, the maps file) seen the same way, against
the simulator's real Modbus server: a write whose values reached the machine counts as
written whatever its audit says of its end; a half-written state is the write's own;
a restore is said done only once the target, read back, holds the previous state."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq.campaign.campaign_file import SimulatorSpec
from ogacq.campaign.station import open_controller, simulator_endpoints, start_simulator
from ogacq.history.recording import writebacks_of
from ogacq.model.machine import MachineSpec
from ogacq.session.records import MapsRecord, OffsetsRecord
from ogacq.session.store import LoadedSession, SessionWriter, load_session
from ogacq.writeback.audit import AuditLog
from ogacq.writeback.maps import MapsFile
from ogacq.writeback.maps_table import maps_checksum, write_maps_table
from ogacq.writeback.offsets_target import ControllerOffsets
from ogacq.writeback.write_target import (
    NotRestored,
    found_in_force,
    left_half_way,
    restore,
    write_in_force,
)
from tests.compensation.maps import screw_map

OLD = {"x": 0.0, "y": 0.0, "z": 0.0}
NEW = {"x": 0.25, "y": -0.5, "z": 0.75}


@pytest.fixture
def controller() -> Iterator[AxisController]:
    stack = start_simulator(MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001),
                            SimulatorSpec(seed=1, speed=50))
    try:
        spec, _ = simulator_endpoints(stack)
        with open_controller(spec) as opened:
            opened.write_offsets(OLD)
            yield opened
    finally:
        stack.close()


def session_with(tmp_path, *records) -> LoadedSession:
    """A campaign's session whose audit holds ``records`` (a write's intent, say,
    with no outcome: the process was killed before it)."""
    path = tmp_path / "s.jsonl"
    with SessionWriter.create(path, {"station": {}}) as writer:
        for record in records:
            writer.write(record)
    return load_session(path)


def intent(operation: str = "write-1", new=NEW) -> OffsetsRecord:
    return OffsetsRecord(stage="intent", details={
        "operation": operation, "action": "write", "profile": "cia402", "old_mm": OLD,
        "new_mm": new})


def test_a_write_killed_before_its_done_record_counts_as_written(tmp_path, controller):
    """Killed after the controller took the new values, before ``done``: the audit
    says interrupted, the controller says written, and the controller is believed
    (the procedure looked only for ``done`` writes: it found nothing to restore)."""
    target = ControllerOffsets(controller, options=_no_homing())
    session = session_with(tmp_path, intent())
    controller.write_offsets(NEW)
    (op,) = target.operations(session)
    assert op.status == "interrupted"
    assert write_in_force(target, [op], target.held()) is op
    with AuditLog(session) as audit:
        assert found_in_force(target, session, audit) == op
    session = load_session(session.path)  # read back: the audit now says it is in force
    (op,) = target.operations(session)
    assert op.status == "done" and op.new_mm == NEW
    assert writebacks_of(session)[0].status == "done"  # and so does the history
    with AuditLog(session) as audit:
        restored = restore(target, op, session, audit, "test")
    assert restored is not None and restored.startswith("restore-")
    assert target.same(target.held(), OLD)
    after = {o.operation: o for o in target.operations(load_session(session.path))}
    assert after[restored].status == "done" and after[restored].restores == "write-1"


def test_a_write_cut_half_way_is_its_own_state_and_put_back(tmp_path, controller):
    """x and y written, z not yet: the write's own state, not someone else's change;
    a restore puts the old values back (it was refused as 'a later change')."""
    target = ControllerOffsets(controller, options=_no_homing())
    session = session_with(tmp_path, intent())
    controller.write_offsets({**OLD, "x": NEW["x"], "y": NEW["y"]})
    ops = target.operations(session)
    held = target.held()
    assert write_in_force(target, ops, held) is None
    assert left_half_way(target, ops, held) is ops[0]
    controller.write_offsets({**OLD, "x": 1.0})  # not what the write left: someone else's
    assert left_half_way(target, ops, target.held()) is None
    controller.write_offsets({**OLD, "x": NEW["x"], "y": NEW["y"]})
    with AuditLog(session) as audit:
        restore(target, ops[0], session, audit, "test")
    assert target.same(target.held(), OLD)


def test_a_restore_not_read_back_is_not_said_done(tmp_path, controller, monkeypatch):
    """The drive acknowledged, the read-back holds something else: NotRestored, with
    what is held, never 'restored'."""
    target = ControllerOffsets(controller, options=_no_homing())
    session = session_with(tmp_path, intent())
    controller.write_offsets(NEW)
    (op,) = target.operations(session)
    monkeypatch.setattr(target, "execute", lambda plan, audit, by: "restore-lost")
    with AuditLog(session) as audit, pytest.raises(NotRestored) as caught:
        restore(target, op, session, audit, "test")
    assert "read back x +0.2500, y -0.5000, z +0.7500 mm" in str(caught.value)


def test_a_maps_write_killed_before_its_done_record_counts_as_written(tmp_path):
    path = tmp_path / "maps.json"
    new = write_maps_table(path, {"x": screw_map("x")})  # the file was replaced, then killed
    session = session_with(tmp_path, MapsRecord(stage="intent", details={
        "operation": "maps-write-1", "action": "write", "file": str(path), "old_maps": [],
        "old_checksum": maps_checksum({}), "new_maps": [screw_map("x").to_json()],
        "new_checksum": new.checksum}))
    target = MapsFile(path)
    (op,) = target.operations(session)
    assert op.status == "interrupted" and write_in_force(target, [op], target.held()) is op
    with AuditLog(session) as audit:
        restore(target, op, session, audit, "test")
    assert target.held() == maps_checksum({})


def _no_homing():
    from ogacq.writeback.execute import WriteOptions

    return WriteOptions(rehome=False)
