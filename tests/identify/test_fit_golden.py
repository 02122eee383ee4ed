"""The fit gives the same results as before it was made fast (issue 14).

``fit_golden.json`` holds the values, std, covariance, residuals, noise,
identifiability and ``refit --json`` object of every case below, written by the
fit as it was before the issue-14 speed-ups (commit 4ae4846, bisection noise
estimate, six model evaluations per fit). Every case must still agree to 1e-9
(mm; a parameter's value, std and derivatives to 1e-10 of its plausible range,
which is 1e-9 mm for an offset; relative 1e-12 for numbers beyond 1000): the
paper's deviations (every data set, every parameter set, linear and exact, OLS
and GLS) and simulated campaigns whose free sets reach every branch of the
model's Jacobian (squareness, axis offset, encoder scale, backlash, thermal
drift, gauge position and gain), measured and stated noise, a 10 um dial, a
scan and a fit whose rank stays short.

Regenerate (only when a result is meant to change, and say why in the commit):
``python tests/identify/test_fit_golden.py --write``.
"""

from __future__ import annotations

import json
import math
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from ogacq.identify.fit import FitResult, evaluate, fit
from ogacq.identify.noise import GaugeNoise, sigma_from_scatter, within_variance
from ogacq.identify.observations import readings_observations
from ogacq.io.loading import load_observations
from ogacq.io.machine_file import read_machine
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import EFFECT_BY_NAME, PARAM_NAMES, PARAM_SETS, effect_of, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

GOLDEN = Path(__file__).with_name("fit_golden.json")
PAPER = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
PAPER_SETS = ("experiment1_6", "experiment2_12", "experiment2_6", "experiment3_12",
              "experiment3_6")
TOLERANCE = 1e-9
# A parameter's value, std, covariance and derivatives are compared in shares of its
# plausible range (the currency of the fit's own step tolerance): 1e-10 of it is
# 1e-9 mm for an offset, 5e-6 ppm for a gauge's gain.
RANGE_TOLERANCE = 1e-10
# A number beyond a thousand (a gain's variance in ppm^2, a diverged unidentifiable
# fit's value) is compared to its last few digits instead: a double holds no more.
RELATIVE = 1e-12
PARAMETER_KEYS = ("values", "std", "covariance", "theta", "jacobian", "json")

DIGITAL = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001,
                      gauge_repeatability_mm=0.002)
DIGITAL_MEASURED = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
DIAL = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.01)
TRUTH = {"joint_offset.x": -0.49, "joint_offset.y": 0.50, "joint_offset.z": -1.67,
         "squareness.xy": 0.4, "backlash.z": 0.02, "thermal_drift.y": 0.01,
         "gauge_scale.y_x": 300.0}
EVERY_BRANCH = PARAM_SETS["offsets"] + (
    "squareness.xy", "squareness.xz", "axis_offset.yz", "encoder_scale.x", "backlash.z",
    "thermal_drift.y", "gauge_position.x", "gauge_scale.y_x")


def simulated(machine: MachineSpec, config: ProtocolConfig, seed: int):
    layout = planned_layout(config, machine)
    rng = np.random.default_rng(seed)
    clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(
        vector(TRUTH))
    noisy = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] \
        + rng.normal(0, 0.002, len(layout))
    step = machine.gauge_resolution_mm
    return readings_observations(machine, layout, np.round(noisy / step) * step)


@cache
def cases() -> dict[str, FitResult]:
    out: dict[str, FitResult] = {}
    paper = read_machine(PAPER / "machine.toml")
    for name in PAPER_SETS:
        obs = load_observations(PAPER / f"{name}.csv", paper)
        for params in ("offsets", "lengths", "both"):
            for method in ("linear", "exact"):
                for weighting in ("ols", "gls"):
                    out[f"paper {name} {params} {method} {weighting}"] = fit(
                        obs, PARAM_SETS[params], method=method, weighting=weighting)
    papers = simulated(DIGITAL, ProtocolConfig(cycles=3), 1)
    for params in ("offsets", "lengths", "both"):
        out[f"papers' plan 72 {params}"] = fit(papers, PARAM_SETS[params])
    out["papers' plan 72 offsets linear"] = fit(papers, PARAM_SETS["offsets"],
                                                method="linear")
    out["papers' plan 72 every branch"] = fit(papers, EVERY_BRANCH)
    measured = simulated(DIGITAL_MEASURED, ProtocolConfig(cycles=4), 2)
    out["measured noise 96 offsets"] = fit(measured, PARAM_SETS["offsets"])
    out["measured noise 96 every branch"] = fit(measured, EVERY_BRANCH)
    dial = simulated(DIAL, ProtocolConfig(cycles=5), 3)
    out["dial 120 offsets"] = fit(dial, PARAM_SETS["offsets"])
    out["dial 120 both"] = fit(dial, PARAM_SETS["both"])
    scan = simulated(DIGITAL, ProtocolConfig(cycles=1, scan_step_mm=20.0), 4)
    out["scan offsets"] = fit(scan, PARAM_SETS["offsets"])
    out["scan every branch"] = fit(scan, EVERY_BRANCH)
    one_leg = simulated(DIGITAL, ProtocolConfig(cycles=1, legs=("x",)), 5)
    out["one leg every branch (rank short)"] = fit(one_leg, EVERY_BRANCH)
    found = out["papers' plan 72 offsets"]
    out["papers' plan 72 evaluate"] = evaluate(papers, found.names, found.values)
    return out


