import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest

from ogacq.io.machine_file import read_machine
from tests.balance import (
    file_totals,
    for_worker,
    known_seconds,
    longest_first,
    remember,
    whole_suite,
)

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "ogacq" / "examples" / "paper"

# ogacq's data folder (the default history, the wizard's inventory) is never the real
# home's: one for the whole run, made before any fixture can record into it, and each
# test its own (below), so that no test sees another's history. A history named in the
# environment of whoever runs the suite is not written to either.
_SUITE_HOME = Path(tempfile.mkdtemp(prefix="ogacq-test-home-"))


def pytest_configure(config: pytest.Config) -> None:
    os.environ["OGACQ_HOME"] = str(_SUITE_HOME)
    os.environ.pop("OGACQ_HISTORY", None)


def pytest_unconfigure(config: pytest.Config) -> None:
    shutil.rmtree(_SUITE_HOME, ignore_errors=True)


# The files longest first (tests/balance.py): both workers busy to the end of a run.
_durations: list[tuple[str, float]] = []


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items[:] = longest_first(items, known_seconds(config))


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node: Any) -> None:  # xdist's controller, per worker
    for_worker(node)


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    _durations.append((report.nodeid, report.duration))


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    if whole_suite(session.config, exitstatus):
        remember(session.config, file_totals(_durations))


@pytest.fixture(autouse=True)
def ogacq_home(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch,
               ) -> Path:
    """This test's own data folder (its default history.sqlite)."""
    home = tmp_path_factory.mktemp("ogacq-home")
    monkeypatch.setenv("OGACQ_HOME", str(home))
    monkeypatch.delenv("OGACQ_HISTORY", raising=False)
    return home


@pytest.fixture(autouse=True)
def one_command() -> None:
    """Each test a command of its own: the first verdict it prints is said in full
    (``ogacq/cli/verdict_text.py``: once a command, as ``run_app`` starts each)."""
    from ogacq.cli.verdict_text import new_command

    new_command()


@pytest.fixture(scope="session")
def paper_dir() -> Path:
    return PAPER


@pytest.fixture(scope="session")
def paper_machine():
    return read_machine(PAPER / "machine.toml")
