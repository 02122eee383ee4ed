"""'Validated' says where it looked: the positions of each leg's travel its campaigns
read, and that between them nothing was measured."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from ogacq.calibration.validate import where_looked
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL
from ogacq.protocol.plan import ProtocolConfig


def session(name: str, plan: ProtocolConfig) -> SimpleNamespace:
    return SimpleNamespace(path=Path(f"/run/{name}.jsonl"),
                           header=SimpleNamespace(plan=plan.to_dict()))


def test_the_papers_postures_and_a_scan_between_are_counted_per_leg():
    papers = session("validation", ProtocolConfig())
    said = where_looked([papers], PAPER_PROTOTYPE_DIGITAL)  # type: ignore[list-item]
    assert said == ("at 3 positions of each leg's travel (3 in validation); between them "
                    "not measured")
    scan = session("validation-scan", ProtocolConfig(
        postures=(), approach="both", cycles=2, scan_targets_mm=(-50.5, -20.25, 10.0, 33.3)))
    said = where_looked([papers, scan], PAPER_PROTOTYPE_DIGITAL)  # type: ignore[list-item]
    # the scan's Zero reading is the papers' zero posture: 3 + 4 distinct positions
    assert said.startswith("at 7 positions of each leg's travel (3 in validation, 5 in "
                           "validation-scan)"), said
