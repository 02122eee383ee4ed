"""A joint's side before its first recorded move is unknown, not "none": a readings
CSV that starts at Max (the machine homed, the move there not recorded) with a
backlash in the drive."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ogacq.diagnose.diagnosis import diagnose
from ogacq.identify.consistency import fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.observations import readings_observations
from ogacq.model.measurement import approach_from_sequence, predict_coordinates
from ogacq.model.parameters import vector
from tests.diagnose.campaigns import MACHINE, NOISE_MM, OFFSETS, STEP_MM, layout

BACKLASH = 0.05


def csv_campaign(seed: int):
    """The plan's readings (whose first posture the joint really reached moving up),
    recorded as a CSV records them: sides from the order of the readings alone."""
    plan = layout(("max", "min", "zero", "max"))
    rng = np.random.default_rng(seed)
    clean = predict_coordinates(vector({**OFFSETS, "backlash.x": BACKLASH}), plan, MACHINE)
    values = clean + rng.uniform(2, 10, plan.n_gauges)[plan.gauge] + \
        rng.normal(0, NOISE_MM, len(plan))
    recorded = replace(plan, approach=approach_from_sequence(plan.q_mm))
    return plan, readings_observations(MACHINE, recorded, np.round(values / STEP_MM) * STEP_MM)


def test_the_side_before_the_first_move_is_resolved_or_left_unknown_never_guessed():
    taken = 0
    for seed in range(1, 6):
        plan, obs = csv_campaign(seed)
        assert (obs.layout.approach[:2, 0] == 0).all()  # unknown in the CSV
        d = diagnose(obs)
        [x] = [c for c in d.sides if c.axis == 0]
        assert x.side in (0, plan.approach[0, 0]), "a side the data do not favour clearly"
        taken += x.side != 0
        [effect] = d.effects
        assert effect.name == "backlash.x"
        assert abs(effect.value - BACKLASH) < 3 * effect.std
        assert d.final.consistent
        if x.side:
            assert "taken as from below" in " ".join(d.caveats())
            assert d.to_json()["unknown_sides"][0]["taken"] == 1
    assert taken >= 3


def test_resolving_the_side_fits_the_backlash_better_than_leaving_it_in_the_middle():
    _, obs = csv_campaign(3)
    d = diagnose(obs)
    assert [c.side for c in d.sides if c.axis == 0] == [1]
    # the same model with the side left unknown: the two first readings sit half a
    # backlash off
    names = ("joint_offset.x", "joint_offset.y", "joint_offset.z", "backlash.x")
    middle = fit_verdict(fit(obs, names, weighting="gls", noise=d.noise))
    assert d.final.statistic < middle.statistic - 5
