from __future__ import annotations

import itertools
import os

import pytest

from tests.history.postgres import Server, binaries, running_server

_names = itertools.count(1)


@pytest.fixture(scope="session")
def postgres_server() -> Server:
    """One PostgreSQL server for the whole test session, started by the first test that
    asks for it. Skipped only where its binaries are missing outside CI (CI=true
    installs them: there it must run)."""
    if binaries() is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("PostgreSQL's binaries are missing under CI: .ci/run installs the "
                        "postgresql package")
        pytest.skip("PostgreSQL's binaries are not installed (apt-get install postgresql)")
    with running_server() as server:
        yield server


@pytest.fixture
def postgres_url(postgres_server: Server) -> str:
    """An empty database of its own for each test."""
    return postgres_server.new_database(f"history_{os.getpid()}_{next(_names)}")
