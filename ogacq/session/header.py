"""The session header: the first line of every session (docs/formats.md, "Sessions"),
as one typed value the report, the history, the plots and the write-back read.

What the header says is kept as written: ``from_json`` then ``to_json`` gives back the
same keys in the same order with the same values, so a session's header line, its
digest and the record's id (``ogacq.record.document``) do not depend on this type.
A key this version does not name (an older or newer session's, the line's ``type``)
or a named key holding a value of another type than this version writes
(a hand-edited header) is kept in ``extra`` and written back where it was; the named
attribute is then None, as for a key the session does not have.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ogacq.session.json_document import JsonObject, NamedJson

__all__ = ["SessionHeader"]


@dataclass(frozen=True)
class SessionHeader(NamedJson):
    """A session's first line. Every attribute is None when the session does not say it
    (an import from a CSV has no plan, a session from before issue 15 no identity)."""

    format: str | None = None  # "ogacq-session/1"
    integrity: str | None = None  # the seal the records carry (ogacq.session.seal)
    closing: str | None = None  # "closed": each writer's turn ends with a closed record
    software: str | None = None  # "ogacq 0.1.0"
    created: str | None = None  # when the session was started, ISO 8601 with offset
    machine: JsonObject | None = None  # the machine file as the campaign read it
    machine_file: str | None = None
    campaign_file: str | None = None
    simulated: bool | None = None  # a rehearsal on the simulator, never the machine's record
    station: JsonObject | None = None  # controller and gauges as opened (the first station)
    plan: JsonObject | None = None  # the protocol (ProtocolConfig.to_dict)
    identity: JsonObject | None = None  # machine name, serial, operator
    instruments: Sequence[Any] | None = None  # each gauge's certificate (objects)
    date: str | None = None  # the campaign's date (a simulated one for a rehearsal)
    simulator: JsonObject | None = None  # the simulator's settings (seed, effects, ...)
    wizard: JsonObject | None = None  # what the wizard recorded of its run
    procedure: JsonObject | None = None  # ogacq calibrate's log: its procedure
    kind: str | None = None  # "positioning": an axis's test by its scale, not the legs'
    positioning: JsonObject | None = None  # that test's plan (PositioningPlan.to_json)
    # every other key, and a named one of an unexpected type, as written
    extra: JsonObject = field(default_factory=dict)
    # the keys in the order written (empty: the named attributes given, then extra)
    order: tuple[str, ...] = ()

    @property
    def gauges(self) -> JsonObject:
        """The station's gauges as opened, by key (``{}`` when it names none)."""
        gauges = (self.station or {}).get("gauges")
        return gauges if isinstance(gauges, Mapping) else {}

