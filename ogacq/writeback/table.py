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

import contextlib
import logging
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq.io.errors import InputError
from ogacq.io.toml_file import line_of, read_toml
from ogacq.model.parameters import AXES

log = logging.getLogger(__name__)

FORMAT = "ogacq-offsets/1"
_TOP = {"format", "written", "session", "action", "joint_offset_mm"}


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
        data, text = read_toml(path, "the offset table")
    except FileNotFoundError:
        return OffsetTable(path, dict.fromkeys(AXES, 0.0), exists=False)
    for key in data:
        if key not in _TOP:
            raise InputError(path, f"unknown key {key!r} in the offset table (allowed: "
                             f"{', '.join(sorted(_TOP))})", line_of(text, key))
    if data.get("format", FORMAT) != FORMAT:
        raise InputError(path, f"offset table format {data['format']!r} is not {FORMAT!r}",
                         line_of(text, "format"))
    table = data.get("joint_offset_mm")
    if not isinstance(table, dict):
        raise InputError(path, "missing [joint_offset_mm] (x, y, z in mm)")
    offsets: dict[str, float] = {}
    for key, value in table.items():
        line = line_of(text, key)
        if key not in AXES:
            raise InputError(path, f"[joint_offset_mm] has unknown axis {key!r} (x, y, z)", line)
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value):
            raise InputError(path, f"joint_offset_mm.{key} must be a finite number of mm, "
                             f"got {value!r}", line)
        offsets[key] = float(value)
    missing = [a for a in AXES if a not in offsets]
    if missing:
        raise InputError(path, f"[joint_offset_mm] lacks {', '.join(missing)}",
                         line_of(text, "joint_offset_mm"))
    about = {k: data[k] for k in ("written", "session", "action") if k in data}
    return OffsetTable(path, offsets, exists=True, about=about)


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def write_offset_table(path: str | Path, offsets_mm: dict[str, float], *,
                       session: str = "", action: str = "write") -> OffsetTable:
    """Replace the table atomically (temporary file, fsync, rename, fsync of the folder)
    and return it as read back from disk."""
    path = Path(path)
    values = {a: float(offsets_mm[a]) for a in AXES}
    bad = {a: v for a, v in values.items() if not math.isfinite(v)}
    if bad:
        raise ValueError(f"offset table: {bad} are not finite numbers")
    lines = [
        "# Software joint offsets (mm), applied by ogacq to every commanded position:",
        "# controller coordinate q = raw position - offset. Written by `ogacq offsets`;",
        "# the session named below records the old and new values.",
        f"format = {_toml_string(FORMAT)}",
        f"written = {_toml_string(time.strftime('%Y-%m-%dT%H:%M:%S%z'))}",
        f"session = {_toml_string(session)}",
        f"action = {_toml_string(action)}",
        "",
        "[joint_offset_mm]",
        # repr round-trips a float exactly, and is valid TOML for finite values
        *(f"{a} = {values[a]!r}" for a in AXES),
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write("\n".join(lines) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_folder(path.parent)
    log.info("offset table %s written (%s): %s", path, action,
             ", ".join(f"{a} {v:+.6f} mm" for a, v in values.items()))
    return read_offset_table(path)


def _fsync_folder(folder: Path) -> None:
    """Make the rename itself durable (POSIX); a no-op where folders cannot be opened."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)
