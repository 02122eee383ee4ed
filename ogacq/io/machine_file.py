"""The machine file (TOML, INTERCHANGE.md)."""

from __future__ import annotations

import math
from pathlib import Path

from ogacq.io.errors import InputError
from ogacq.io.toml_file import line_of, read_toml
from ogacq.model.machine import MachineSpec

REQUIRED = ("leg_length_mm", "rho_min_mm", "rho_max_mm", "gauge_resolution_mm")
OPTIONAL = ("gauge_repeatability_mm",)
UNIT_SUFFIX = "_mm"
MAX_LENGTH_MM = 1e5  # 100 m: beyond any machine this tool calibrates


def read_machine(path: str | Path) -> MachineSpec:
    try:
        data, text = read_toml(path, "machine file")
    except FileNotFoundError:
        raise InputError(path, "no such machine file") from None
    return machine_from_mapping(data, path, text)


def machine_from_mapping(data: dict, path: str | Path = "<machine>", text: str = "",
                         ) -> MachineSpec:
    known = set(REQUIRED) | set(OPTIONAL)
    for key in data:
        if key in known:
            continue
        hint = ""
        stem = key.rsplit("_", 1)[0]
        if f"{stem}{UNIT_SUFFIX}" in known:
            hint = f"; lengths are in mm: did you mean {stem}{UNIT_SUFFIX}?"
        elif f"{key}{UNIT_SUFFIX}" in known:
            hint = f"; keys carry their unit: did you mean {key}{UNIT_SUFFIX}?"
        raise InputError(path, f"unknown key {key!r}{hint}", line_of(text, key))
    for key in REQUIRED:
        if key not in data:
            raise InputError(path, f"missing key {key!r} (required: {', '.join(REQUIRED)})")
    values: dict[str, float] = {}
    for key in (*REQUIRED, *OPTIONAL):
        if key not in data:
            continue
        value = data[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(path, f"{key} must be a number in mm, got {value!r}",
                             line_of(text, key))
        if not math.isfinite(value) or abs(value) > MAX_LENGTH_MM:
            raise InputError(path, f"{key} must be a finite length in mm (at most "
                             f"{MAX_LENGTH_MM:g}), got {value!r}", line_of(text, key))
        values[key] = float(value)
    try:
        return MachineSpec(
            leg_length_mm=values["leg_length_mm"], rho_min_mm=values["rho_min_mm"],
            rho_max_mm=values["rho_max_mm"], gauge_resolution_mm=values["gauge_resolution_mm"],
            gauge_repeatability_mm=values.get("gauge_repeatability_mm"),
            name=Path(str(path)).stem)
    except ValueError as exc:
        problem = str(exc).split("; ")[0]
        key = next((k for k in (*REQUIRED, *OPTIONAL) if k in problem), "rho_max_mm")
        raise InputError(path, f"impossible geometry: {problem}", line_of(text, key)) from None
