"""mypy over ogacq and the drivers finds nothing (tools/typecheck.py, with the options
of pyproject's [tool.mypy]), and it does guard the Station contract: a station that
misses a method is rejected where the runner is given it.

mypy keeps its cache in .mypy_cache at the project root: the first run of a checkout
analyses everything (about a minute on a busy two-core machine), later ones only
what changed.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def typecheck(*paths: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(ROOT / "tools" / "typecheck.py"),
                           *map(str, paths)], cwd=ROOT, capture_output=True, text=True,
                          timeout=900)


def test_ogacq_and_the_drivers_type_check_clean():
    done = typecheck()
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.startswith("Success: no issues found"), done.stdout


STATIONS = '''
from collections.abc import Mapping, Sequence

from ogacq_drivers.errors import DriverError
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.protocol.deadline import DeadlineStation
from ogacq.protocol.plan import ProtocolConfig, Read, SettleRule, StabilityRule
from ogacq.protocol.runner import CampaignRunner
from ogacq.protocol.station import GaugeReadings, Joints, SettledGauge, settle_unjudged
from ogacq.session.store import SessionWriter


class AllButSettling:  # every method of the contract but read_settled
    def move(self, q_mm: Joints, timeout_s: float) -> Joints:
        return q_mm

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        return []

    def settle(self, seconds: float) -> None:
        pass

    def campaign_time_s(self) -> float:
        return 0.0

    def stop_axes(self) -> None:
        pass

    def recover_axes(self) -> bool:
        return True

    def take_check_request(self) -> bool:
        return False


class Complete(AllButSettling):
    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> Mapping[str, SettledGauge | DriverError]:
        return settle_unjudged(self, gauges, rule)


class WithoutSettling(AllButSettling):  # as a station before the contract
    pass


def run(writer: SessionWriter) -> None:
    config = ProtocolConfig()
    CampaignRunner(Complete(), writer, config, PAPER_PROTOTYPE)
    CampaignRunner(DeadlineStation(Complete(), 60.0), writer, config, PAPER_PROTOTYPE)
    CampaignRunner(WithoutSettling(), writer, config, PAPER_PROTOTYPE)  # rejected
    DeadlineStation(WithoutSettling(), 60.0)  # rejected
'''


def test_a_station_missing_a_method_is_rejected_by_the_type_checker(tmp_path):
    snippet = tmp_path / "station_snippet.py"
    snippet.write_text(textwrap.dedent(STATIONS).lstrip("\n"))
    rejected = [n for n, line in enumerate(snippet.read_text().splitlines(), 1)
                if line.endswith("# rejected")]
    done = typecheck(snippet)
    errors = [m for m in done.stdout.splitlines() if ": error: " in m]
    assert [int(m.split(":")[1]) for m in errors] == rejected, done.stdout
    assert all("WithoutSettling" in m and '"Station"' in m for m in errors), errors
    assert "read_settled" in done.stdout  # mypy names the missing member
    assert done.returncode == 1