def summary(result: FitResult) -> dict:
    """Everything a user sees of a fit, as plain numbers (None for NaN, strings for
    infinities)."""
    ident = result.identifiability
    return {
        "values": result.values, "std": result.std, "covariance": result.covariance,
        "residuals": result.residuals, "residual_rms_mm": result.residual_rms_mm,
        "sigma_mm": result.sigma_mm, "dof": result.dof, "theta": result.theta,
        "jacobian": result.jacobian, "converged": result.converged,
        "noise": noise_summary(result.noise),
        "identifiability": {"rank": ident.rank, "condition_number": ident.condition_number,
                            "correlation": ident.correlation,
                            "identifiable": ident.identifiable, "reasons": ident.reasons,
                            "unidentified": ident.unidentified},
        "json": result.to_json("golden"),
    }


def noise_summary(noise: GaugeNoise) -> dict:
    return {k: getattr(noise, k) for k in ("sigma_mm", "source", "step_mm", "scatter_mm",
                                           "shared_var", "dof", "pure_error_ss",
                                           "repeats_scatter_mm")}


def plain(x):
    """JSON-able: arrays to lists, NaN to None, infinities to strings."""
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, np.ndarray | list | tuple):
        return [plain(v) for v in np.asarray(x, dtype=object).tolist()] \
            if isinstance(x, np.ndarray) else [plain(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None if math.isnan(x) else ("inf" if x > 0 else "-inf")
    return x


def scatter_cases() -> list[list[float]]:
    """(scatter variance, step, sigma found): the noise estimate's inversion across
    the regimes, from a dial far coarser than the noise to rounding dithered away."""
    rows = []
    for step in (0.001, 0.01):
        for ratio in (0.0, 1e-4, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 3.0):
            target = within_variance(ratio * step, step)
            rows.append([target, step, sigma_from_scatter(target, step)])
    return rows


def compare(expected, actual, where: str, tolerance: float = TOLERANCE) -> None:
    if isinstance(expected, dict):
        assert expected.keys() == actual.keys(), where
        for key in expected:
            compare(expected[key], actual[key], f"{where}.{key}", tolerance)
    elif isinstance(expected, list):
        assert len(expected) == len(actual), where
        for k, (e, a) in enumerate(zip(expected, actual, strict=True)):
            compare(e, a, f"{where}[{k}]", tolerance)
    elif isinstance(expected, float) and isinstance(actual, float):
        assert actual == pytest.approx(expected, abs=tolerance, rel=RELATIVE), where
    else:
        assert expected == actual, where


def in_ranges(fit: dict, names: tuple[str, ...]) -> dict:
    """The parameter-valued parts of a plain :func:`summary`, each number divided by
    its parameter's plausible range (squared for a covariance; a derivative by the
    parameter multiplied)."""
    ranges = [effect_of(n).plausible_range for n in names]
    every = [effect_of(n).plausible_range for n in PARAM_NAMES]

    def share(x, r):
        return x / r if isinstance(x, float) else x

    def nested_share(table: dict) -> dict:
        return {effect: {where: share(v, EFFECT_BY_NAME[effect].plausible_range)
                         for where, v in values.items()} for effect, values in table.items()}

    return {
        "values": [share(v, r) for v, r in zip(fit["values"], ranges, strict=True)],
        "std": [share(v, r) for v, r in zip(fit["std"], ranges, strict=True)],
        "covariance": [[share(c, ri * rj) for c, rj in zip(row, ranges, strict=True)]
                       for row, ri in zip(fit["covariance"], ranges, strict=True)],
        "theta": [share(v, r) for v, r in zip(fit["theta"], every, strict=True)],
        "jacobian": [[share(d, 1.0 / r) for d, r in zip(row, ranges, strict=True)]
                     for row in fit["jacobian"]],
        "json": {**fit["json"], "parameters": nested_share(fit["json"]["parameters"]),
                 "std": nested_share(fit["json"]["std"])},
    }


@pytest.fixture(scope="module")
def golden() -> dict:
    return json.loads(GOLDEN.read_text())


@pytest.mark.parametrize("case", sorted(json.loads(GOLDEN.read_text())["fits"])
                         if GOLDEN.exists() else [])
def test_fit_unchanged(golden, case):
    result = cases()[case]
    expected, actual = golden["fits"][case], plain(summary(result))
    compare(in_ranges(expected, result.names), in_ranges(actual, result.names), case,
            RANGE_TOLERANCE)
    compare({k: v for k, v in expected.items() if k not in PARAMETER_KEYS},
            {k: v for k, v in actual.items() if k not in PARAMETER_KEYS}, case)


def test_noise_inversion_unchanged(golden):
    compare(golden["scatter"], plain(scatter_cases()), "scatter")


def test_every_case_is_checked(golden):
    """A case added above without regenerating the file would pass unchecked."""
    assert sorted(golden["fits"]) == sorted(cases())


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    GOLDEN.write_text(json.dumps({"fits": {k: plain(summary(v)) for k, v in cases().items()},
                                  "scatter": plain(scatter_cases())}) + "\n")
    print(f"wrote {GOLDEN}")
