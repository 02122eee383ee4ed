"""The procedure's journal (``ProcedureLog.once``): a step run once and recorded, its
recorded result handed back after the log is reopened (a resume) instead of running it
again, each round's steps apart, a step begun and cut by a kill undone first, and a
log written before the steps were named (plain words) resumed alike."""

from __future__ import annotations

import json
from collections.abc import Callable

from ogacq.calibration.log import LOG_NAME, ProcedureLog, Step
from ogacq.calibration.procedure import Outcome, _outcome_of
from ogacq.writeback.outcome import WriteOutcome


def counted(calls: list[str], name: str, details: dict) -> Callable[[], dict]:
    def run() -> dict:
        calls.append(name)
        return details
    return run


def test_a_step_runs_once_and_a_resume_replays_its_recorded_result(tmp_path):
    calls: list[str] = []
    log = ProcedureLog.create(tmp_path, {"mode": "simulator"})
    got = log.once(Step.COMPENSATION, counted(calls, "first", {"offsets_mm": {"x": 0.1}}),
                   round=None)
    again = log.once(Step.COMPENSATION, counted(calls, "again", {"offsets_mm": {"x": 9.0}}),
                     round=None)
    log.close()
    resumed = ProcedureLog.reopen(tmp_path)
    replayed = resumed.once(Step.COMPENSATION, counted(calls, "resumed", {}), round=None)
    second = resumed.once(Step.COMPENSATION, counted(calls, "round 2", {"offsets_mm": {}}),
                          round=2)
    resumed.close()
    assert calls == ["first", "round 2"]
    assert got == again == replayed == {"offsets_mm": {"x": 0.1}}  # round 1: no key
    assert second == {"round": 2, "offsets_mm": {}}
    lines = [json.loads(line) for line in (tmp_path / LOG_NAME).read_text().splitlines()]
    assert [(r["step"], r.get("round")) for r in lines if r["type"] == "calibrate"] == \
        [("compensation", None), ("compensation", 2)]


def test_a_step_begun_and_not_done_is_cut_before_it_runs_again(tmp_path):
    calls: list[str] = []
    log = ProcedureLog.create(tmp_path, {"mode": "simulator"})
    cut = counted(calls, "undone", {})
    log.once(Step.WRITTEN, counted(calls, "write", {"offsets": "W1"}), cut=cut)
    assert calls == ["write"]  # not begun: nothing to undo
    log.once(Step.CONFIRMED, counted(calls, "confirm", {"by": "--yes"}), round=2)
    log.close()  # killed in round 2's write, after its confirmation
    resumed = ProcedureLog.reopen(tmp_path)
    written = resumed.once(Step.WRITTEN, counted(calls, "write 2", {"offsets": "W2"}),
                           cut=cut, round=2)
    resumed.once(Step.WRITTEN, counted(calls, "write 3", {}), cut=cut, round=2)
    resumed.close()
    assert calls == ["write", "confirm", "undone", "write 2"]
    assert written == {"round": 2, "offsets": "W2"}


def test_a_log_written_with_plain_words_resumes_and_its_end_is_an_outcome(tmp_path):
    old = ProcedureLog.create(tmp_path, {"mode": "simulator"})
    old.add("note", text="maps not established")  # type: ignore[arg-type]
    old.add("finished", outcome="restored", reason="worse")  # type: ignore[arg-type]
    old.close()
    log = ProcedureLog.reopen(tmp_path)
    assert log.once(Step.NOTE, lambda: {"text": "told again"}, text="maps not established") \
        == {"text": "maps not established"}
    assert log.finished is not None
    end = _outcome_of(tmp_path, log.procedure, log.finished.details)
    log.close()
    assert isinstance(end, Outcome) and end.outcome is WriteOutcome.RESTORED
    assert end.exit_code == 4
