"""The procedure's journal: each step run once, its result replayed after a kill
(bluesky's plans and checkpoints are the model).

``procedure.jsonl`` in the procedure's folder holds a header (what was asked:
the mode, the options, the setup) and one ``calibrate`` record per step done
(``ogacq.session.records.CalibrateRecord``, its ``step`` a ``Step``). It is written
with the session store (sequence numbers, checksums, an OS lock, fsync), so a killed
procedure loses nothing it recorded, and ``ProcedureLog.once`` hands a step's recorded
result back on ``ogacq calibrate --resume`` instead of running it again: the procedure
continues at the first step not done, and says nothing twice.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from ogacq.errors import InputError
from ogacq.session.header import SessionHeader
from ogacq.session.records import CalibrateRecord
from ogacq.session.store import SessionWriter, load_session

LOG_NAME = "procedure.jsonl"
PROCEDURE_FORMAT = "ogacq-calibrate/1"

Details = dict[str, Any]  # what a step recorded: its key (role, round, ...) and result


class Step(StrEnum):
    """A step of the procedure, as its log names it (a member is the word on disk)."""

    CAMPAIGN = "campaign"  # a campaign (role, status started or finished), its session
    SCALE_MAPS = "scale maps"  # what each axis scale's test found along its axis
    DIAGNOSIS = "diagnosis"  # a campaign's diagnosis (role)
    SEPARATION = "separation"  # the separating measurement planned
    NOTE = "note"  # something the end must say (text)
    COMPENSATION = "compensation"  # the offsets and maps to write, the tables exported
    REFUSED = "refused"  # the gate refused the write: the procedure ends
    DECLINED = "declined"  # the operator declined it: the procedure ends
    CONFIRMED = "confirmed"  # the operator (or --yes) confirmed the write
    WRITTEN = "written"  # the offsets and maps written, read back, audited
    VALIDATION = "validation"  # a validation campaign judged (role)
    SCALES = "scales"  # each axis scale's test after the write, against its map
    RESTORED = "restored"  # the validation was worse: the state before put back
    FINISHED = "finished"  # the end, its outcome and reason


# The step whose record says a step was begun: a resume that finds it without the step
# itself finds the step cut by the kill (a write half-made), to be undone before it runs.
BEGUN_BY = {Step.WRITTEN: Step.CONFIRMED}


@dataclass
class ProcedureLog:
    path: Path
    header: SessionHeader
    steps: list[CalibrateRecord]
    writer: SessionWriter

    @property
    def procedure(self) -> str:
        return str((self.header.procedure or {})["id"])

    @classmethod
    def create(cls, folder: Path, setup: dict[str, Any]) -> ProcedureLog:
        path = folder / LOG_NAME
        header = {"procedure": {"format": PROCEDURE_FORMAT,
                                "id": f"C-{time.strftime('%Y%m%d')}-{secrets.token_hex(3)}",
                                **setup}}
        writer = SessionWriter.create(path, header)
        return cls(path, load_session(path).header, [], writer)

    @classmethod
    def reopen(cls, folder: Path) -> ProcedureLog:
        path = folder / LOG_NAME
        if not path.is_file():
            raise InputError(folder, f"no calibration procedure here (no {LOG_NAME})")
        loaded = load_session(path)
        if (loaded.header.procedure or {}).get("format") != PROCEDURE_FORMAT:
            raise InputError(path, f"not an {PROCEDURE_FORMAT} log")
        writer = SessionWriter.append_to(path, loaded.size_bytes or None)
        return cls(path, loaded.header, loaded.of_type(CalibrateRecord), writer)

    def once(self, step: Step, run: Callable[[], Details], *,
             cut: Callable[[], None] | None = None, **key: Any) -> Details:
        """``step`` (``key``: which one, a None value for a key the record leaves out)
        run once: the details its latest record holds where the log has it, else
        ``run()``'s, recorded after ``key``. ``cut``: run first where the step was begun
        and not done (``BEGUN_BY``)."""
        done = self.last(step, **key)
        if done is not None:
            return done.details
        if cut is not None and self.last(BEGUN_BY[step], **key) is not None:
            cut()
        details = run()
        present = {k: v for k, v in key.items() if v is not None}
        return self.add(step, **present, **details).details

    def add(self, step: Step, **details: Any) -> CalibrateRecord:
        record = CalibrateRecord(step=step, details=details)
        self.writer.write(record)
        self.writer.sync()  # a step is done once it is on the disk
        self.steps.append(record)
        return record

    def last(self, step: Step, **match: Any) -> CalibrateRecord | None:
        """The latest record of ``step`` whose details hold ``match``."""
        for record in reversed(self.steps):
            if record.step == step and all(record.details.get(k) == v
                                           for k, v in match.items()):
                return record
        return None

    @property
    def finished(self) -> CalibrateRecord | None:
        return self.last(Step.FINISHED)

    def close(self) -> None:
        self.writer.close()
