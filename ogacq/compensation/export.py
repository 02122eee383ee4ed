"""Every table format written into one folder, with the ISO 230-2 figures beside.

``export_tables(folder, maps)`` writes ``linuxcnc/``, ``fanuc/``, ``siemens/`` and
``csv/`` (each format's files, the figures in their comments or, for LinuxCNC
whose table file takes no comments, in the INI fragment beside it) and returns
what was written with each axis's figures before and after (predicted).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ogacq.compensation.fanuc import FanucOptions, fanuc_tables
from ogacq.compensation.linuxcnc import LinuxCncOptions, linuxcnc_tables
from ogacq.compensation.plain_csv import csv_tables
from ogacq.compensation.siemens import SiemensOptions, siemens_tables
from ogacq.compensation.tables import ControllerTables, TableError
from ogacq.model.axis_map import AxisMap

FORMATS = ("linuxcnc", "fanuc", "siemens", "csv")


@dataclass(frozen=True)
class Exported:
    format: str
    files: tuple[Path, ...]
    figures: dict[str, dict[str, Any]]  # axis -> {"before": ..., "after": ...}
    problem: str | None = None  # the map does not fit this format (nothing written)

    def to_json(self) -> dict[str, Any]:
        return {"format": self.format, "files": [str(f) for f in self.files],
                "figures": self.figures, "problem": self.problem}


def tables_of(fmt: str, maps: Mapping[str, AxisMap], title: str) -> list[ControllerTables]:
    """The format's tables: FANUC's twice, with the negative-direction table (3605#0)
    and with the backlash parameter 1851 instead, for a control without the option."""
    if fmt == "linuxcnc":
        return [linuxcnc_tables(maps, LinuxCncOptions(), title=title)]
    if fmt == "fanuc":
        return [fanuc_tables(maps, FanucOptions(), title=title),
                fanuc_tables(maps, FanucOptions(bidirectional=False), title=title)]
    if fmt == "siemens":
        return [siemens_tables(maps, SiemensOptions(), title=title)]
    if fmt == "csv":
        return [csv_tables(maps, title=title)]
    raise ValueError(f"unknown table format {fmt!r}; known: {', '.join(FORMATS)}")


def export_tables(folder: Path, maps: Mapping[str, AxisMap], *, title: str = "",
                  formats: tuple[str, ...] = FORMATS) -> list[Exported]:
    out = []
    for fmt in formats:
        try:
            variants = tables_of(fmt, maps, title)
        except TableError as exc:  # said, and the other formats still written
            out.append(Exported(fmt, (), {}, str(exc)))
            continue
        where = folder / fmt
        where.mkdir(parents=True, exist_ok=True)
        for tables in variants:
            written = []
            for name, text in tables.files.items():
                path = where / name
                path.write_text(text, encoding="utf-8")
                written.append(path)
            figures = {a: {"before": t.before().to_json(), "after": t.after().to_json()}
                       for a, t in tables.axes.items()}
            out.append(Exported(fmt, tuple(written), figures))
    return out
