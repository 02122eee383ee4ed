"""What a 72-reading ``refit`` and ``diagnose`` import (issue 27's start-up): kept by
*what* is loaded, never by a timing. The modules named here are each milliseconds of
a short analysis: rich's tables under --json, numpy's masked arrays (np.unique's and
np.median's plain calls), OpenSSL's hashes, tempfile, the protocol for a readings
refit."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ogacq.io.tables import write_readings
from tests.diagnose.campaigns import layout, simulate
from tests.diagnose.test_diagnose_cli import MACHINE_TOML

GOLDEN_SESSION = Path(__file__).resolve().parents[1] / "golden" / "session.jsonl"

PROBE = """
import json, sys
from ogacq.cli.app import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""

# the page and its figures (matplotlib: most of a second) are the report's alone. Not
# tempfile: typer 0.29 switches pydantic's plugins off at its first option, whose loader
# imports importlib.metadata, and that tempfile (Python 3.11's importlib.resources); this
# machine's site loads it before any command, a fresh venv does not (seen by .ci/run there)
NEVER = ("numpy.ma", "numpy.typing", "hashlib", "matplotlib", "ogacq.report")


@pytest.fixture(scope="module")
def readings(tmp_path_factory):
    """The papers' plan, 3 cycles (72 readings), with two effects the offsets leave
    out: the diagnosis runs its whole search, the plans that would separate them
    and the scan that would show a map."""
    root = tmp_path_factory.mktemp("startup")
    (root / "m.toml").write_text(MACHINE_TOML)
    obs = simulate({"squareness.xy": 0.4, "backlash.z": 0.02}, 1,
                   lay=layout(cycles=3))
    assert len(obs) == 72
    write_readings(root / "r.csv", obs.layout, obs.values)
    return root


def run(*args: object, env: dict[str, str] | None = None) -> tuple[set[str], str]:
    """The modules loaded by the command, and what it printed."""
    proc = subprocess.run([sys.executable, "-c", PROBE, *map(str, args)], capture_output=True,
                          text=True, timeout=120, env=None if env is None else
                          {**os.environ, **env})
    assert proc.returncode == 0, proc.stderr
    *printed, last = proc.stdout.splitlines()
    out = json.loads(last)
    assert out["code"] == 0, proc.stderr
    return set(out["modules"]), "\n".join(printed)


def modules_after(*args: object) -> set[str]:
    return run(*args)[0]


def at_start() -> set[str]:
    """What the interpreter loads before any command (site and its .pth files: on
    some machines a CA bundle's loader brings tempfile and more): not the command's."""
    proc = subprocess.run([sys.executable, "-c", "import json, sys; "
                           "print(json.dumps(sorted(sys.modules)))"],
                          capture_output=True, text=True, timeout=60, check=True)
    return set(json.loads(proc.stdout))


def loaded(modules: set[str], prefixes: tuple[str, ...]) -> set[str]:
    modules = modules - at_start()
    return {m for m in modules if m.startswith(prefixes) and
            any(m == p or m.startswith(p + ".") for p in prefixes)}


def test_refit_of_readings(readings):
    as_json = modules_after("refit", readings / "r.csv", "-m", readings / "m.toml", "--json")
    assert not loaded(as_json, ("rich.table", "ogacq.protocol", "ogacq.diagnose", *NEVER))
    # its text: rich draws it, to a pipe as to a terminal
    to_pipe = modules_after("refit", readings / "r.csv", "-m", readings / "m.toml")
    assert "rich.table" in to_pipe  # the probe sees what the command loads
    assert not loaded(to_pipe, ("ogacq.protocol", *NEVER))


def test_diagnose_of_readings(readings):
    as_json, printed = run("diagnose", readings / "r.csv", "-m", readings / "m.toml",
                           "--json")
    # the whole diagnosis ran: effects found, a scan planned that would tell one from
    # a map along its axis
    diagnosis = json.loads(printed)
    assert diagnosis["effects"]
    assert any(p["measurement"] == "scan" for p in diagnosis["proposals"]), printed
    assert not loaded(as_json, ("rich.table", *NEVER))
    assert not loaded(modules_after("diagnose", readings / "r.csv", "-m",
                                    readings / "m.toml"), NEVER)


def test_a_session_warns_in_one_line(tmp_path):
    """A session's warning (a torn last record) on refit: one line, as every command
    prints a warning (the terminal's handler installed before that record)."""
    torn = tmp_path / "torn.jsonl"
    torn.write_bytes(GOLDEN_SESSION.read_bytes() + b'{"seq": 99, "kind": "rea')
    line = len(GOLDEN_SESSION.read_bytes().splitlines()) + 1
    proc = subprocess.run([sys.executable, "-m", "ogacq", "refit", torn, "--json"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == [
        f"ogacq: warning: {torn}:{line}: dropped a torn last record (24 bytes: "
        """'{"seq": 99, "kind": "rea')"""], proc.stderr
