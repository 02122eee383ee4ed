"""The machine file (TOML, INTERCHANGE.md): its schema, reading and writing.

Beside the INTERCHANGE geometry keys, optional identity and acceptance keys
(docs/calibration-record.md 1): ``name`` (default: the file's stem), ``serial``,
``leg_expansion_ppm_per_k`` and a ``[tolerances]`` table. A file without them
reads as before."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq_drivers.config_schema import Field, MapOf, Source, Table, dump, load, number, text
from ogacq.io.atomic import write_atomically
from ogacq.io.names import name_problem
from ogacq.io.toml_file import input_error, load_toml
from ogacq.model.machine import DECISION_RULES, SCREW_AXES, MachineSpec, Screw

if TYPE_CHECKING:
    from ogacq.model.tolerances import Tolerances

MAX_LENGTH_MM = 1e5  # 100 m: beyond any machine this tool calibrates
_LENGTH = number(maximum=MAX_LENGTH_MM)
# the twelve deviations a tolerance may name (docs/formats.md, deviations CSV)
DEVIATION_NAMES = tuple(f"d{axis}_{leg}{side}" for leg in "xyz" for axis in "xyz"
                        if axis != leg for side in "+-")
# The keys that say the geometry: what a reanalysis with another machine file compares.
GEOMETRY_KEYS = ("leg_length_mm", "rho_min_mm", "rho_max_mm", "gauge_resolution_mm",
                 "gauge_repeatability_mm")

_TOLERANCE = number(positive=True, maximum=MAX_LENGTH_MM)
_TOLERANCES = Table((
    Field("deviation_mm", _TOLERANCE, attr="default_mm"),
    Field("decision_rule", text(*DECISION_RULES)),
    *(Field(name, _TOLERANCE) for name in DEVIATION_NAMES),
), noun="key")

_SCREW = Table((
    Field("lead_mm", _LENGTH),
    Field("revolution_mm", _LENGTH),
), build=Screw, noun="key")

MACHINE_FILE = Table((
    Field("name", text()),
    Field("serial", text()),
    Field("leg_length_mm", _LENGTH, required=True),
    Field("rho_min_mm", _LENGTH, required=True),
    Field("rho_max_mm", _LENGTH, required=True),
    Field("gauge_resolution_mm", _LENGTH, required=True),
    Field("gauge_repeatability_mm", _LENGTH),
    # 0..1000 ppm/K covers every engineering material (invar ~1, steel 11.5,
    # aluminium 23, polymers ~100); beyond it the number is a mistake
    Field("leg_expansion_ppm_per_k", number(minimum=0.0, maximum=1000.0)),
    Field("tolerances", _TOLERANCES, decode=lambda table: _tolerances(table),
          encode=lambda tolerances: _tolerance_table(tolerances)),
    # [screws.x] lead_mm, revolution_mm: the periods of the drive's errors, which the
    # separating scan is designed to sample (ogacq.protocol.scan_design)
    Field("screws", MapOf(_SCREW, keys=SCREW_AXES, noun="axis"),
          decode=lambda table: tuple(sorted(table.items())), encode=dict),
))


def _tolerances(table: dict[str, Any]) -> Tolerances:
    from ogacq.model.tolerances import Tolerances  # a file stating them builds the class

    per = {k: v for k, v in table.items() if k in DEVIATION_NAMES}
    return Tolerances(table.get("default_mm"), per, table.get("decision_rule", "guard-band"))


def _tolerance_table(tolerances: Tolerances) -> dict[str, Any]:
    return {"default_mm": tolerances.default_mm, "decision_rule": tolerances.decision_rule,
            **tolerances.per_deviation}


def read_machine(path: str | Path) -> MachineSpec:
    values, source = load_toml(path, MACHINE_FILE, "the machine file")
    _check_identity(values, source)  # a file's; a session's recorded machine reads as it was
    stem = Path(str(path)).stem
    if "name" not in values:
        _check_stem(stem, source)
    return _machine(values, source, default_name=stem)


def machine_from_mapping(data: dict, path: str | Path = "<machine>") -> MachineSpec:
    """The machine a session header records, checked as a machine file is (a header
    written before the name was recorded names it after nothing: "")."""
    source = Source(str(path), input_error, what="the recorded machine")
    return _machine(load(MACHINE_FILE, data, source), source, default_name="")


def machine_dict(machine: MachineSpec) -> dict[str, Any]:
    """The machine as a session header records it: the machine file's keys."""
    out: dict[str, Any] = {"leg_length_mm": machine.leg_length_mm,
                           "rho_min_mm": machine.rho_min_mm,
                           "rho_max_mm": machine.rho_max_mm,
                           "gauge_resolution_mm": machine.gauge_resolution_mm}
    if machine.gauge_repeatability_mm is not None:
        out["gauge_repeatability_mm"] = machine.gauge_repeatability_mm
    if machine.name:
        out["name"] = machine.name
    if machine.serial:
        out["serial"] = machine.serial
    if machine.leg_expansion_ppm_per_k is not None:
        out["leg_expansion_ppm_per_k"] = machine.leg_expansion_ppm_per_k
    if machine.tolerances is not None:
        out["tolerances"] = machine.tolerances.to_json()
    if machine.screws:
        out["screws"] = {axis: {k: v for k, v in vars(screw).items() if v is not None}
                         for axis, screw in machine.screws}
    return out


