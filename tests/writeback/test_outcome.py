"""The write-back's words named once (``ogacq/writeback/outcome.py``): written to the
session as the words they were, read back as the enum, spelt nowhere else in the
write-back."""

from __future__ import annotations

import ast
import json
from pathlib import Path

from ogacq.session.records import EndRecord
from ogacq.session.store import SessionWriter, load_session
from ogacq.writeback.audit import AuditLog, operations
from ogacq.writeback.outcome import Stage, WriteOutcome

WRITEBACK = Path(__file__).resolve().parents[2] / "ogacq" / "writeback"


def test_an_operation_reads_its_stage_back_as_the_enum_and_writes_the_same_words(tmp_path):
    with SessionWriter.create(tmp_path / "s.jsonl", {"plan": None}) as writer:
        writer.write(EndRecord(status="complete"))
    with AuditLog(load_session(tmp_path / "s.jsonl")) as audit:
        for op in ("write-1", "write-2"):
            audit.record(Stage.INTENT, operation=op, action="write", old_mm={"x": 0.0},
                         new_mm={"x": 0.1})
        audit.record(Stage.DONE, operation="write-1", action="write", new_mm={"x": 0.1})
    ops = operations(load_session(tmp_path / "s.jsonl"))
    # write-2's intent has no end: the process died between them
    assert [op.status for op in ops] == [Stage.DONE, Stage.INTERRUPTED]
    assert all(isinstance(op.status, Stage) for op in ops)
    lines = [json.loads(line) for line in (tmp_path / "s.jsonl").read_text().splitlines()]
    assert [line.get("stage") for line in lines if line.get("type") == "offsets"] == \
        ["intent", "intent", "done"]


def test_the_words_are_those_the_records_and_the_history_hold():
    assert [s.value for s in Stage] == ["refused", "declined", "intent", "done", "failed",
                                        "interrupted"]
    assert f"{WriteOutcome.RESTORED}" == "restored" == json.loads(
        json.dumps(WriteOutcome.RESTORED))
    assert {"restored": 4}.get(WriteOutcome.RESTORED) == 4  # a member finds its word


def test_no_write_back_module_spells_a_stage_or_an_outcome():
    words = {m.value for m in (*Stage, *WriteOutcome)}
    spelt = [f"{path.name}:{node.lineno} {node.value!r}"
             for path in sorted(WRITEBACK.glob("*.py")) if path.name != "outcome.py"
             for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
             if isinstance(node, ast.Constant) and node.value in words]
    assert spelt == []
