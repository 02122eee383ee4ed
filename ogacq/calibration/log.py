"""The procedure's log: one append-only file of records, as a campaign's session.

``procedure.jsonl`` in the procedure's folder holds a header (what was asked:
the mode, the options, the setup) and one ``calibrate`` record per step done
(``ogacq.session.records.CalibrateRecord``): a campaign started or finished, a
diagnosis, the separating measurement planned, the compensation, the operator's
confirmation, the writes, the validation, a restore, the end. It is written with
the session store (sequence numbers, checksums, an OS lock, fsync), so a killed
procedure loses nothing it recorded, and ``ogacq calibrate --resume`` reads it to
continue at the first step not done.
"""

from __future__ import annotations

import secrets
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ogacq.errors import InputError
from ogacq.session.header import SessionHeader
from ogacq.session.records import CalibrateRecord
from ogacq.session.store import SessionWriter, load_session

LOG_NAME = "procedure.jsonl"
PROCEDURE_FORMAT = "ogacq-calibrate/1"


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

    def add(self, step: str, **details: Any) -> CalibrateRecord:
        record = CalibrateRecord(step=step, details=details)
        self.writer.write(record)
        self.writer.sync()  # a step is done once it is on the disk
        self.steps.append(record)
        return record

    def last(self, step: str, **match: Any) -> CalibrateRecord | None:
        """The latest record of ``step`` whose details hold ``match``."""
        for record in reversed(self.steps):
            if record.step == step and all(record.details.get(k) == v
                                           for k, v in match.items()):
                return record
        return None

    @property
    def finished(self) -> CalibrateRecord | None:
        return self.last("finished")

    def close(self) -> None:
        self.writer.close()
