"""Sessions to and from the readings CSV (INTERCHANGE.md), and to observations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ogacq.identify.observations import Observations, readings_observations
from ogacq.io.errors import InputError
from ogacq.io.machine_file import machine_dict, machine_from_mapping
from ogacq.io.tables import check_table_postures, read_readings, write_readings
from ogacq.model.gauges import Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.session.records import EndRecord, ReadingRecord, Record
from ogacq.session.store import LoadedSession, write_session


def session_machine(session: LoadedSession) -> MachineSpec:
    return machine_from_mapping(dict(session.header.machine or {}), session.path)


def session_layout(session: LoadedSession) -> tuple[ReadingsLayout, np.ndarray]:
    rows = session.readings
    if not rows:
        raise InputError(session.path, "the session holds no readings yet")
    postures = [r.posture for r in rows]
    layout = ReadingsLayout.build(
        q_mm=[r.q_mm for r in rows], leg=[r.gauge.indices[1] for r in rows],
        gauge_axis=[r.gauge.indices[0] for r in rows], t_s=[r.t_s for r in rows],
        cycle=[r.cycle for r in rows], tcp_mm=[r.tcp_mm for r in rows],
        approach=[r.approach for r in rows],
        # imported readings carry none: the layout then finds them from the TCP
        posture=None if None in postures else postures)
    return layout, np.array([r.reading_mm for r in rows])


def session_observations(session: LoadedSession, machine: MachineSpec | None = None,
                         ) -> Observations:
    layout, values = session_layout(session)
    # how many gauge values each reading averaged and their scatter, where recorded
    rows = session.readings
    averaged = np.array([r.averaged or 0 for r in rows], dtype=int)
    spread = np.array([np.nan if r.averaged_sd_mm is None else r.averaged_sd_mm for r in rows])
    known = averaged.any()
    return readings_observations(machine or session_machine(session), layout, values,
                                 str(session.path), averaged if known else None,
                                 spread if known else None)


def export_readings(session: LoadedSession, path: str | Path) -> int:
    layout, values = session_layout(session)
    write_readings(path, layout, values)
    return len(values)


def import_readings(csv_path: str | Path, machine: MachineSpec, session_path: str | Path,
                    ) -> Path:
    """A session holding a readings CSV's rows, for tools that work on sessions."""
    table = read_readings(csv_path)
    check_table_postures(table, machine, csv_path)
    layout = table.layout()
    header = {"machine": machine_dict(machine), "station": {"imported_from": str(csv_path)},
              "plan": None}
    records: list[Record] = [ReadingRecord(
        step=f"import/{k + 1}", gauge=Gauge.at(layout.gauge_axis[k], layout.leg[k]),
        cycle=int(layout.cycle[k]), posture=None, t_s=float(layout.t_s[k]),
        q_mm=tuple(layout.q_mm[k].tolist()), tcp_mm=tuple(layout.tcp_mm[k].tolist()),
        approach=tuple(layout.approach[k].tolist()),
        reading_mm=float(table.reading_mm[k])) for k in range(len(layout))]
    records.append(EndRecord(status="complete", readings=len(layout)))
    # whole or not at all: a full disk leaves no half session in the way of a retry
    return write_session(session_path, header, records)
