"""Executing a plan: the order of work, the read-back, and the audit records when a step
fails; with a stand-in controller, so each failure can be made to happen."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from ogacq_drivers.axes.controller import OffsetChange
from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.errors import DeviceTimeout
from ogacq.model.parameters import AXES
from ogacq.session.records import EndRecord, OffsetsRecord, ResumeRecord
from ogacq.session.store import SessionWriter, load_session
from ogacq.writeback.audit import AuditLog, last_write, operations
from ogacq.writeback.execute import WriteBackError, WriteOptions, execute_plan
from ogacq.writeback.policy import AxisChange, ControllerFacts, OffsetPlan
from ogacq.writeback.table import read_offset_table

ZEROS = dict.fromkeys(AXES, 0.0)
NEW = {"x": 1.24, "y": 0.79, "z": -0.90}


class StandInController:
    """What ``execute_plan`` uses of ``AxisController``, with faults on request."""

    def __init__(self, profile_name: str, *, store_error_mm: float = 0.0,
                 home_error_mm: float = 0.0, home_fails: bool = False) -> None:
        self.profile = load_profile(profile_name)
        self.held = dict(ZEROS)
        self.software = self.profile.offset.kind == "software"
        self.store_error_mm = store_error_mm
        self.home_error_mm = home_error_mm
        self.home_fails = home_fails
        self.calls: list[str] = []

    @property
    def software_offsets_mm(self) -> dict[str, float]:
        return dict(self.held)

    def read_offsets(self) -> dict[str, float]:
        return dict(self.held)

    def read_status(self):
        return {a: SimpleNamespace(servo_on=True) for a in AXES}

    def write_offsets(self, offsets_mm, *, force=False) -> OffsetChange:
        self.calls.append("write")
        old = dict(self.held)
        self.held.update({a: v + self.store_error_mm for a, v in offsets_mm.items()})
        when = "now" if self.software else "at_next_homing"
        return OffsetChange(old, dict(self.held), when, not self.software)

    def save_to_nvm(self) -> None:
        self.calls.append("nvm")

    def enable(self, axes=None) -> None:
        self.calls.append("enable")

    def disable(self, axes=None) -> None:
        self.calls.append("disable")

    def home(self):
        self.calls.append("home")
        if self.home_fails:
            raise DeviceTimeout("home x: homed did not become True within 60 s", where="sim")
        return {a: SimpleNamespace(position_mm=-self.held[a] + self.home_error_mm)
                for a in AXES}


def plan_for(profile_name: str, current=ZEROS, new=NEW) -> OffsetPlan:
    facts = ControllerFacts.of(load_profile(profile_name))
    return OffsetPlan("write", facts, tuple(AxisChange(a, current[a], new[a]) for a in AXES),
                      baseline_mm=dict(current))


@pytest.fixture
def session(tmp_path):
    with SessionWriter.create(tmp_path / "s.jsonl", {"plan": None}) as writer:
        writer.write(EndRecord(status="complete"))
    return load_session(tmp_path / "s.jsonl")


def stages(path: Path) -> list[str]:
    return [r.stage for r in load_session(path).of_type(OffsetsRecord)]


def test_write_read_back_save_rehome_and_record(session):
    controller = StandInController("cia402")
    with AuditLog(session) as audit:
        outcome = execute_plan(controller, plan_for("cia402"), audit,
                               WriteOptions(save_nvm=True, confirmed_by="--yes"))
    assert controller.calls == ["write", "nvm", "enable", "home"]
    assert outcome.new_mm == NEW and outcome.rehomed and outcome.nvm_saved
    assert stages(session.path) == ["intent", "done"]
    intent, done = load_session(session.path).of_type(OffsetsRecord)
    assert intent.details["old_mm"] == ZEROS and intent.details["new_mm"] == NEW
    assert intent.details["save_nvm"]
    assert done.details["home_positions_mm"] == {a: -v for a, v in NEW.items()}
    # no "resume" record: a write-back is not a campaign resume
    assert load_session(session.path).of_type(ResumeRecord) == []
    op = last_write(load_session(session.path))
    assert op.status == "done" and op.old_mm == ZEROS and op.new_mm == NEW


def test_no_home_leaves_the_offset_pending(session):
    controller = StandInController("cia402")
    with AuditLog(session) as audit:
        outcome = execute_plan(controller, plan_for("cia402"), audit, WriteOptions(rehome=False))
    assert controller.calls == ["write"] and outcome.pending_homing


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"store_error_mm": 0.02}, "read back x +1.2600"),
    ({"home_error_mm": 0.3}, "after homing the axes read"),
    ({"home_fails": True}, "homed did not become True"),
])
def test_a_failed_step_is_recorded_with_what_the_controller_holds(session, kwargs, words):
    controller = StandInController("cia402", **kwargs)
    with AuditLog(session) as audit, pytest.raises(WriteBackError) as failed:
        execute_plan(controller, plan_for("cia402"), audit, WriteOptions())
    assert failed.value.written and words in str(failed.value)
    assert "ogacq offsets restore" in str(failed.value)
    assert stages(session.path) == ["intent", "failed"]
    record = load_session(session.path).of_type(OffsetsRecord)[-1]
    assert words in record.details["error"] and record.details["held_mm"] == controller.held
    # restore has what it needs: the old values, from the intent
    op = operations(load_session(session.path))[-1]
    assert op.status == "failed" and op.old_mm == ZEROS


def test_offsets_changed_since_the_plan_writes_nothing(session):
    controller = StandInController("cia402")
    controller.held["y"] = 0.5  # someone wrote in between
    with AuditLog(session) as audit, pytest.raises(WriteBackError) as failed:
        execute_plan(controller, plan_for("cia402"), audit, WriteOptions())
    assert not failed.value.written and "changed since the plan" in str(failed.value)
    assert controller.calls == [] and stages(session.path) == []


def test_software_table_written_atomically_and_read_back(session, tmp_path):
    controller = StandInController("iai-pcon")
    table = tmp_path / "cfg" / "offsets.toml"
    with AuditLog(session) as audit:
        outcome = execute_plan(controller, plan_for("iai-pcon"), audit, WriteOptions(),
                               offsets_file=table)
    assert controller.calls == ["write"]  # takes effect now: nothing to home
    assert outcome.takes_effect == "now" and not outcome.rehomed
    on_disk = read_offset_table(table)
    assert on_disk.exists and on_disk.offsets_mm == NEW
    assert on_disk.about["session"] == str(session.path.resolve())
    assert [p.name for p in table.parent.iterdir()] == ["offsets.toml"]  # no temporary left


def test_software_profile_needs_its_table_and_has_no_nvm(session):
    controller = StandInController("iai-pcon")
    with AuditLog(session) as audit:
        with pytest.raises(WriteBackError, match="offsets_file"):
            execute_plan(controller, plan_for("iai-pcon"), audit, WriteOptions())
        with pytest.raises(WriteBackError, match="non-volatile"):
            execute_plan(controller, plan_for("iai-pcon"), audit, WriteOptions(save_nvm=True),
                         offsets_file=Path("t.toml"))
    assert controller.calls == [] and stages(session.path) == []


def test_a_torn_last_record_is_cut_before_appending(session):
    with session.path.open("a") as fh:
        fh.write('{"type":"reading","step":"x/c1')  # a crash mid-write
    torn = load_session(session.path)
    assert torn.warnings
    with AuditLog(torn) as audit:
        audit.record("declined", action="write")
    again = load_session(session.path)
    assert not again.warnings and stages(session.path) == ["declined"]
