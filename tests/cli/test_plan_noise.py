"""Issue 38: `ogacq plan` predicted with the display step as the gauge noise (10 µm,
its rounding added on top) where the diagnosis of the same machine measured 2.9 µm,
the rounding of a quiet gauge. The plan now predicts with the noise given, measured
from an earlier campaign's repeats, or stated in the machine file, else with the
display's rounding alone, and says which."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ogacq.identify.accuracy import planned_observations, predict_accuracy
from ogacq.identify.fit import fit
from ogacq.identify.noise import noise_for
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.model.parameters import PARAM_SETS
from ogacq.session.convert import session_observations
from ogacq.session.store import load_session
from tests.writeback.conftest import ogacq_here

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "ogacq" / "examples" / "paper"
SESSION = ROOT / "tests" / "golden" / "session.jsonl"  # a seeded campaign, 3 cycles


def _plan(capsys, monkeypatch, machine: Path, *extra: str | Path) -> dict:
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", machine, "--trials", "0", "--json",
                     *extra)
    assert ran.returncode == 0, ran.stderr
    return json.loads(ran.stdout)


def test_without_a_stated_noise_the_plan_predicts_with_the_rounding_alone(capsys,
                                                                           monkeypatch):
    """The papers' machine (a 10 µm dial, no repeatability stated): the display's
    rounding, 2.9 µm a reading, not a 10 µm scatter beside it."""
    out = _plan(capsys, monkeypatch, PAPER / "machine.toml")
    assert (out["noise_mm"], out["noise_source"]) == (0.0, "display rounding")
    obs = planned_observations(PAPER_PROTOTYPE, postures=("zero", "max", "min", "zero"),
                               cycles=3)
    rounding = predict_accuracy(obs, PARAM_SETS["offsets"], 0.0, rounding_mm=0.01)
    step_as_noise = predict_accuracy(obs, PARAM_SETS["offsets"], 0.01, rounding_mm=0.01)
    std = np.array(list(out["analytic_std"].values()))
    np.testing.assert_allclose(std, rounding.analytic_std)
    assert np.all(std < 0.6 * step_as_noise.analytic_std)
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", PAPER / "machine.toml")
    assert ran.returncode == 0 and "std Monte-Carlo" not in ran.stdout  # trials alike
    text = " ".join(ran.stdout.split())
    assert "the 10 µm display step's rounding alone (2.9 µm a reading" in text, text
    assert "gauge_repeatability_mm" in text and "--noise-from" in text


def test_a_stated_noise_is_used_and_said_per_value(capsys, monkeypatch, tmp_path):
    machine = tmp_path / "m.toml"
    machine.write_text((PAPER / "machine.toml").read_text()
                       + "gauge_repeatability_mm = 0.002\n")
    out = _plan(capsys, monkeypatch, machine)
    assert (out["noise_mm"], out["noise_source"]) == (0.002, "machine file")
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", machine, "--trials", "0")
    assert "gauge noise 2 µm a value, stated in m.toml" in " ".join(ran.stdout.split())


def test_the_noise_an_earlier_campaigns_repeats_show_is_used_when_given(capsys, monkeypatch,
                                                                       tmp_path):
    """The golden session's readings are means of 3 values whose rounding the scatter
    dithers: the plan predicts with a reading's whole noise, not rounded again; its
    std is the one the session's own fit found."""
    obs = session_observations(load_session(SESSION))
    measured = noise_for(replace(obs, machine=replace(obs.machine,
                                                      gauge_repeatability_mm=None)))
    assert measured.measured and measured.dithered and obs.averaged is not None
    machine = tmp_path / "m.toml"  # the session's own machine
    machine.write_text("".join(f"{k} = {v}\n" for k, v in obs.machine.__dict__.items()
                               if k in ("leg_length_mm", "rho_min_mm", "rho_max_mm",
                                        "gauge_resolution_mm")))
    out = _plan(capsys, monkeypatch, machine, "--noise-from", SESSION)
    assert out["noise_source"] == "repeated readings"
    assert out["noise_mm"] == pytest.approx(measured.sigma_mm)
    own = fit(obs, PARAM_SETS["offsets"])
    np.testing.assert_allclose(list(out["analytic_std"].values()), own.std, rtol=0.05)
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", machine,
                     "--trials", "0", "--noise-from", SESSION)
    text = " ".join(ran.stdout.split())
    assert "µm a reading (the mean of 3 values), measured from the repeats of" in text, text
    assert "(52 dof)" in text, text


@pytest.mark.parametrize(("extra", "named"), [
    (("--noise-from", PAPER / "experiment2_12.csv"), "experiment2_12.csv: holds no repeated"),
    (("--noise-from", PAPER / "none.jsonl"), "none.jsonl: no such file"),
    (("--noise-from", SESSION, "--noise", "0.001"), "--noise-from: give the noise"),
])
def test_a_noise_that_cannot_be_had_is_refused_in_one_line(extra, named, capsys, monkeypatch):
    ran = ogacq_here(capsys, monkeypatch, "plan", "-m", PAPER / "machine.toml", "--trials",
                     "0", *extra)
    lines = ran.stderr.strip().splitlines()
    assert ran.returncode == 2 and len(lines) == 1 and named in lines[0], ran.stderr