def geometry_dict(machine: MachineSpec) -> dict[str, Any]:
    """The keys that say the geometry (identity and acceptance left out)."""
    return {k: v for k, v in machine_dict(machine).items() if k in GEOMETRY_KEYS}


def _check_identity(values: dict, source: Source) -> None:
    """A name and serial as the history, the record and every one-line output show
    them: not blank (a blank name records a machine named after nothing, which the
    history refuses), and a name (``ogacq.io.names``)."""
    for key in ("name", "serial"):
        value = values.get(key)
        if value is None:
            continue
        if not value.strip():
            raise source.fail((key,), "is blank: give the machine's " + (
                "name, or leave the key out for the file's name" if key == "name"
                else "serial number, or leave the key out"))
        problem = name_problem(value)
        if problem is not None:
            raise source.fail((key,), f"= {value[:60]!r} {problem}")


def _check_stem(stem: str, source: Source) -> None:
    """A file without ``name`` names the machine after its stem, which then goes where
    a name goes (the history, the record, the controller tables' titles): one printable
    line, as ``name`` must be (``name_problem``: its length too), and printable."""
    bad = next((c for c in stem if not c.isprintable()), None)
    problem = f"holds U+{ord(bad):04X}, which does not print" if bad is not None \
        else name_problem(stem)
    if problem is not None:
        raise source.fail((), "", f"has no name, and its file name {stem[:60]!r} {problem}: "
                          "give the machine's name (name = \"...\") or rename the file")


def _machine(values: dict, source: Source, default_name: str) -> MachineSpec:
    values = {"name": default_name, **values}
    try:
        return MachineSpec(**values)
    except ValueError as exc:
        problem = str(exc).split("; ")[0]
        if problem.startswith("screws."):  # names its own key: screws.x.lead_mm
            raise source.fail(tuple(problem.split(" ")[0].split(".")), "",
                              f"implausible: {problem}") from None
        key = next((f.key for f in MACHINE_FILE.fields if f.key in problem), "rho_max_mm")
        what = "implausible" if key.startswith("gauge_") else "impossible geometry"
        raise source.fail((key,), "", f"{what}: {problem}") from None


def machine_text(machine: MachineSpec, comment: str, *, footer: str = "") -> str:
    """The machine file of ``machine``, ``comment`` on top, ``footer`` (comment
    lines) at the end."""
    text_ = dump(MACHINE_FILE, machine, header=comment)
    if footer:
        text_ += "\n" + "\n".join(f"# {line}" if line else "#"
                                  for line in footer.splitlines()) + "\n"
    return text_


def write_machine(path: str | Path, machine: MachineSpec, comment: str) -> Path:
    path = Path(path)
    write_atomically(path, machine_text(machine, comment).encode("utf-8"))  # whole or nothing
    return path
