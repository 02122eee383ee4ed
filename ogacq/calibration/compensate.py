"""What a calibration writes: the joint offsets of the diagnosis's final model, and
one error map per axis for what a table corrects.

The offsets are those of the final model (``writeback.evidence``), moved by the
constant each new map takes off (a map is zero at its reference forward: the
joint offset carries the rest; ``ogacq.compensation.effects``). The maps are the
diagnosis's maps and its compensable library effects, made into one per axis
without correcting anything twice (``ogacq.compensation.combine``), added to the
maps that were in force during the campaign (its readings show what they left).
Every table format is exported beside, with the ISO 230-2 figures.

The campaign identified the maps in its controller coordinate, that of the offsets
then in force. The offsets written beside them move that coordinate along the
screws (``q = p - o``, the drive's raw position p being where the screw is): the
joint at q then is at ``q + s`` after, s = o_then - o_written. So each map is
written moved by s (a screw error of pitch P left where it was is off by
``2 pi s / P`` of phase: a joint offset of 1.24 mm leaves 39 % of a 20 mm pitch's
error in place), zero again at its reference, its new constant added to the offset
(which moves s by as much: a fixed point, reached in a pass or two, a map's slope
being a few um per mm). A map in force on an axis whose offset changes is moved too.
The maps are tabulated from the diagnosis's fitted shapes over the whole travel of
the new coordinate, beyond the readings where needed (a scan stops short of the
travel's ends, and the move shifts them): a table holding its end values there would
leave the error of the last millimetres in place, where the papers' postures read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ogacq.calibration.maps import (
    compensable_effects,
    diagnosis_maps,
    model_effects,
    uncompensated_effects,
)
from ogacq.calibration.scale_map import ScaleFit
from ogacq.campaign.run import recorded_maps
from ogacq.compensation.combine import compensation, with_offsets
from ogacq.compensation.effects import effect_maps
from ogacq.compensation.export import within_its_band
from ogacq.compensation.iso230 import map_figures
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.session.store import LoadedSession
from ogacq.writeback.evidence import Evidence, evidence_of

TABLES_FOLDER = "tables"
Register = Callable[[float], float]  # an offset as the controller stores it


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
    # the diagnosis's maps not applied, each with why (``export.within_its_band``)
    not_applied: tuple[str, ...] = ()

    def figures_before(self) -> dict[str, dict[str, Any]]:
        return {a: map_figures(m).to_json() for a, m in self.maps.items()}

    def to_json(self) -> dict[str, Any]:
        """Every field in its order (a tuple as a list), then the figures before."""
        out = {f.name: list(v) if isinstance(v := getattr(self, f.name), tuple) else v
               for f in fields(self)}
        out.update(evidence_session=str(self.evidence_session),
                   maps=[m.to_json() for m in self.maps.values()])
        return {**out, "figures_before": self.figures_before()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Compensation:
        maps = {m.axis: m for m in (AxisMap.from_json(e) for e in d.get("maps") or ())}
        return cls(Path(d["evidence_session"]), maps, dict(d.get("shift_mm") or {}),
                   tuple(d.get("compensated") or ()), tuple(d.get("uncompensated") or ()),
                   tuple(d.get("diagnosis_maps") or ()), d.get("in_force_checksum"),
                   dict(d["offsets_mm"]), dict(d["offsets_std_mm"]),
                   dict(d.get("effects") or {}), list(d.get("tables") or []),
                   tuple(d.get("not_applied") or ()))


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
                    register: Register | None = None,
                    scales: Mapping[str, ScaleFit] | None = None) -> Compensation:
    """The offsets and maps that correct what the diagnosis of ``session`` found, the
    maps in the controller coordinate the offsets make. ``register``: the value the
    controller stores for an offset (its step); None: as given. ``scales``: what each
    axis scale measured before (``ogacq.calibration.scale_map``), in the campaign's
    coordinate: on its axis, the cyclic error it found is the map instead of the
    diagnosis's, and where it found nothing, no map is (the scale reads the joint over
    its whole travel, the legs' gauges over a sixth of it). The joint offsets stay the
    legs' (their diagnosis made with the scales' maps known, ``with_scale_maps``), the
    maps' values where the offsets' zero will be added to them, as a diagnosis's are:
    the scale reads up to a constant."""
    effects = compensable_effects(diagnosis)
    in_force, checksum = in_force_maps(session)
    # tabulated over the travel the offsets make, zero where their zero will be
    spans, zero_at = _spans(diagnosis, machine)
    found, taken, not_applied = _along(diagnosis, scales or {}, spans, zero_at)
    per_axis = compensation(found, effect_maps(effects, machine, spans=spans,
                                               references=zero_at), effects, in_force)
    shift = {a: (per_axis[a].offset_shift_mm if a in per_axis else 0.0) + taken[a]
             for a in AXES}
    campaign_maps = {**{a: m for a, m in in_force.items() if a not in per_axis},
                     **{a: c.axis_map for a, c in per_axis.items()}}
    maps, constants, evidence = _with_offsets(diagnosis, session, campaign_maps, shift,
                                              register, new=set(per_axis))
    return Compensation(
        session.path, {a: maps[a] for a in AXES if a in maps},
        {a: shift[a] + constants.get(a, 0.0) for a in AXES}, tuple(effects),
        tuple(uncompensated_effects(diagnosis)),
        tuple(m.source or f"map of {m.axis}" for m in diagnosis_maps(diagnosis)), checksum,
        dict(evidence.identified_mm), dict(evidence.std_mm),
        {n: {"value": e.value, "std": e.std} for n, e in model_effects(diagnosis).items()},
        not_applied=not_applied)


def _along(diagnosis: Diagnosis, scales: Mapping[str, ScaleFit],
           spans: dict[str, tuple[float, float]], zero_at: dict[str, float],
           ) -> tuple[tuple[AxisMap, ...], dict[str, float], tuple[str, ...]]:
    """The maps along the axes, tabulated over ``spans`` and zero at ``zero_at``: the
    diagnosis's, but where a scale measured its axis the scale's; and per axis the
    maps' value at ``zero_at``, which goes to the offset (a diagnosis's map, fitted zero
    at its reference, stays in the offset where a scale's replaces it: the offsets were
    identified with it); and why a diagnosis's map is not applied, where one is not."""
    measured = {a for a, f in scales.items() if f.found is not None or f.flat}
    by_scale = {a: f.found for a, f in scales.items() if f.found is not None}
    # a map its own band could hold from nothing is not applied: the maps file would
    # correct by it what no table format writes (``export.within_its_band``)
    legs = [m for m in diagnosis.maps_over(spans, zero_at) if m.axis not in measured]
    why_not = {m.axis: within_its_band(m) for m in legs}
    found = tuple(m for m in legs if why_not[m.axis] is None) \
        + tuple(by_scale[a].over(spans[a], zero_at[a]) for a in sorted(by_scale))
    taken = {a: diagnosis.map_value_at(a, zero_at[a]) + (
        float(by_scale[a].error_mm(np.array([zero_at[a]]))[0]) if a in by_scale else 0.0)
        for a in AXES}
    return found, taken, tuple(f"axis {a}: {w}" for a, w in why_not.items() if w)


