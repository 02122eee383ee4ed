"""Honest failure: physics outside the library is reported as unexplained, with where
the misfit sits, and no library effect is named with confidence."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.diagnosis import PARTIAL_SHARE, diagnose
from ogacq.identify.observations import readings_observations
from tests.diagnose.campaigns import RICH, layout, simulate

# A periodic lead-screw error of 20 um amplitude and 16 mm pitch on every drive.
LEAD_SCREW = (0.02, 16.0)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lead_screw_error_is_unexplained(seed):
    """With intermediate postures the joint-position error is seen at enough points
    that no library effect mimics it: the tool says it does not know."""
    d = diagnose(simulate({}, seed, lay=layout(RICH), lead_screw=LEAD_SCREW))
    assert not d.base.consistent
    assert d.outcome == "unexplained", [e.name for e in d.effects]
    assert not d.final.consistent
    assert d.confident() == []
    out = d.to_json()
    assert [e["effect"] for e in out["effects"]] == ["unexplained"]
    assert out["effects"][0]["where"] == d.unexplained
    assert out["final"]["consistent"] is False
    # what the search tried does not remove most of the misfit
    assert d.explained_share < PARTIAL_SHARE


def test_lead_screw_on_three_postures_carries_the_caveat():
    """At Zero, Max and Min only, the error is three numbers per drive, which leg
    lengths or scales can reproduce; whatever is named, the report says that
    intermediate postures would tell."""
    d = diagnose(simulate({}, 4, lead_screw=LEAD_SCREW))
    assert not d.base.consistent
    if d.effects:
        assert any("lead-screw" in c for c in d.caveats())


def test_real_effect_beside_a_small_unknown_one_is_still_named():
    d = diagnose(simulate({"squareness.xy": 1.0}, 5, lay=layout(RICH), lead_screw=(0.005, 16.0)))
    assert "squareness.xy" in [e.name for e in d.effects]


def test_disturbance_of_one_cell_is_not_blamed_on_an_effect():
    """A stand knocked at one gauge's Max posture (15 um on three readings): whatever
    pair of effects absorbs it is reported with a disturbance of that gauge as an
    equally good explanation, never with confidence."""
    obs = simulate({}, 6)
    lay = obs.layout
    knocked = (lay.gauge_axis == 1) & (lay.leg == 0) & (lay.tcp_mm[:, 0] > 1.0)
    values = obs.values + np.where(knocked, 0.015, 0.0)
    d = diagnose(readings_observations(obs.machine, lay, values))
    assert not d.base.consistent
    assert d.located.where() == "y_x"
    assert d.base.worst_cell is not None and d.base.worst_cell.cell == "y_x at max"
    assert d.confident() == []
    for e in d.to_json()["effects"]:
        assert {"effect": "unexplained", "where": "y_x"} in e["alternatives"] \
            or e["effect"] == "unexplained"
