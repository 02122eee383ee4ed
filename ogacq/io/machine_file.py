"""The machine file (TOML, INTERCHANGE.md): its schema, reading and writing."""

from __future__ import annotations

from pathlib import Path

from ogacq_drivers.config_schema import Field, Source, Table, dump, load, number
from ogacq.io.toml_file import input_error, load_toml
from ogacq.model.machine import MachineSpec

MAX_LENGTH_MM = 1e5  # 100 m: beyond any machine this tool calibrates
_LENGTH = number(maximum=MAX_LENGTH_MM)

MACHINE_FILE = Table((
    Field("leg_length_mm", _LENGTH, required=True),
    Field("rho_min_mm", _LENGTH, required=True),
    Field("rho_max_mm", _LENGTH, required=True),
    Field("gauge_resolution_mm", _LENGTH, required=True),
    Field("gauge_repeatability_mm", _LENGTH),
))


def read_machine(path: str | Path) -> MachineSpec:
    values, source = load_toml(path, MACHINE_FILE, "the machine file")
    return _machine(values, source)


def machine_from_mapping(data: dict, path: str | Path = "<machine>") -> MachineSpec:
    """The machine a session header records, checked as a machine file is."""
    source = Source(str(path), input_error, what="the recorded machine")
    return _machine(load(MACHINE_FILE, data, source), source)


def _machine(values: dict, source: Source) -> MachineSpec:
    path = source.path
    try:
        return MachineSpec(**values, name=Path(str(path)).stem)
    except ValueError as exc:
        problem = str(exc).split("; ")[0]
        key = next((f.key for f in MACHINE_FILE.fields if f.key in problem), "rho_max_mm")
        raise source.fail((key,), "", f"impossible geometry: {problem}") from None


def machine_text(machine: MachineSpec, comment: str) -> str:
    """The machine file of ``machine``, ``comment`` on top."""
    return dump(MACHINE_FILE, machine, header=comment)


def write_machine(path: str | Path, machine: MachineSpec, comment: str) -> Path:
    path = Path(path)
    path.write_text(machine_text(machine, comment), encoding="utf-8")
    return path
