"""Turn a file given on the command line into observations to fit."""

from __future__ import annotations

import logging
from pathlib import Path

from ogacq.identify.observations import (
    Observations,
    deviations_observations,
    readings_observations,
)
from ogacq.io.errors import InputError
from ogacq.io.tables import check_postures, read_deviations, read_readings, sniff
from ogacq.model.machine import MachineSpec

log = logging.getLogger(__name__)


def load_observations(path: str | Path, machine: MachineSpec) -> Observations:
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    kind = sniff(path)
    if kind == "deviations":
        return deviations_observations(machine, read_deviations(path), source=str(path))
    if kind == "readings":
        table = read_readings(path)
        check_postures(table, machine, path)
        return readings_observations(machine, table.layout(), table.reading_mm, str(path))
    from ogacq.session.convert import session_observations
    from ogacq.session.store import load_session

    session = load_session(path)
    for warning in session.warnings:
        log.warning(warning)
    return session_observations(session, machine)
