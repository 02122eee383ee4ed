"""What a calibration writes: the joint offsets of the diagnosis's final model, and
one error map per axis for what a table corrects.

The offsets are those of the final model (``writeback.evidence``), moved by the
constant each new map takes off (a map is zero at its reference forward: the
joint offset carries the rest; ``ogacq.compensation.effects``). The maps are the
diagnosis's maps and its compensable library effects, made into one per axis
without correcting anything twice (``ogacq.compensation.combine``), added to the
maps that were in force during the campaign (its readings show what they left).
Every table format is exported beside, with the ISO 230-2 figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq.calibration.maps import (
    compensable_effects,
    diagnosis_maps,
    model_effects,
    uncompensated_effects,
)
from ogacq.campaign import recorded_maps
from ogacq.compensation.combine import compensation
from ogacq.compensation.effects import effect_maps
from ogacq.compensation.export import export_tables
from ogacq.compensation.iso230 import map_figures
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.session.store import LoadedSession
from ogacq.writeback.evidence import Evidence, evidence_of

TABLES_FOLDER = "tables"


@dataclass(frozen=True)
class Compensation:
    """What the procedure will write, as its log records it."""

    evidence_session: Path
    maps: dict[str, AxisMap]  # axis -> the new map in force (only axes with something new)
    shift_mm: dict[str, float]  # added to each identified joint offset
    compensated: tuple[str, ...]  # library effects the maps correct
    uncompensated: tuple[str, ...]  # effects no table corrects: they stay
    diagnosis_maps: tuple[str, ...]  # what the diagnosis's maps were, in words
    in_force_checksum: str | None  # the maps the campaign ran with (None: none)
    offsets_mm: dict[str, float]  # the joint offsets the write corrects (shift included)
    offsets_std_mm: dict[str, float]
    effects: dict[str, dict[str, float]] = field(default_factory=dict)  # name -> value, std
    tables: list[dict[str, Any]] = field(default_factory=list)

    def figures_before(self) -> dict[str, dict[str, Any]]:
        return {a: map_figures(m).to_json() for a, m in self.maps.items()}

    def to_json(self) -> dict[str, Any]:
        return {"evidence_session": str(self.evidence_session),
                "maps": [m.to_json() for m in self.maps.values()],
                "shift_mm": self.shift_mm, "compensated": list(self.compensated),
                "uncompensated": list(self.uncompensated),
                "diagnosis_maps": list(self.diagnosis_maps),
                "in_force_checksum": self.in_force_checksum,
                "offsets_mm": self.offsets_mm, "offsets_std_mm": self.offsets_std_mm,
                "effects": self.effects, "tables": self.tables,
                "figures_before": self.figures_before()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Compensation:
        maps = {m.axis: m for m in (AxisMap.from_json(e) for e in d.get("maps") or ())}
        return cls(Path(d["evidence_session"]), maps, dict(d.get("shift_mm") or {}),
                   tuple(d.get("compensated") or ()), tuple(d.get("uncompensated") or ()),
                   tuple(d.get("diagnosis_maps") or ()), d.get("in_force_checksum"),
                   dict(d["offsets_mm"]), dict(d["offsets_std_mm"]),
                   dict(d.get("effects") or {}), list(d.get("tables") or []))


def in_force_maps(session: LoadedSession) -> tuple[dict[str, AxisMap], str | None]:
    """The maps the campaign ran with, by axis, and their checksum (None: none)."""
    recorded = recorded_maps(session)
    if not recorded:
        return {}, None
    from ogacq.writeback.maps_table import read_maps_table

    table = read_maps_table(recorded["file"])
    # the file may have changed since: the write's plan refuses that (stale); here the
    # maps are only what the readings are relative to, when they are still the same
    same = table.checksum == recorded.get("checksum")
    return (table.maps if same else {}), recorded.get("checksum")


def compensation_of(diagnosis: Diagnosis, session: LoadedSession, machine: MachineSpec,
                    ) -> Compensation:
    """The offsets and maps that correct what the diagnosis of ``session`` found."""
    effects = compensable_effects(diagnosis)
    found_maps = diagnosis_maps(diagnosis)
    in_force, checksum = in_force_maps(session)
    per_axis = compensation(found_maps, effect_maps(effects, machine), effects, in_force)
    shift = {a: per_axis[a].offset_shift_mm if a in per_axis else 0.0 for a in AXES}
    evidence = evidence_for(diagnosis, session, shift)
    return Compensation(
        session.path, {a: c.axis_map for a, c in per_axis.items()}, shift, tuple(effects),
        tuple(uncompensated_effects(diagnosis)),
        tuple(m.source or f"map of {m.axis}" for m in found_maps), checksum,
        dict(evidence.identified_mm), dict(evidence.std_mm),
        {n: {"value": e.value, "std": e.std} for n, e in model_effects(diagnosis).items()})


def evidence_for(diagnosis: Diagnosis, session: LoadedSession,
                 shift_mm: dict[str, float]) -> Evidence:
    """The write-back evidence of the diagnosis's final model: its joint offsets (plus
    the maps' constants), its verdict, and the effects that stay uncompensated."""
    stay = uncompensated_effects(diagnosis)
    effects = [e.name for e in diagnosis.effects]
    model = ("diagnosis: joint offsets with " + ", ".join(effects)) if effects \
        else "joint offsets"
    return evidence_of(session, diagnosis.final_fit, diagnosis.final, model, stay, shift_mm)


def export(folder: Path, comp: Compensation, title: str) -> list[dict[str, Any]]:
    """Every table format of the new maps into ``folder/tables``."""
    if not comp.maps:
        return []
    return [e.to_json() for e in export_tables(folder / TABLES_FOLDER, comp.maps, title=title)]
