"""The software offset table: joint offsets the tool applies itself.

Controllers with no zero-offset register (the IAI profile) leave the offsets
to the tool: ``AxisController`` adds them to every commanded position. The
table is a small TOML file named by the campaign file's ``[controller]
offsets_file``; every campaign loads it, ``ogacq offsets write`` replaces it
atomically (a crash leaves the old file or the new one, never half of one).

    format = "ogacq-offsets/1"
    [joint_offset_mm]          # q = raw - offset, per axis
    x = 1.2429
    y = 0.7911
    z = -0.9035
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq_drivers.config_schema import Field, Table, dump, load, number, text
from ogacq.io.atomic import write_atomically
from ogacq.io.toml_file import read_toml
from ogacq.logs import logger
from ogacq.model.parameters import AXES

log = logger(__name__)

FORMAT = "ogacq-offsets/1"
HEADER = """Software joint offsets (mm), applied by ogacq to every commanded position:
controller coordinate q = raw position - offset. Written by `ogacq offsets`;
the session named below records the old and new values."""

OFFSET_TABLE_FILE = Table((
    Field("format", text(FORMAT)),
    Field("written", text()),
    Field("session", text()),
    Field("action", text()),
    Field("joint_offset_mm", Table(tuple(Field(a, number(), required=True) for a in AXES),
                                   noun="axis"), required=True),
))


@dataclass(frozen=True)
class OffsetTable:
    path: Path
    offsets_mm: dict[str, float]
    exists: bool  # False: no file yet (before the first write-back), all offsets zero
    about: dict[str, Any] = field(default_factory=dict)  # written, session, action


def read_offset_table(path: str | Path) -> OffsetTable:
    """The table at ``path``; a missing file means no offsets yet (all zero)."""
    path = Path(path)
    try:
        data, source = read_toml(path, "the offset table")
    except FileNotFoundError:
        return OffsetTable(path, dict.fromkeys(AXES, 0.0), exists=False)
    given = load(OFFSET_TABLE_FILE, data, source)
    offsets = given.pop("joint_offset_mm")
    given.pop("format", None)
    return OffsetTable(path, {a: offsets[a] for a in AXES}, exists=True, about=given)


def write_offset_table(path: str | Path, offsets_mm: dict[str, float], *,
                       session: str = "", action: str = "write") -> OffsetTable:
    """Replace the table atomically (temporary file, fsync, rename, fsync of the folder)
    and return it as read back from disk."""
    path = Path(path)
    values = {a: float(offsets_mm[a]) for a in AXES}
    content = dump(OFFSET_TABLE_FILE, {
        "format": FORMAT, "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "session": session, "action": action, "joint_offset_mm": values}, header=HEADER)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, content.encode("utf-8"))  # its folder synced too
    log.info("offset table %s written (%s): %s", path, action,
             ", ".join(f"{a} {v:+.6f} mm" for a, v in values.items()))
    return read_offset_table(path)
