"""The import layers: ``drivers`` never imports ``ogacq``, no module imports a layer
above its own, and the packages of one layer import each other one way only. And
one module, the station, opens devices and starts the simulator.

The source is read with ``ast``, nothing is imported: imports inside functions and
under ``TYPE_CHECKING`` count too, since they are dependencies all the same.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"ogacq_drivers": "drivers", "ogacq": "ogacq"}  # installed name -> folder

# Lowest first. A module belongs to the longest entry naming it or a package above it
# (a bare package name, "ogacq", names its __init__ only). A module may import its own
# layer and those below; within a layer, the entries must not import each other in a
# cycle. Entries are packages, except where a package spans layers:
# - ogacq.io: its error type and TOML reading are the ground everything reads files
#   with (the package as such sits there); machine files need the model; tables and
#   loading build observations (ogacq.identify) and sessions.
# - ogacq.protocol.plan: the plan is what identification, accuracy prediction and
#   separation derive their layouts of readings from; the runner executing it records
#   into sessions, so the rest of ogacq.protocol sits with the session.
# - ogacq.writeback.table, ogacq.writeback.maps_table, ogacq.writeback.endpoint_lock: the
#   offset table, the maps file and the lock on a controller and its maps file: the maps
#   file, opened with the controller by the station and loaded by every campaign,
#   while the rest of writeback decides from finished campaigns. And
#   ogacq.writeback.outcome, the words of the audit trail and of calibrate's end, which
#   the campaigns and the history read in sessions and records.
LAYERS: list[tuple[str, ...]] = [
    ("ogacq_drivers", "ogacq_drivers.errors", "ogacq_drivers.config_schema",
     "ogacq_drivers.atomic", "ogacq_drivers.threads"),
    ("ogacq_drivers.link", "ogacq_drivers.usb_net", "ogacq_drivers.usb_link",
     "ogacq_drivers.input_link"),
    ("ogacq_drivers.axes", "ogacq_drivers.indicators"),
    ("ogacq_drivers.sim",),  # device emulators speaking the wire protocols
    ("ogacq", "ogacq.errors", "ogacq.logs", "ogacq.io", "ogacq.io.errors", "ogacq.io.text",
     "ogacq.io.toml_file"),
    ("ogacq.model",),
    ("ogacq.protocol.plan",),  # the one plan: every layout of readings derives from it
    # computed from the model alone, and the files read without a campaign
    ("ogacq.identify", "ogacq.sim", "ogacq.io.machine_file", "ogacq.writeback.table",
     "ogacq.writeback.maps_table", "ogacq.writeback.endpoint_lock", "ogacq.writeback.outcome",
     "ogacq.uncertainty", "ogacq.compensation"),
    ("ogacq.protocol", "ogacq.session", "ogacq.io.tables", "ogacq.campaign.campaign_file",
     "ogacq.campaign.templates", "ogacq.record", "ogacq.record.context", "ogacq.history"),
    ("ogacq.io.loading", "ogacq.campaign.station", "ogacq.diagnose"),
    ("ogacq.campaign",),  # the run, traceability and the instruments inventory
    ("ogacq.writeback", "ogacq.report"),
    # the record: the campaign, its uncertainty, its write-backs, its report data
    ("ogacq.record.document", "ogacq.record.evaluation", "ogacq.history.recording",
     "ogacq.history.earlier"),
    # calibrate's procedure: campaigns, diagnoses, write-backs and the record, in order
    ("ogacq.calibration",),
    ("ogacq.cli", "ogacq.__main__"),
]
LEVEL = {entry: level for level, entries in enumerate(LAYERS) for entry in entries}


@cache
def modules() -> dict[str, Path]:
    """Every module of the project by dotted name (a package by its __init__)."""
    found: dict[str, Path] = {}
    for package, folder in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = (package, *path.relative_to(ROOT / folder).with_suffix("").parts)
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def project_module(name: str) -> str | None:
    """The project module an imported name lives in (``a.b.C`` -> ``a.b``), if any."""
    while name and name not in modules():
        name = name.rpartition(".")[0]
    return name or None


@cache
def imported_names(module: str) -> frozenset[str]:
    """Every dotted name ``module`` imports (``from a.b import C`` gives ``a.b.C``),
    wherever in the file it does."""
    path = modules()[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([node.module] if node.module else [])])
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return frozenset(names)


def imports_of(module: str) -> frozenset[str]:
    """The project modules ``module`` imports."""
    found = {project_module(name) for name in imported_names(module)}
    return frozenset(m for m in found if m is not None and m != module)


def entry_of(module: str) -> str | None:
    """The LAYERS entry a module belongs to."""
    matches = [e for e in LEVEL if module == e or (module.startswith(e + ".")
                                                   and e not in PACKAGES)]
    return max(matches, key=len, default=None)


def test_every_module_and_entry_is_placed():
    """A new module outside every entry must be given its layer; a stale entry goes."""
    assert "ogacq_drivers.link" in modules() and "ogacq.cli.app" in modules()
    unplaced = sorted(m for m in modules() if entry_of(m) is None)
    assert not unplaced, f"place these modules in LAYERS: {unplaced}"
    stale = sorted(e for e in LEVEL if not any(entry_of(m) == e for m in modules()))
    assert not stale, f"LAYERS names modules that are gone: {stale}"


def test_drivers_never_import_ogacq():
    offending = {m: sorted(t for t in imports_of(m) if t.split(".")[0] == "ogacq")
                 for m in modules() if m.split(".")[0] == "ogacq_drivers"}
    assert not {m: t for m, t in offending.items() if t}


def test_no_module_imports_a_higher_layer():
    upward = [f"{m} (layer {LEVEL[entry_of(m)]}) imports {t} (layer {LEVEL[entry_of(t)]})"
              for m in sorted(modules()) for t in sorted(imports_of(m))
              if LEVEL[entry_of(t)] > LEVEL[entry_of(m)]]
    assert not upward, "\n".join(upward)


def test_no_import_cycle_between_packages():
    """Between the entries of LAYERS (packages, mostly): an edge set without a cycle."""
    edges: dict[str, set[str]] = {e: set() for e in LEVEL}
    for m in modules():
        edges[entry_of(m)].update(entry_of(t) for t in imports_of(m))
    for entry in edges:
        edges[entry].discard(entry)
    cycle = _a_cycle(edges)
    assert cycle is None, " -> ".join(cycle or [])


def _a_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph, as a closed path, or None (depth-first search)."""
    done: set[str] = set()
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        if node in path:
            return path[path.index(node):] + [node]
        if node in done:
            return None
        path.append(node)
        for target in sorted(edges[node]):
            if (cycle := visit(target)) is not None:
                return cycle
        path.pop()
        done.add(node)
        return None

    return next((c for c in map(visit, sorted(edges)) if c is not None), None)


