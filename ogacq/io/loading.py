"""Turn a file given on the command line into observations to fit, with the machine
they belong to: a session's own, or the one the user names."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

from ogacq.identify.observations import (
    Observations,
    deviations_observations,
    readings_observations,
)
from ogacq.identify.plausibility import check_observations
from ogacq.io.errors import InputError
from ogacq.io.tables import check_table_postures, read_deviations, read_readings, sniff
from ogacq.model.machine import MachineSpec

log = logging.getLogger(__name__)


def load_observations(path: str | Path, machine: MachineSpec | None = None,
                      names: Sequence[str] = (), *, machine_path: str | Path | None = None,
                      other_geometry: bool = False) -> Observations:
    """Observations of ``path`` (readings CSV, deviations CSV or session), checked to be
    plausible millimetres and enough for ``names``.

    A session records its machine, which is used when ``machine`` is None; a
    ``machine`` that differs from it is refused (naming ``machine_path`` and the
    keys) unless ``other_geometry`` says the user means to reanalyse with it. A
    CSV records none: ``machine`` is required."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    kind = sniff(path)
    if kind == "session":
        obs = _session_observations(path, machine, machine_path, other_geometry)
    elif machine is None:
        raise InputError(path, f"a {kind} CSV does not record its machine: give the machine "
                               "file with --machine M.toml")
    elif kind == "deviations":
        obs = deviations_observations(machine, read_deviations(path), source=str(path))
    else:
        table = read_readings(path)
        check_table_postures(table, machine, path)
        obs = readings_observations(machine, table.layout(), table.reading_mm, str(path))
    check_observations(obs, names)
    return obs


def _session_observations(path: Path, machine: MachineSpec | None,
                          machine_path: str | Path | None, other_geometry: bool
                          ) -> Observations:
    from ogacq.io.machine_file import geometry_dict
    from ogacq.session.convert import session_machine, session_observations
    from ogacq.session.store import load_session

    session = load_session(path)
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
    return session_observations(session, machine or recorded)
