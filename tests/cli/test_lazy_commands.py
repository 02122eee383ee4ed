"""The app imports a command's module only when that command runs: one command's
start-up does not pay for the others (the simulator, the wizard, the report's
matplotlib and jinja2)."""

from __future__ import annotations

import gc
import json
import subprocess
import sys

from ogacq.cli.app import OgacqCommands
from ogacq.cli.lazy import (
    LazyCommandSpec,
    LazyCommandTable,
    LazyGroupSpec,
    freeze_once,
    import_target,
    one_paragraph_lines,
)

PROBE = """
import json, sys
from ogacq.cli.app import main
main(sys.argv[1:])
print(json.dumps(sorted(m for m in sys.modules if m.startswith(("ogacq", "ogacq_drivers", "jinja2",
                                                                 "matplotlib")))))
"""


def modules_after(*args: str) -> set[str]:
    proc = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return set(json.loads(proc.stdout.splitlines()[-1]))


def command_modules() -> set[str]:
    targets = []
    for target in OgacqCommands.table.values():
        targets += target.commands.values() if isinstance(target, LazyGroupSpec) \
            else [target.target if isinstance(target, LazyCommandSpec) else target]
    return {t.partition(":")[0] for t in targets}


def test_one_command_imports_its_own_module_only():
    loaded = modules_after("refit", "--help")
    assert loaded & command_modules() == {"ogacq.cli.refit_cmd"}
    assert not {m for m in loaded if m.startswith(("ogacq_drivers.sim", "ogacq.cli.wizard",
                                                    "jinja2", "matplotlib"))}


def test_the_help_lists_every_command_without_importing_one():
    loaded = modules_after("--help")
    assert not loaded & command_modules()
    assert not {m for m in loaded if m.startswith((
        "ogacq_drivers.axes", "ogacq_drivers.indicators", "ogacq_drivers.sim", "ogacq.model",
        "jinja2", "matplotlib"))}


def test_each_summary_is_its_commands_first_paragraph():
    """The table's summary is what the help lists in place of the docstring: the two
    must not drift apart."""
    for name, spec in OgacqCommands.table.items():
        if isinstance(spec, LazyCommandSpec):
            doc = one_paragraph_lines(import_target(spec.target).__doc__) or ""
            assert spec.summary == doc.split("\n\n")[0], name


def test_a_command_is_imported_with_the_collector_paused_then_frozen(tmp_path, monkeypatch):
    """Its imports trigger no collection (each would scan the whole heap for nothing,
    ~10 % of a short diagnose's CPU), its objects are frozen out of later ones, and the
    collector runs again for the command itself."""
    (tmp_path / "throwaway_cmd.py").write_text(
        'import gc\nCOLLECTING = gc.isenabled()\n\n\ndef command() -> None:\n    """Do."""\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    table = LazyCommandTable({"throwaway": LazyCommandSpec("throwaway_cmd:command", "Do.")}, {})
    other = LazyCommandTable({"other": LazyCommandSpec("throwaway_cmd:command", "Do.")}, {})
    freeze_once.cache_clear()  # as in a new process
    frozen = gc.get_freeze_count()
    try:
        assert table["throwaway"].name == "throwaway"
        assert sys.modules["throwaway_cmd"].COLLECTING is False
        assert gc.isenabled()
        assert gc.get_freeze_count() > frozen
        # once per process: a second command built freezes nothing more (the garbage a
        # process running many commands, the tests, holds is not pinned at each)
        gc.unfreeze()
        assert other["other"].name == "other" and gc.get_freeze_count() == 0
    finally:
        gc.unfreeze()
        sys.modules.pop("throwaway_cmd", None)
