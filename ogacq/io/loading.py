"""Turn a file given on the command line into observations to fit, with the machine
they belong to: a session's own, or the one the user names; and, for a session,
what every output must say about it (partial, edited: ``ogacq.session.state``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.identify.observations import Observations, deviations_observations, readings_observations
from ogacq.identify.plausibility import check_observations
from ogacq.io.errors import InputError
from ogacq.io.tables import check_table_postures, read_deviations, read_readings, sniff
from ogacq.model.machine import MachineSpec

if TYPE_CHECKING:
    from ogacq.session.state import Completeness
    from ogacq.session.store import LoadedSession

@dataclass(frozen=True)
class LoadedInput:
    """What an analysis reads: the observations and, for a session, the session and how
    far its campaign went."""

    observations: Observations
    session: LoadedSession | None = None
    state: Completeness | None = None

    def notes(self) -> list[str]:
        """What the output says first (partial, edited, an older format); none for a CSV
        or a complete, untouched session."""
        if self.session is None:  # a CSV: the sessions' modules are not even imported
            return []
        from ogacq.session.state import session_notes

        return session_notes(self.session, self.state)

    def state_json(self) -> dict[str, Any]:
        """The keys a JSON output gains for the same (``partial``, ``edited``, ...)."""
        if self.session is None:
            return {}
        from ogacq.session.state import state_json

        return state_json(self.session, self.state)

    @property
    def partial(self) -> bool:
        return self.state is not None and not self.state.complete


def load_observations(path: str | Path, machine: MachineSpec | None = None,
                      names: Sequence[str] = (), *, machine_path: str | Path | None = None,
                      other_geometry: bool = False, partial: bool = False,
                      accept_edited: bool = False) -> Observations:
    """The observations of :func:`load_input`."""
    return load_input(path, machine, names, machine_path=machine_path,
                      other_geometry=other_geometry, partial=partial,
                      accept_edited=accept_edited).observations


def load_input(path: str | Path, machine: MachineSpec | None = None, names: Sequence[str] = (), *,
               machine_path: str | Path | None = None, other_geometry: bool = False,
               partial: bool = False, accept_edited: bool = False) -> LoadedInput:
    """Observations of ``path`` (readings CSV, deviations CSV or session), checked to be
    plausible millimetres and enough for ``names``.

    A session records its machine, which is used when ``machine`` is None; a
    ``machine`` that differs from it is refused (naming ``machine_path`` and the
    keys) unless ``other_geometry`` says the user means to reanalyse with it. A
    CSV records none: ``machine`` is required. A session whose campaign has not
    finished is refused unless ``partial``, one edited after it was written unless
    ``accept_edited`` (Refused, exit 4)."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    kind = sniff(path)
    if kind != "session" and machine is None:
        raise InputError(path, f"a {kind} CSV does not record its machine: give the machine "
                               "file with --machine M.toml")
    if kind == "deviations":
        assert machine is not None
        loaded = LoadedInput(deviations_observations(machine, read_deviations(path),
                                                     source=str(path)))
    elif kind == "readings":
        assert machine is not None
        table = read_readings(path)
        check_table_postures(table, machine, path)
        loaded = LoadedInput(readings_observations(machine, table.layout(), table.reading_mm,
                                                   str(path)))
    else:
        loaded = _session_input(path, machine, machine_path, other_geometry, partial, accept_edited)
    check_observations(loaded.observations, names)
    return loaded


def _session_input(path: Path, machine: MachineSpec | None, machine_path: str | Path | None,
                   other_geometry: bool, partial: bool, accept_edited: bool) -> LoadedInput:
    from ogacq.io.machine_file import geometry_dict
    from ogacq.session.convert import session_machine, session_observations
    from ogacq.session.state import require_complete
    from ogacq.session.store import load_session

    session = load_session(path, accept_edited=accept_edited)
    state = require_complete(session, partial)
    if session.warnings:  # logging imported where a file has something to say
        from ogacq.logs import logger

        log = logger(__name__)
        for warning in session.warnings:
            log.warning(warning)
    recorded = session_machine(session)
    if machine is not None and not other_geometry:
        given, own = geometry_dict(machine), geometry_dict(recorded)
        differing = [f"{k} {given.get(k, 'absent')} there, {own.get(k, 'absent')} in the "
                     "session" for k in dict.fromkeys([*own, *given]) if given.get(k) != own.get(k)]
        if differing:
            raise InputError(machine_path or "--machine", f"differs from the machine {path} was "
                             f"recorded with: {'; '.join(differing)}. Leave out --machine to "
                             "use the session's own, or add --other-geometry to reanalyse "
                             "with this one")
    return LoadedInput(session_observations(session, machine or recorded), session, state)
