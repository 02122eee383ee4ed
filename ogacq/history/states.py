"""The machine's states over time: its offsets and its maps together.

Each write-back or restore of the offsets, and each write or restore of the maps
ogacq applies, leaves two states in the history (what it found, ``before``, and
what it left, ``after``). Folded in time order they give the machine's whole state
at each of them: the offsets the controller held and the maps in force then, so
any two can be compared (``ogacq history MACHINE --states --diff A B``). A
``calibrate`` event says what became of the write-backs it made: kept after a
validation, or restored, and why.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.errors import InputError
from ogacq.history.entries import Event, MapState, OffsetState
from ogacq.model.axis_map import AxisMap
from ogacq.model.gauges import AXES
from ogacq.writeback.outcome import WriteOutcome


@dataclass(frozen=True)
class MachineState:
    state_id: str  # the offsets (S-) or maps (M-) state that made it
    kind: str  # "offsets" or "maps"
    stage: str  # before, after
    at: str | None
    wall: float | None
    operation: str
    action: str  # write, restore
    status: str
    record_id: str
    offsets_mm: dict[str, float | None] | None  # None: not known yet at that time
    maps: dict[str, dict[str, Any]] | None  # axis -> ogacq-axis-map/1; None: not known
    maps_checksum: str | None
    fate: str | None = None  # what a calibrate procedure made of this write

    def as_mapping(self) -> dict[str, Any]:
        return {"state": self.state_id, "kind": self.kind, "stage": self.stage, "at": self.at,
                "operation": self.operation, "action": self.action, "status": self.status,
                "record": self.record_id, "offsets_mm": self.offsets_mm,
                "maps_checksum": self.maps_checksum,
                "maps_axes": sorted(self.maps) if self.maps is not None else None,
                "fate": self.fate}


def fates(events: Sequence[Event]) -> dict[str, str]:
    """operation -> what its calibrate procedure made of it, in words."""
    out: dict[str, str] = {}
    for event in events:
        d = event.details or {}
        name = d.get("procedure", event.record_id)
        outcome = d.get("outcome")
        reason = d.get("reason")
        for op in (d.get("writes") or {}).values():
            if op:
                out[str(op)] = (f"validated by calibrate {name}"
                                if outcome == WriteOutcome.VALIDATED
                                else f"restored by calibrate {name}: {reason}"
                                if outcome == WriteOutcome.RESTORED
                                else f"calibrate {name}: {outcome}" + (f" ({reason})"
                                                                         if reason else ""))
        for op in (d.get("restores") or {}).values():
            if op:
                out[str(op)] = f"restore by calibrate {name}: {reason}"
    return out


def timeline(offsets: Sequence[OffsetState], maps: Sequence[MapState],
             events: Sequence[Event] = ()) -> list[MachineState]:
    """Every state of either kind in time order, each with the machine's whole state."""
    rows: list[tuple[float, int, str, OffsetState | MapState]] = \
        [(v.wall or 0.0, v.stage != "before", v.state_id, v) for v in offsets] + \
        [(v.wall or 0.0, v.stage != "before", v.state_id, v) for v in maps]
    told = fates(events)
    held_offsets: dict[str, float | None] | None = None
    held_maps: dict[str, dict[str, Any]] | None = None
    held_checksum: str | None = None
    out = []
    for _, _, _, v in sorted(rows, key=lambda r: r[:3]):
        if isinstance(v, OffsetState):
            held_offsets, kind = dict(v.offsets_mm), "offsets"
        else:
            held_maps = {str(m.get("axis")): dict(m) for m in v.maps}
            held_checksum, kind = v.checksum, "maps"
        fate = told.get(v.operation) if v.stage == "after" else None
        out.append(MachineState(v.state_id, kind, v.stage, v.at, v.wall, v.operation,
                                v.action, v.status, v.record_id, held_offsets, held_maps,
                                held_checksum, fate))
    return out


def find(states: Sequence[MachineState], wanted: str) -> MachineState:
    for v in states:
        if v.state_id == wanted.strip():
            return v
    raise InputError(wanted, "no such state in this machine's history (`--states` lists "
                     "them)")


def _map_change(a: Mapping[str, Any] | None, b: Mapping[str, Any] | None) -> dict[str, Any]:
    if a is None and b is None:
        return {"change": "none"}
    ma = AxisMap.from_json(a) if a is not None else None
    mb = AxisMap.from_json(b) if b is not None else None
    out: dict[str, Any] = {"from": ma.checksum()[:12] if ma else None,
                           "to": mb.checksum()[:12] if mb else None}
    if ma is not None and mb is not None and ma.checksum() == mb.checksum():
        return {**out, "change": "none"}
    grid = np.unique(np.concatenate([np.asarray(m.positions_mm) for m in (ma, mb) if m]))

    def err(m: AxisMap | None, side: int) -> np.ndarray:
        return np.zeros_like(grid) if m is None else m.error_mm(grid, side)

    return {**out, "change": "added" if ma is None else "removed" if mb is None else "changed",
            "max_forward_change_mm": round(float(np.max(np.abs(err(mb, 1) - err(ma, 1)))), 7),
            "max_reverse_change_mm": round(float(np.max(np.abs(err(mb, -1) - err(ma, -1)))),
                                           7)}


def diff(a: MachineState, b: MachineState) -> dict[str, Any]:
    """What changed from state ``a`` to state ``b``: each offset, each axis's map."""
    offsets = {}
    for axis in AXES:
        va = (a.offsets_mm or {}).get(axis)
        vb = (b.offsets_mm or {}).get(axis)
        offsets[axis] = {"from": va, "to": vb,
                         "change": round(vb - va, 9) if va is not None and vb is not None
                         else None}
    maps = {axis: _map_change((a.maps or {}).get(axis), (b.maps or {}).get(axis))
            for axis in AXES}
    return {"from": a.as_mapping(), "to": b.as_mapping(), "offsets_mm": offsets,
            "maps": maps, "maps_known": a.maps is not None or b.maps is not None}
