"""A reading far from its repeats is named, with the verdict without it; repeats that
move together (a drift through the campaign) and clean campaigns name none. Sweeps of
the rates: bench/sweep_outliers.py (0-0.5 % named where there is none, ~95 % of
15-sigma slips found)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ogacq.diagnose.locate import row_labels
from ogacq.diagnose.outliers import outlying_readings
from ogacq.identify.noise import noise_for
from ogacq.identify.observations import Observations, readings_observations
from ogacq.io.tables import write_readings
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings
from tests.cli.helpers import run_ogacq
from tests.diagnose.campaigns import (
    MACHINE,
    MACHINE_WITHOUT_NOISE,
    NOISE_MM,
    OFFSETS,
    simulate,
)
from tests.diagnose.test_diagnose_cli import MACHINE_TOML

SLIP_MM = 0.03  # 15 noise steps: a dial misread by a few divisions, a digit typed wrong
LEVEL = 0.01


def slipped(obs: Observations, row: int, by_mm: float = SLIP_MM) -> Observations:
    values = obs.values.copy()
    values[row] += by_mm
    return readings_observations(obs.machine, obs.layout, values)


def named(obs: Observations) -> list[int]:
    found, _ = outlying_readings(obs, row_labels(obs), noise_for(obs), LEVEL)
    return [r.index for r in found]


@pytest.mark.parametrize("machine", [MACHINE, MACHINE_WITHOUT_NOISE], ids=["stated", "measured"])
@pytest.mark.parametrize("row", [9, 40, 70])
def test_a_slipped_reading_is_named_whatever_the_noise_source(machine, row):
    clean = simulate({}, 5, machine=machine)
    obs = slipped(clean, row)
    found, tested = outlying_readings(obs, row_labels(obs), noise_for(obs), LEVEL)
    assert [r.index for r in found] == [row]
    [r] = found
    assert r.deviation_mm == pytest.approx(SLIP_MM, abs=4 * NOISE_MM)
    assert r.p_value < 1e-6 and 0 < tested <= len(obs)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_clean_campaign_names_none(seed):
    assert named(simulate({}, seed)) == []
    assert named(simulate({"squareness.xy": 0.5}, seed)) == []  # physics is no slip


DIAL = replace(MACHINE_WITHOUT_NOISE, gauge_resolution_mm=0.01)


@pytest.mark.parametrize("machine", [DIAL, replace(DIAL, gauge_repeatability_mm=0.0005)],
                         ids=["measured", "stated"])
def test_a_coarse_display_flipping_one_step_is_no_slip(machine):
    """A 0.01 mm dial on a gauge that scatters 1 um: repeats read the same division but
    where the machine sits near a division's edge, where one of them reads the next.
    Rounding alone puts a reading up to one division from its repeats (its error lies
    within half a division either way); with the noise measured from the repeats, one
    was named a slip in 4 of 6 campaigns. A slip
    of 5 divisions is still named."""
    lay = planned_layout(ProtocolConfig(cycles=6), machine)
    for seed in range(6):
        obs = simulated_readings(machine, lay, OFFSETS, scatter_mm=0.001, step_mm=0.01,
                                 seed=seed)
        assert named(obs) == [], seed
    assert named(slipped(obs, 40, 0.05)) == [40]


def test_a_drift_through_the_campaign_is_no_slip():
    """Every posture's later cycles read higher (a warming gauge, 4 noise steps per
    cycle): the repeats move together, which the rest of the diagnosis explains."""
    obs = simulate({}, 4)
    warming = obs.values + 0.2 * obs.layout.t_s / 3600  # 0.2 mm/h
    assert named(readings_observations(obs.machine, obs.layout, warming)) == []


def test_tabulated_deviations_have_no_repeats_to_judge_by(paper_dir):
    from ogacq.io.loading import load_input
    from ogacq.io.machine_file import read_machine
    from ogacq.model.parameters import PARAM_SETS

    loaded = load_input(paper_dir / "experiment2_12.csv",
                        read_machine(paper_dir / "machine.toml"), PARAM_SETS["offsets"])
    assert named(loaded.observations) == []


def test_diagnose_names_the_reading_and_the_verdict_without_it(tmp_path):
    """Through the command: the slip inflates the noise measured from the repeats until
    the joint offsets alone pass; the reading is named, and without it they do not."""
    obs = slipped(simulate({"squareness.xy": 0.4}, 6, machine=MACHINE_WITHOUT_NOISE), 33, 2.0)
    write_readings(tmp_path / "r.csv", obs.layout, obs.values)
    (tmp_path / "m.toml").write_text(MACHINE_TOML.replace("gauge_repeatability_mm = 0.002\n",
                                                          ""))
    out = run_ogacq("diagnose", tmp_path / "r.csv", "-m", tmp_path / "m.toml", "--json",
                    check_json=True)
    assert out["base"]["consistent"] is True  # what the slip did to the verdict
    [reading] = out["outliers"]["readings"]
    gauge = row_labels(obs).gauge[33]
    assert (reading["gauge"], reading["cycle"]) == (gauge, int(obs.layout.cycle[33]))
    assert reading["deviation_mm"] == pytest.approx(2.0, abs=0.01)
    assert out["outliers"]["without"]["verdict"] == "inconsistent"
    text = run_ogacq("diagnose", tmp_path / "r.csv", "-m", tmp_path / "m.toml").stdout
    assert "One reading lies far from its repeats" in text
    assert f"{gauge} at " in text and "without it, joint offsets only: NOT within" in text
    clean = simulate({}, 6, machine=replace(MACHINE_WITHOUT_NOISE))
    write_readings(tmp_path / "c.csv", clean.layout, clean.values)
    assert "outliers" not in run_ogacq("diagnose", tmp_path / "c.csv", "-m",
                                       tmp_path / "m.toml", "--json", check_json=True)
    assert np.isfinite(reading["p_value"])