# How far beyond the travel moved by the final model's joint offsets the maps are
# tabulated: the maps' constants and the register's step move the offsets by a few
# micrometres more. No source: a margin.
SPAN_MARGIN_MM = 0.1
# Where the maps written are zero: the controller's zero, the reference position of the
# tables written from them (FANUC's 3620, Siemens' reference point: ogacq/compensation).
MAP_REFERENCE_MM = 0.0
FIXED_POINT_PASSES = 4
SAME_MOVE_MM = 1e-7  # far below any register's step and any map's meaning


def _spans(diagnosis: Diagnosis, machine: MachineSpec,
           ) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """Per axis, the campaign's q the travel covers once the final model's joint offsets
    are written (the joint at q then at q + drho after), and the q that becomes the
    reference (MAP_REFERENCE_MM after)."""
    spans, zero_at = {}, {}
    for a in AXES:
        drho = diagnosis.final_fit.value(f"joint_offset.{a}")
        spans[a] = (machine.rho_min_mm - drho - SPAN_MARGIN_MM,
                    machine.rho_max_mm - drho + SPAN_MARGIN_MM)
        zero_at[a] = MAP_REFERENCE_MM - drho
    return spans, zero_at


def coordinate_moves(evidence: Evidence, register: Register | None = None,
                     ) -> dict[str, float]:
    """Per axis, how far the offsets written move the controller coordinate: the joint
    at q during the campaign is at q + s after, s = o_then - o_written (``q = p - o``),
    o_written = o_then - drho as the register stores it (``writeback.policy``)."""
    then = evidence.in_force_mm or dict.fromkeys(AXES, 0.0)
    store = register or (lambda v: v)
    return {a: then[a] - store(then[a] - evidence.identified_mm[a]) for a in AXES}


def _with_offsets(diagnosis: Diagnosis, session: LoadedSession,
                  campaign_maps: dict[str, AxisMap], shift: dict[str, float],
                  register: Register | None, new: set[str],
                  ) -> tuple[dict[str, AxisMap], dict[str, float], Evidence]:
    """The maps moved with the offsets written beside them (``combine.with_offsets``),
    their new constants (to add to the offsets) and the evidence with those; a map in
    force that nothing new changes, only where its offset moves."""
    constants: dict[str, float] = {}
    moves: dict[str, float] | None = None
    maps: dict[str, AxisMap] = {}
    for _ in range(FIXED_POINT_PASSES):
        evidence = evidence_for(diagnosis, session,
                                {a: shift[a] + constants.get(a, 0.0) for a in AXES})
        now = coordinate_moves(evidence, register)
        if moves is not None and all(abs(now[a] - moves[a]) <= SAME_MOVE_MM for a in AXES):
            break
        moves = now
        maps, constants = {}, {}
        for a, m in campaign_maps.items():
            if a in new or moves[a] != 0.0:  # one in force stays where its offset stays
                maps[a], constants[a] = with_offsets(m, moves[a], MAP_REFERENCE_MM)
    return maps, constants, evidence


def evidence_for(diagnosis: Diagnosis, session: LoadedSession,
                 shift_mm: dict[str, float]) -> Evidence:
    """The write-back evidence of the diagnosis's final model: its joint offsets (plus
    the maps' constants), its verdict, and the effects that stay uncompensated."""
    stay = uncompensated_effects(diagnosis)
    effects = [e.name for e in diagnosis.effects]
    model = ("diagnosis: joint offsets with " + ", ".join(effects)) if effects \
        else "joint offsets"
    return evidence_of(session, diagnosis.final_fit, diagnosis.final, model, stay, shift_mm)
