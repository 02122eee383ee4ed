"""The maps file: the error maps ogacq applies itself to every target it commands.

The Modbus drives hold no compensation table, so the maps live in a JSON file
named by the campaign file's ``[controller] maps_file``, as the IAI offsets live
in the software offset table: every campaign loads it (the runner corrects each
target, ``ogacq.compensation.applied``), ``ogacq calibrate`` replaces it
atomically (a crash leaves the old file or the new one, never half of one) and
reads it back. Each map is stored whole (``AxisMap.to_json``) with its checksum,
so a file edited by hand is refused rather than applied; it names the machine it
was measured on, and a campaign of another machine refuses it::

    {"format": "ogacq-maps/1", "written": "...", "session": "...", "action": "write",
     "machine": {"name": "...", "serial": "..."},
     "maps": [{"format": "ogacq-axis-map/1", "axis": "x", ...}],
     "checksums": {"x": "<sha256 of the map>"}}

The file's identity, recorded in every session that used it, is ``checksum``: the
SHA-256 of the axes' checksums in order (no maps: the checksum of none).
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq.io.atomic import write_atomically
from ogacq.io.errors import InputError
from ogacq.io.text import decode_text
from ogacq.logs import logger
from ogacq.model.axis_map import AxisMap
from ogacq.model.parameters import AXES

log = logger(__name__)

FORMAT = "ogacq-maps/1"
Owner = tuple[str, str]  # the machine's name and serial


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

    @property
    def owner(self) -> Owner | None:
        """The machine (name, serial) the file names; None where it names none."""
        named = self.about.get("machine")
        return (str(named.get("name", "")), str(named.get("serial", ""))) \
            if isinstance(named, dict) else None

    def identity(self) -> dict[str, Any]:
        """What a session records of the maps it ran with."""
        return {"file": str(self.path), "exists": self.exists, "checksum": self.checksum,
                "axes": {a: m.checksum() for a, m in self.maps.items()},
                "sources": {a: m.source for a, m in self.maps.items()}}


# A map of a thousand points in both directions with its u is ~100 kB.
MAX_BYTES = 4 * 2**20
KEYS = frozenset({"format", "written", "session", "action", "machine", "maps", "checksums"})
#: The gate of the offsets (``ogacq offsets write --max-change-mm`` default): a map moves
#: each target by its value, and no error a map corrects is larger on this machine type.
MAX_MAP_MM = 2.0


def read_maps_table(path: str | Path, *, owner: Owner | None = None) -> MapsTable:
    """The file at ``path``; a missing file means no maps (nothing applied). Read only
    from a regular file of bounded size; a key unknown or given twice, a map beyond
    ``MAX_MAP_MM``, a checksum that is not its map's, or (``owner`` given) the maps of
    another machine: refused (InputError, naming the file)."""
    path = Path(path)
    data = _read_regular(path)
    if data is None:
        return MapsTable(path, {}, exists=False)
    text = decode_text(data, path)  # UTF-8 (a BOM dropped), a wrong byte named by its line
    try:
        document = json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"the maps file is not JSON: {exc.msg} at column {exc.colno}",
                         exc.lineno) from None
    except RecursionError:
        raise InputError(path, "the maps file is not JSON ogacq writes: nested too deep") \
            from None
    except ValueError as exc:  # an integer of thousands of digits, a key given twice
        raise InputError(path, f"the maps file is not JSON ogacq writes ({exc})") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise InputError(path, f"not an {FORMAT} maps file")
    unknown = sorted(set(document) - KEYS)
    if unknown:
        raise InputError(path, f"unknown key {unknown[0]!r} in the maps file (known: "
                         f"{', '.join(sorted(KEYS))})")
    maps = _maps_in(path, document)
    table = MapsTable(path, maps, exists=True,
                      about={k: document[k] for k in ("written", "session", "action", "machine")
                             if k in document})
    if owner is not None and maps:
        _check_owner(table, owner)
    return table


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"key {key!r} given twice")
        out[key] = value
    return out


def _read_regular(path: Path) -> bytes | None:
    """The bytes of a regular file (None: no file); a FIFO, a device, a link to nothing
    or a file too large to be a maps file refused before a byte is read."""
    if path.is_symlink() and not path.exists():
        raise InputError(path, f"a link to {os.readlink(path)}, which does not exist: the maps "
                         "file was moved or deleted")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO opens without a writer
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise InputError(path, f"cannot read the maps file ({exc.strerror or exc})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise InputError(path, "not a regular file: the maps are read from a file only")
        if info.st_size > MAX_BYTES:
            raise InputError(path, f"{info.st_size} bytes: more than any maps file holds "
                             f"({MAX_BYTES} at most)")
        with os.fdopen(os.dup(fd), "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(path, f"cannot read the maps file ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    if len(data) > MAX_BYTES:  # grew while read
        raise InputError(path, f"more than any maps file holds ({MAX_BYTES} bytes at most)")
    return data


def _maps_in(path: Path, document: dict[str, Any]) -> dict[str, AxisMap]:
    listed, checksums = document.get("maps"), document.get("checksums")
    if not isinstance(listed, list) or not isinstance(checksums, dict):
        raise InputError(path, "the maps file needs 'maps' (a list) and 'checksums'")
    maps: dict[str, AxisMap] = {}
    for k, entry in enumerate(listed):
        if not isinstance(entry, dict):
            raise InputError(path, f"map {k + 1} is not a JSON object")
        m = AxisMap.from_json(entry, f"{path}: map {k + 1}")
        if m.axis not in AXES:
            raise InputError(path, f"map {k + 1} is of axis {m.axis!r}: the axes are "
                             f"{', '.join(AXES)}")
        if m.axis in maps:
            raise InputError(path, f"two maps of axis {m.axis}")
        if checksums.get(m.axis) != m.checksum():
            raise InputError(path, f"the map of axis {m.axis} does not match its checksum: "
                             "changed after ogacq wrote it; write it again with ogacq")
        largest = max((abs(v) for v in (*m.forward_mm, *m.reverse_mm)), default=0.0)
        if not largest <= MAX_MAP_MM:  # NaN included
            raise InputError(path, f"the map of axis {m.axis} reaches {largest:g} mm: beyond "
                             f"the {MAX_MAP_MM:g} mm any correction of this machine type "
                             "stays within (the offsets' gate); refused")
        maps[m.axis] = m
    if set(checksums) != set(maps):  # a checksum under another axis than its map's
        raise InputError(path, f"checksums of axes {', '.join(sorted(checksums))} for maps of "
                         f"{', '.join(sorted(maps)) or 'none'}")
    if list(maps) != [a for a in AXES if a in maps]:
        raise InputError(path, "the maps are not in axis order x, y, z as ogacq writes them")
    return maps


def _check_owner(table: MapsTable, owner: Owner) -> None:
    """The maps of this machine (name and serial as its machine file says), not those
    of another copied in."""
    named = table.owner
    if named != owner:
        said = f"{named[0] or 'no name'}, serial {named[1] or 'none'}" if named else \
            "no machine"
        raise InputError(table.path, f"the maps are those of {said}, not of this machine "
                         f"({owner[0] or 'no name'}, serial {owner[1] or 'none'}): maps are "
                         "applied to the machine they were measured on only")


def write_maps_table(path: str | Path, maps: Mapping[str, AxisMap], *, session: str = "",
                     action: str = "write", owner: Owner = ("", "")) -> MapsTable:
    """Replace the file atomically (temporary file, fsync, rename, fsync of the folder)
    and return it as read back from disk."""
    path = Path(path)
    ordered = {a: maps[a] for a in AXES if a in maps}
    content = json.dumps({
        "format": FORMAT, "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "session": session, "action": action,
        "machine": {"name": owner[0], "serial": owner[1]},
        "maps": [m.to_json() for m in ordered.values()],
        "checksums": {a: m.checksum() for a, m in ordered.items()}}, indent=1) + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, content.encode("utf-8"))  # its folder synced too
    log.info("maps file %s written (%s): %s", path, action, maps_checksum(ordered)[:12])
    return read_maps_table(path, owner=owner)
