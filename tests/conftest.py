from pathlib import Path

import pytest

from ogacq.io.machine_file import read_machine

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "ogacq" / "examples" / "paper"


@pytest.fixture(scope="session")
def paper_dir() -> Path:
    return PAPER


@pytest.fixture(scope="session")
def paper_machine():
    return read_machine(PAPER / "machine.toml")
