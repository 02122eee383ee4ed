"""What a 72-reading ``refit`` and ``diagnose`` import (issue 27's start-up): kept by
*what* is loaded, never by a timing. The modules named here are each milliseconds of
a command whose whole run is about 0.15 s (refit) and 0.25 s (diagnose): the terminal
rendering (rich) under --json, numpy's masked arrays (np.unique's and np.median's
plain calls), OpenSSL's hashes, tempfile, the protocol for a readings refit, and logging
when a CSV is analysed (nothing logs)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ogacq.cli.fast_path import NO_FAST_PATH
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

# typer (and its click) too: refit and diagnose take the fast path (cli/fast_path.py)
NEVER = ("numpy.ma", "numpy.typing", "hashlib", "tempfile", "typer", "click")
# nothing logs when a CSV is analysed: logging waits for the first logger (ogacq/logs.py)
NOT_FOR_A_CSV = ("logging",)


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
    assert not loaded(as_json, ("rich", "ogacq.protocol", "ogacq.diagnose", *NEVER,
                                *NOT_FOR_A_CSV))
    # its text to a pipe: written as rich would, without rich (cli/text_out.py)
    to_pipe = modules_after("refit", readings / "r.csv", "-m", readings / "m.toml")
    assert not loaded(to_pipe, ("rich", "ogacq.protocol", *NEVER, *NOT_FOR_A_CSV))
    # to a terminal (FORCE_COLOR makes rich take the pipe for one): rich draws it
    on_terminal, _ = run("refit", readings / "r.csv", "-m", readings / "m.toml",
                         env={"FORCE_COLOR": "1"})
    assert "rich.table" in on_terminal  # the probe sees what the command loads
    assert not loaded(on_terminal, ("ogacq.protocol", *NEVER))


def test_diagnose_of_readings(readings):
    as_json, printed = run("diagnose", readings / "r.csv", "-m", readings / "m.toml",
                           "--json")
    # the whole diagnosis ran: effects found, a scan planned that would tell one from
    # a map along its axis
    diagnosis = json.loads(printed)
    assert diagnosis["effects"]
    assert any(p["measurement"] == "scan" for p in diagnosis["proposals"]), printed
    assert not loaded(as_json, ("rich", *NEVER, *NOT_FOR_A_CSV))
    # its text to a pipe, the search table shrunk to 80 columns: without rich
    assert not loaded(modules_after("diagnose", readings / "r.csv", "-m",
                                    readings / "m.toml"), ("rich", *NEVER, *NOT_FOR_A_CSV))


def test_a_session_warns_on_the_fast_path_as_on_typers(tmp_path):
    """A session's warning (a torn last record) on refit's fast path, where logging is
    imported only when the session's loader makes its logger: one line, as every
    command prints a warning (the terminal's handler installed before that record)."""
    torn = tmp_path / "torn.jsonl"
    torn.write_bytes(GOLDEN_SESSION.read_bytes() + b'{"seq": 99, "kind": "rea')
    line = len(GOLDEN_SESSION.read_bytes().splitlines()) + 1
    for env in ({}, {NO_FAST_PATH: "1"}):
        proc = subprocess.run([sys.executable, "-m", "ogacq", "refit", torn, "--json"],
                              capture_output=True, text=True, timeout=120,
                              env={**os.environ, **env})
        assert proc.returncode == 0, proc.stderr
        assert proc.stderr.splitlines() == [
            f"ogacq: warning: {torn}:{line}: dropped a torn last record (24 bytes: "
            """'{"seq": 99, "kind": "rea')"""], (env, proc.stderr)
