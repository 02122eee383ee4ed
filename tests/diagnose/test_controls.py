"""Control campaigns with no effect: a consistent campaign is called consistent, and
the rate of false alarms over many seeds stays near the tests' nominal 1 %."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.identify.consistency import LEVEL as ALPHA
from tests.diagnose.campaigns import MACHINE, MACHINE_WITHOUT_NOISE, simulate

SEEDS = range(100)


@pytest.mark.parametrize(("machine", "label"), [(MACHINE, "noise from the machine file"),
                                                (MACHINE_WITHOUT_NOISE,
                                                 "noise from repeated readings")])
def test_false_alarm_rate_near_nominal(machine, label):
    results = [diagnose(simulate({}, 7000 + seed, machine=machine)) for seed in SEEDS]
    inconsistent = np.mean([not d.base.consistent for d in results])
    claimed = np.mean([bool(d.effects) for d in results])
    confident = np.mean([bool(d.confident()) for d in results])
    print(f"\ncontrols, {label}: {len(results)} campaigns, base called inconsistent "
          f"{inconsistent:.1%}, an effect named {claimed:.1%}, named with confidence "
          f"{confident:.1%} (nominal level {ALPHA:.0%})")
    # Nominal 1 %: five or more of a hundred would happen with probability 0.3 %.
    assert inconsistent <= 0.05
    assert claimed <= 0.05
    assert all(d.noise.source == ("machine file" if machine is MACHINE else
                                  "repeated readings") for d in results)


def test_verdict_p_values_are_not_piled_at_zero():
    """Under noise alone the overall test's p is uniform: about a tenth below 0.1."""
    p = np.array([diagnose(simulate({}, 9000 + s)).base.overall_p for s in SEEDS])
    assert 0.03 < np.mean(p < 0.1) < 0.2
    assert 0.3 < np.mean(p < 0.5) < 0.7


def test_consistent_campaign_reports_no_effects_and_keeps_offsets():
    d = diagnose(simulate({}, 1))
    assert d.outcome == "consistent"
    out = d.to_json()
    assert out["effects"] == []
    assert out["base"]["consistent"] and out["final"]["consistent"]
    assert out["base"] == out["final"]
    assert np.allclose([out["parameters"]["joint_offset"][a] for a in "xyz"],
                       [2.0, 2.0, -2.0], atol=0.01)
