"""The suite's files ordered longest first, so that both workers stay busy to the end.

``--dist loadfile`` hands each worker a whole file at a time, in the order of the
collection. xdist's own order (``--loadscope-reorder``, its default) puts the files with
the most tests first, which is the wrong end for this suite: its longest files are
end-to-end runs of one or two tests (the demo, the calibrations), so they came last and
one worker ran them alone while the other had nothing left. pyproject's addopts turn
that off (``--no-loadscope-reorder``) and :func:`longest_first` orders the files by the
seconds they took, longest first (the longest-processing-time rule), each file's tests
in their own order (a module's fixtures and its order kept).

The seconds come from the last run on this checkout (pytest's cache, ``file_seconds``,
written at the end of every run with the cache on) and, for a file the cache does not
know (a fresh clone, as CI's), from ``tests/file_seconds.json`` (a run's measurements,
written by ``python bench/suite_balance.py --write``). A file known to neither counts as
short: it keeps its place among the short files. Stale seconds cost balance, never a
test: the order of files is all they change.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol, TypeVar

import pytest

CACHE_KEY = "ogacq/file_seconds"
WORKER_KEY = "ogacq_file_seconds"
_READ = pytest.StashKey[dict[str, float]]()  # what the controller read, once
COMMITTED = Path(__file__).with_name("file_seconds.json")


class _Item(Protocol):
    nodeid: str


Item = TypeVar("Item", bound=_Item)


def file_of(nodeid: str) -> str:
    """The test file of a test id (``tests/a/test_b.py::test_c[x]`` -> ``tests/a/test_b.py``)."""
    return nodeid.split("::", 1)[0]


def longest_first(items: Sequence[Item], seconds: Mapping[str, float]) -> list[Item]:
    """``items`` grouped by file, the files in decreasing ``seconds`` (an unknown file: 0),
    ties in their first appearance; within a file, the items' own order."""
    first_seen: dict[str, int] = {}
    for n, item in enumerate(items):
        first_seen.setdefault(file_of(item.nodeid), n)
    return sorted(items, key=lambda item: (-seconds.get(file_of(item.nodeid), 0.0),
                                           first_seen[file_of(item.nodeid)]))


def for_worker(node: Any) -> None:
    """Hand an xdist worker (``node``, its controller's WorkerController) the seconds its
    controller read, the same to every worker."""
    stash = node.config.stash
    if _READ not in stash:
        stash[_READ] = known_seconds(node.config)
    node.workerinput[WORKER_KEY] = stash[_READ]


def file_totals(durations: Iterable[tuple[str, float]]) -> dict[str, float]:
    """Seconds per file: the sum of its tests' setup, call and teardown."""
    totals: dict[str, float] = {}
    for nodeid, seconds in durations:
        totals[file_of(nodeid)] = totals.get(file_of(nodeid), 0.0) + seconds
    return totals


def known_seconds(config: pytest.Config) -> dict[str, float]:
    """The committed seconds, overridden by this checkout's last run where it knows. An
    xdist worker takes the controller's (``for_worker``): each worker reading the cache
    itself could read another run's write, collect in another order, and xdist stops a
    run whose workers' collections differ."""
    worker = getattr(config, "workerinput", None)
    if worker is not None and WORKER_KEY in worker:
        return dict(worker[WORKER_KEY])
    seconds: dict[str, float] = json.loads(COMMITTED.read_text()) if COMMITTED.is_file() \
        else {}
    cache = getattr(config, "cache", None)  # None under -p no:cacheprovider
    if cache is not None:
        seconds.update(cache.get(CACHE_KEY, {}))
    return seconds


def whole_suite(config: pytest.Config, exitstatus: int) -> bool:
    """A run of every test to its end, seen by the process that gathers the reports (xdist's
    controller, or the one process of ``-n 0``): its seconds are each file's whole."""
    return (config.args_source is pytest.Config.ArgsSource.TESTPATHS
            and not config.option.keyword and not config.option.markexpr
            and not getattr(config.option, "lf", False)
            and not hasattr(config, "workerinput")
            and exitstatus in (pytest.ExitCode.OK, pytest.ExitCode.TESTS_FAILED))


def remember(config: pytest.Config, measured: Mapping[str, float]) -> None:
    """This run's seconds per file into the cache, beside the files it did not run."""
    cache = getattr(config, "cache", None)
    if cache is None or not measured:
        return
    cache.set(CACHE_KEY, {**cache.get(CACHE_KEY, {}), **{
        name: round(s, 2) for name, s in measured.items()}})
