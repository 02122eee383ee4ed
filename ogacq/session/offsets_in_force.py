"""The joint offsets the controller held while a campaign ran, as its session recorded
them: the station reads them after homing at every start (``ogacq.campaign.station``),
the header's station for the first start and a ``station`` record for each resume.

A joint offset is identified relative to these (``q = raw - o``), so they are what
turns an identified offset into the offset the machine needs (``o - identified``):
the write-back plans from them, and the history compares calibrations by them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ogacq.model.parameters import AXES
from ogacq.session.records import StationRecord
from ogacq.session.store import LoadedSession


@dataclass(frozen=True)
class OffsetsInForce:
    """``offsets_mm``: None when a start did not record them (a session written before
    they were, or a station that could not read them); ``consistent``: the same at
    every start (a resume after a change mixes two baselines)."""

    offsets_mm: dict[str, float] | None
    consistent: bool

    def to_json(self) -> dict[str, Any]:
        return {"offsets_mm": self.offsets_mm, "consistent": self.consistent}


def stations(session: LoadedSession) -> list[Mapping[str, Any]]:
    """The station of every start of the campaign: the header's, then each resume's."""
    return [dict(session.header.station or {}),
            *(r.description for r in session.of_type(StationRecord))]


def offsets_in_force(session: LoadedSession) -> OffsetsInForce:
    recorded = [_offsets(s) for s in stations(session)]
    known = [r for r in recorded if r is not None]
    consistent = all(all(abs(k[a] - known[0][a]) < 1e-9 for a in AXES) for k in known[1:])
    in_force = known[0] if known and len(known) == len(recorded) else None
    return OffsetsInForce(in_force, consistent)


def _offsets(station: Mapping[str, Any]) -> dict[str, float] | None:
    controller = station.get("controller")
    found = controller.get("offsets_mm") if isinstance(controller, Mapping) else None
    if not isinstance(found, Mapping) or any(a not in found for a in AXES):
        return None
    try:
        return {a: float(found[a]) for a in AXES}
    except (TypeError, ValueError):  # a hand-edited session: as not recorded
        return None
