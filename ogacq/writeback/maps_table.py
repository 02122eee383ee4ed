"""The maps file: the error maps ogacq applies itself to every target it commands.

The Modbus drives hold no compensation table, so the maps live in a JSON file
named by the campaign file's ``[controller] maps_file``, as the IAI offsets live
in the software offset table: every campaign loads it (the runner corrects each
target, ``ogacq.compensation.applied``), ``ogacq calibrate`` replaces it
atomically (a crash leaves the old file or the new one, never half of one) and
reads it back. Each map is stored whole (``AxisMap.to_json``) with its checksum,
so a file edited by hand is refused rather than applied::

    {"format": "ogacq-maps/1", "written": "...", "session": "...", "action": "write",
     "maps": [{"format": "ogacq-axis-map/1", "axis": "x", ...}],
     "checksums": {"x": "<sha256 of the map>"}}

The file's identity, recorded in every session that used it, is ``checksum``: the
SHA-256 of the axes' checksums in order (no maps: the checksum of none).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq.io.errors import InputError
from ogacq.io.text import read_text
from ogacq.logs import logger
from ogacq.model.axis_map import AxisMap
from ogacq.model.parameters import AXES

log = logger(__name__)

FORMAT = "ogacq-maps/1"


def maps_checksum(maps: Mapping[str, AxisMap]) -> str:
    """The identity of a set of maps: SHA-256 over ``axis:checksum`` lines, x y z order."""
    text = "".join(f"{a}:{maps[a].checksum()}\n" for a in AXES if a in maps)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class MapsTable:
    path: Path
    maps: dict[str, AxisMap]
    exists: bool  # False: no file yet, no maps applied
    about: dict[str, Any] = field(default_factory=dict)  # written, session, action

    @property
    def checksum(self) -> str:
        return maps_checksum(self.maps)

    def identity(self) -> dict[str, Any]:
        """What a session records of the maps it ran with."""
        return {"file": str(self.path), "exists": self.exists, "checksum": self.checksum,
                "axes": {a: m.checksum() for a, m in self.maps.items()},
                "sources": {a: m.source for a, m in self.maps.items()}}


def read_maps_table(path: str | Path) -> MapsTable:
    """The file at ``path``; a missing file means no maps (nothing applied)."""
    path = Path(path)
    try:
        text = read_text(path)  # UTF-8 (a BOM dropped), a wrong byte named by its line
    except FileNotFoundError:
        return MapsTable(path, {}, exists=False)
    except OSError as exc:
        raise InputError(path, f"cannot read the maps file ({exc.strerror or exc})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"the maps file is not JSON: {exc.msg} at column {exc.colno}",
                         exc.lineno) from None
    except ValueError as exc:  # an integer of thousands of digits
        raise InputError(path, f"the maps file is not JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise InputError(path, f"not an {FORMAT} maps file")
    maps: dict[str, AxisMap] = {}
    listed = data.get("maps")
    checksums = data.get("checksums")
    if not isinstance(listed, list) or not isinstance(checksums, dict):
        raise InputError(path, "the maps file needs 'maps' (a list) and 'checksums'")
    for k, entry in enumerate(listed):
        if not isinstance(entry, dict):
            raise InputError(path, f"map {k + 1} is not a JSON object")
        m = AxisMap.from_json(entry, f"{path}: map {k + 1}")
        if m.axis in maps:
            raise InputError(path, f"two maps of axis {m.axis}")
        if checksums.get(m.axis) != m.checksum():
            raise InputError(path, f"the map of axis {m.axis} does not match its checksum: "
                             "changed after ogacq wrote it; write it again with ogacq")
        maps[m.axis] = m
    about = {k: data[k] for k in ("written", "session", "action") if k in data}
    return MapsTable(path, maps, exists=True, about=about)


def write_maps_table(path: str | Path, maps: Mapping[str, AxisMap], *, session: str = "",
                     action: str = "write") -> MapsTable:
    """Replace the file atomically (temporary file, fsync, rename, fsync of the folder)
    and return it as read back from disk."""
    path = Path(path)
    ordered = {a: maps[a] for a in AXES if a in maps}
    content = json.dumps({
        "format": FORMAT, "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "session": session, "action": action,
        "maps": [m.to_json() for m in ordered.values()],
        "checksums": {a: m.checksum() for a, m in ordered.items()}}, indent=1) + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(content)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    with contextlib.suppress(OSError):  # the rename itself durable (POSIX)
        folder = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(folder)
        finally:
            os.close(folder)
    log.info("maps file %s written (%s): %s", path, action, maps_checksum(ordered)[:12])
    return read_maps_table(path)
