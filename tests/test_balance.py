"""The suite's files go to the workers longest first (tests/balance.py)."""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from tests.balance import (
    COMMITTED,
    WORKER_KEY,
    file_totals,
    for_worker,
    known_seconds,
    longest_first,
)

ROOT = Path(__file__).resolve().parents[1]


@dataclass
class Item:
    nodeid: str


def test_the_longest_file_goes_first_and_each_file_keeps_its_order():
    items = [Item(n) for n in ("tests/a.py::one", "tests/a.py::two", "tests/b.py::one",
                               "tests/c.py::one[x]", "tests/c.py::one[y]", "tests/d.py::one")]
    seconds = {"tests/c.py": 90.0, "tests/a.py": 5.0, "tests/gone.py": 400.0}
    ordered = [i.nodeid for i in longest_first(items, seconds)]
    assert ordered == ["tests/c.py::one[x]", "tests/c.py::one[y]", "tests/a.py::one",
                       "tests/a.py::two", "tests/b.py::one", "tests/d.py::one"]


def test_a_file_s_seconds_are_its_tests_together():
    assert file_totals([("tests/a.py::one", 1.5), ("tests/b.py::x[1]", 2.0),
                        ("tests/a.py::two", 0.5)]) == {"tests/a.py": 2.0, "tests/b.py": 2.0}


def test_xdist_keeps_the_order_and_a_fresh_clone_knows_the_long_files():
    """xdist's default puts the files with the most tests first, whatever the collection's
    order: the suite's addopts turn it off. The committed seconds are test files' (a name
    gone stale since costs only balance: longest_first passes over it)."""
    addopts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"][
        "ini_options"]["addopts"].split()
    assert "--no-loadscope-reorder" in addopts and "loadfile" in addopts
    seconds = json.loads(COMMITTED.read_text())
    assert seconds and all(name.startswith("tests/") and name.endswith(".py") and s > 0
                           for name, s in seconds.items())


def test_every_worker_orders_by_what_the_controller_read(request):
    """The controller reads the seconds once and hands each worker the same: a worker that
    read the cache itself could find another run's write and collect in another order."""
    nodes = [SimpleNamespace(config=request.config, workerinput={}) for _ in range(2)]
    for node in nodes:
        for_worker(node)
    first, second = (node.workerinput[WORKER_KEY] for node in nodes)
    assert first is second and first
    handed = {"tests/x.py": 5.0}
    worker = SimpleNamespace(workerinput={WORKER_KEY: handed}, cache=None)
    assert known_seconds(worker) == handed  # not the committed file's, nor a cache's
