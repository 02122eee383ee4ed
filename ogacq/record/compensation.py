"""The record's ``compensation`` section (docs/calibration-record.md section 5): what
``ogacq calibrate`` wrote beside the joint offsets, declared once (``declared``).

Built by ``ogacq.calibration.procedure`` as JSON; read here for the page and anyone
else, so no reader goes through the object by hand.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ogacq.record.declared import Section

__all__ = ["CompensationSection", "Iso230Figures", "Iso230Stages", "MapWritten",
           "OffsetsCorrected", "TableExported"]


@dataclass(frozen=True)
class MapWritten(Section):
    """``maps.<axis>``: the map written for an axis."""

    source: str  # what the map corrects, in words ("encoder scale +408 ± 35 ppm (k = 2)")
    checksum: str  # the map's own (ogacq.model.axis_map)


@dataclass(frozen=True)
class Iso230Figures(Section):
    """An axis's ISO 230-2:2014 clause 3 figures in mm (``map_figures(...).to_json()``;
    its range, targets, up and down forms and ``s_source`` kept as written)."""

    A_mm: float | None = None  # bidirectional accuracy
    B_mm: float | None = None  # reversal value
    R_mm: float | None = None  # bidirectional repeatability
    E_mm: float | None = None  # bidirectional systematic deviation
    M_mm: float | None = None  # mean bidirectional positional deviation

    def in_order(self) -> tuple[float | None, ...]:
        """A, B, R, E, M (the order the page and the tables' comments give them)."""
        return (self.A_mm, self.B_mm, self.R_mm, self.E_mm, self.M_mm)


@dataclass(frozen=True)
class Iso230Stages(Section):
    """``iso230_2``: each axis's figures before the write and after (the validation)."""

    before: dict[str, Iso230Figures] = field(default_factory=dict)
    after: dict[str, Iso230Figures] = field(default_factory=dict)


@dataclass(frozen=True)
class OffsetsCorrected(Section):
    """``offsets``: the joint offsets the write corrects, and what the validation left."""

    corrected_mm: dict[str, float]
    left_mm: dict[str, float] | None  # None: no validation campaign


@dataclass(frozen=True)
class TableExported(Section):
    """One of ``tables``: a table format's files, or why it wrote none of some axes
    (``ogacq.compensation.export.Exported.to_json``)."""

    format: str
    files: tuple[str, ...] = ()
    figures: dict[str, Any] = field(default_factory=dict)  # axis -> before, after
    problem: str | None = None
    axes: dict[str, Any] = field(default_factory=dict)  # axis -> written, reason, ...


@dataclass(frozen=True)
class CompensationSection(Section):
    """``compensation``: the procedure, its outcome, the writes and restores (operation
    ids by target), the maps, the effects they correct and leave, the figures, the
    offsets and the tables exported."""

    procedure: str
    outcome: str  # validated, improved, restored, ...
    reason: str = ""
    writes: dict[str, str | None] = field(default_factory=dict)  # target -> operation
    restores: dict[str, str | None] = field(default_factory=dict)
    maps: dict[str, MapWritten] = field(default_factory=dict)
    compensated: tuple[str, ...] = ()
    uncompensated: tuple[str, ...] = ()
    iso230_2: Iso230Stages = field(default_factory=Iso230Stages)
    offsets: OffsetsCorrected | None = None
    tables: tuple[TableExported, ...] = ()
