"""Issue 35.6: the history's database layer is imported only when a history is used,
and then only the dialect in use: an SQLite history (the default) through the
standard library's sqlite3, SQLAlchemy (its URL parser) and psycopg for PostgreSQL
alone. ``diagnose SESSION --history none`` and ``ogacq run
--history none`` paid SQLAlchemy with both its dialects before reading ``none`` (about
60 % of the diagnosis's CPU). Kept by *what* is loaded, never by a timing, in the way
of tests/cli/test_startup_imports.py."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.cli.test_startup_imports import GOLDEN_SESSION, loaded, run
from tests.history.test_e2e import campaign

DATABASE = ("sqlalchemy",)
POSTGRESQL = ("sqlalchemy.dialects.postgresql", "psycopg", "psycopg2")


def test_diagnose_without_a_history_imports_no_database_layer(tmp_path):
    modules, _ = run("diagnose", GOLDEN_SESSION, "--history", "none", "--json",
                     env={"OGACQ_HOME": str(tmp_path / "home")})
    assert not loaded(modules, DATABASE)
    # nor what recording reads (the write-back audit, the drives' profiles behind it)
    assert not loaded(modules, ("ogacq.history.recording", "ogacq.writeback"))


@pytest.mark.parametrize("named", [True, False])
def test_diagnose_into_an_sqlite_history_imports_no_database_library(tmp_path, named):
    """Named (``--history FILE``) or the default (the data folder's ``history.sqlite``):
    recorded through sqlite3 alone (SQLAlchemy's import was ~0.17 s of CPU, most of a
    diagnosis's)."""
    home = tmp_path / "home"
    history = tmp_path / "h.sqlite" if named else home / "history.sqlite"
    option = ("--history", history) if named else ()
    modules, _ = run("diagnose", GOLDEN_SESSION, *option, "--json", env={"OGACQ_HOME": str(home)})
    assert loaded(modules, ("ogacq.history.store", "sqlite3"))  # it did record
    assert history.is_file()
    assert not loaded(modules, (*DATABASE, *POSTGRESQL))


def test_a_diagnosis_the_history_holds_already_reads_no_write_back_audit(tmp_path):
    """A finished campaign's diagnosis records no write-back: the audit's readers (and
    the drives' profiles behind them) are not imported to find it recorded, nor the
    record's types."""
    history = tmp_path / "h.sqlite"
    for _ in range(2):
        modules, _ = run("diagnose", GOLDEN_SESSION, "--history", history, "--json",
                         env={"OGACQ_HOME": str(tmp_path / "home")})
    assert loaded(modules, ("ogacq.history.store",))  # it did read the history
    assert not loaded(modules, ("ogacq.writeback",))
    # nor any record: the history is asked by the record's id (its building, the
    # uncertainty's Monte-Carlo, and reading one are a first diagnosis's alone)
    assert not loaded(modules, ("ogacq.record.calibration_record", "ogacq.record.sections",
                                "ogacq.uncertainty"))


def test_a_campaign_run_without_a_history_imports_no_database_layer(tmp_path):
    path = campaign(tmp_path / "c", 0)
    modules, _ = run("run", path, "--history", "none", "--json",
                     env={"OGACQ_HOME": str(tmp_path / "home")})
    assert (tmp_path / "c" / "session.jsonl").is_file()
    assert not loaded(modules, DATABASE)


def test_no_command_imports_the_database_layer_before_it_runs():
    """`ogacq history --help` (and every command's module) loads no SQLAlchemy: the
    history's types are plain data (``ogacq.history.entries``), its store opened when a
    history is read or written."""
    from ogacq.cli.command_table import COMMANDS, LazyGroupSpec

    modules = sorted({target.partition(":")[0] for spec in COMMANDS.values()
                      for target in (spec.commands.values() if isinstance(spec, LazyGroupSpec)
                                     else (spec.target,))})
    probe = (f"import json, sys\nimport {', '.join(modules)}\n"
             "print(json.dumps(sorted(sys.modules)))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, check=True)
    assert "ogacq.cli.history_cmd" in json.loads(done.stdout)  # the probe sees them
    assert not loaded(set(json.loads(done.stdout)), DATABASE)