def test_the_cycle_finder_finds_cycles():
    """The check above would see a cycle if there were one."""
    assert _a_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _a_cycle({"a": {"b"}, "b": set()}) is None


# What opens a device or starts the simulator; campaigns, the wizard and `ogacq sim`
# reach them through the station, so every endpoint gets the campaign's settings.
ENDPOINT_OPENERS = ("ogacq_drivers.indicators.open_indicator", "ogacq_drivers.link.open_link",
                    "ogacq_drivers.axes.modbus_link.ModbusLink", "ogacq.sim.stack.SimulatorConfig")


def test_only_the_station_opens_endpoints():
    openers = {m: sorted(set(imported_names(m)) & set(ENDPOINT_OPENERS))
               for m in modules() if m.startswith("ogacq.") and entry_of(m) != "ogacq.sim"}
    assert {m: names for m, names in openers.items() if names} == \
        {"ogacq.campaign.station": sorted(ENDPOINT_OPENERS)}


# The terminal's libraries: arguments (typer, click), prompts and rendering (rich).
TERMINAL = ("typer", "click", "rich")


def test_only_the_command_line_talks_to_the_terminal():
    """Domain code lives below ogacq.cli, which only asks, calls and renders: no other
    module imports the command line's libraries."""
    outside = {m: sorted(n for n in imported_names(m) if n.split(".")[0] in TERMINAL)
               for m in modules() if entry_of(m) not in ("ogacq.cli", "ogacq.__main__")}
    assert not {m: names for m, names in outside.items() if names}
    assert any(n.split(".")[0] == "typer" for n in imported_names("ogacq.cli.typer_app"))
