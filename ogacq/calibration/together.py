"""The readings of several sessions of one machine, taken under different corrections,
fitted together.

Each session records the correction in force while it was measured: the joint
offsets the controller held (``offsets_in_force``: read after homing at each start),
the maps ogacq applied to every target (the maps file's checksum on the station, and
each move's ``commanded_mm``: the target the drive was actually sent). The joint is
where the drive was sent plus its own error there: with ``q = p - o`` (the drive's
raw position p being where the screw is, o the offset in force), a target c sent
under offsets o puts the screw at ``p = c + o``, which is ``c + o - o_ref`` in the
coordinate of a session run under ``o_ref``. So each reading's joint coordinate is
taken as the target sent, moved by the change of offsets since the reference
session, never the nominal target a map was meant to land it on: the fit then sees
the machine's whole error in the reference's frame, whatever the maps and offsets
were, and its joint offsets are the reference session's (what a write from it
corrects). The change of offsets is known exactly (each write is read back and
audited, each start records what the controller held), so no offset is fitted per
session.

A reading's target sent is the last move's ``commanded_mm`` before it (with maps
applied), else its ``q_mm`` (the target the controller took, rounded to its step):
the runner records both (``ogacq.protocol.runner``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ogacq.errors import InputError
from ogacq.identify.observations import Observations, readings_observations, readings_together
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES
from ogacq.session.convert import session_machine, session_observations
from ogacq.session.offsets_in_force import offsets_in_force
from ogacq.session.records import MoveRecord, ReadingRecord
from ogacq.session.store import LoadedSession


def sent_targets(session: LoadedSession) -> np.ndarray:
    """(n, 3) the target the drives were sent for each reading, in the session's order."""
    sent: tuple[float, ...] | None = None
    out = []
    for record in session.records:
        if isinstance(record, MoveRecord):
            sent = record.commanded_mm  # None: no map applied, the reading's q was sent
        elif isinstance(record, ReadingRecord):
            out.append(record.q_mm if sent is None else sent)
    return np.asarray(out, dtype=float).reshape(-1, 3)


def frame_shift_mm(session: LoadedSession, reference: LoadedSession) -> np.ndarray:
    """(3,) what moves ``session``'s joint coordinates into ``reference``'s: the
    offsets in force then less the reference's (``q_ref = q + o - o_ref``)."""
    shifts = []
    for s in (session, reference):
        held = offsets_in_force(s)
        if held.offsets_mm is None or not held.consistent:
            raise InputError(s.path, "the offsets the controller held are not recorded at "
                             "every start of this campaign (or changed between starts): "
                             "its readings cannot be put in another session's frame")
        shifts.append(np.array([held.offsets_mm[a] for a in AXES]))
    return shifts[0] - shifts[1]


def in_frame_of(session: LoadedSession, reference: LoadedSession) -> Observations:
    """``session``'s readings with each joint coordinate where its drive was sent, in
    ``reference``'s frame."""
    obs = session_observations(session, session_machine(reference))
    q = sent_targets(session) + frame_shift_mm(session, reference)
    lay = obs.layout
    layout = ReadingsLayout.build(q, lay.leg, lay.gauge_axis, lay.t_s, lay.cycle, lay.tcp_mm,
                                  lay.approach, lay.posture)
    return readings_observations(obs.machine, layout, obs.values, obs.source, obs.averaged,
                                 obs.averaged_sd_mm)


def observations_together(sessions: Sequence[LoadedSession]) -> Observations:
    """The readings of ``sessions`` as one set of observations, in the first's frame of
    offsets: the fit's joint offsets are relative to the offsets it ran with, and its
    errors are the machine's whole error, no map applied (a map a session ran with is
    in its targets sent, not in the fit)."""
    reference = sessions[0]
    return readings_together([in_frame_of(s, reference) for s in sessions],
                             " + ".join(str(s.path) for s in sessions))
