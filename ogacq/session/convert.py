"""Sessions to and from the readings CSV (INTERCHANGE.md), and to observations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ogacq.identify.observations import Observations, readings_observations
from ogacq.io.errors import InputError
from ogacq.io.machine_file import machine_from_mapping
from ogacq.io.tables import check_postures, read_readings, write_readings
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES
from ogacq.session.store import LoadedSession, SessionWriter


def machine_dict(machine: MachineSpec) -> dict:
    out = {"leg_length_mm": machine.leg_length_mm, "rho_min_mm": machine.rho_min_mm,
           "rho_max_mm": machine.rho_max_mm,
           "gauge_resolution_mm": machine.gauge_resolution_mm}
    if machine.gauge_repeatability_mm is not None:
        out["gauge_repeatability_mm"] = machine.gauge_repeatability_mm
    return out


def session_machine(session: LoadedSession) -> MachineSpec:
    return machine_from_mapping(session.header.get("machine", {}), session.path)


def session_layout(session: LoadedSession) -> tuple[ReadingsLayout, np.ndarray]:
    rows = session.readings
    if not rows:
        raise InputError(session.path, "the session holds no readings yet")
    layout = ReadingsLayout.build(
        q_mm=[r["q_mm"] for r in rows],
        leg=[AXES.index(r["leg"]) for r in rows],
        gauge_axis=[AXES.index(r["gauge_axis"]) for r in rows],
        t_s=[r["t_s"] for r in rows], cycle=[r["cycle"] for r in rows],
        tcp_mm=[r["tcp_mm"] for r in rows], approach=[r["approach"] for r in rows])
    return layout, np.array([r["reading_mm"] for r in rows])


def session_observations(session: LoadedSession, machine: MachineSpec | None = None,
                         ) -> Observations:
    layout, values = session_layout(session)
    return readings_observations(machine or session_machine(session), layout, values,
                                 str(session.path))


def export_readings(session: LoadedSession, path: str | Path) -> int:
    layout, values = session_layout(session)
    write_readings(path, layout, values)
    return len(values)


def import_readings(csv_path: str | Path, machine: MachineSpec, session_path: str | Path,
                    ) -> Path:
    """A session holding a readings CSV's rows, for tools that work on sessions."""
    table = read_readings(csv_path)
    check_postures(table, machine, csv_path)
    layout = table.layout()
    header = {"machine": machine_dict(machine), "station": {"imported_from": str(csv_path)},
              "plan": None}
    with SessionWriter.create(session_path, header) as writer:
        for k in range(len(layout)):
            leg, axis = AXES[layout.leg[k]], AXES[layout.gauge_axis[k]]
            writer.append("reading", step=f"import/{k + 1}", gauge=f"{axis}_{leg}", leg=leg,
                          gauge_axis=axis, cycle=int(layout.cycle[k]),
                          t_s=float(layout.t_s[k]), q_mm=layout.q_mm[k].tolist(),
                          tcp_mm=layout.tcp_mm[k].tolist(),
                          approach=layout.approach[k].tolist(),
                          reading_mm=float(table.reading_mm[k]))
        writer.append("end", status="complete")
    return Path(session_path)
