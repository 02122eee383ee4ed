"""The fit gives the same results as the golden record, on every CPU and BLAS kernel.

``fit_golden.json`` holds the values, std, covariance, residuals, noise,
identifiability and ``refit --json`` object of every case below: the paper's
deviations (every data set, every parameter set, linear and exact, OLS and GLS)
and simulated campaigns whose free sets reach every branch of the model's
Jacobian (squareness, axis offset, encoder scale, backlash, thermal drift, gauge
position and gain), measured and stated noise, a 10 um dial, a scan and a fit
whose rank stays short.

What is compared is what the numerics determine (issue 27: a golden value at
1e-10 along an ill-conditioned direction measured the BLAS kernel, not ogacq):

* decisions exactly: rank, identifiable, the unidentified parameters, the
  reasons, convergence, degrees of freedom, the noise's source;
* what the data fix, tightly: the fitted values (residuals) and their rms to
  1e-4 of the gauge noise; each identified parameter to 1e-4 of its own std (the
  fit stops when a step no longer lowers the cost by 1e-12 of it, which leaves
  the minimum undetermined by about 1e-5 std; along a direction the data barely
  see, its std is large and so is what rounding can move); std to 1e-6 relative,
  correlations to 1e-6, the condition number to 1e-6 relative, the Jacobian to
  1e-6 of each column's size;
* what the data do not fix, by what it means: an unidentified parameter's value
  is not compared (the residuals hold every combination the data see); the named
  correlated pairs as a set, each to the 4 decimals shown, in an order that
  follows |r|; a pair within 1e-5 of the naming threshold may fall either side.

``python tools/blas_kernels.py`` runs these and the other numerical tests under
two other OpenBLAS kernels (Sandybridge, Prescott) before landing.

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
from ogacq.identify.identifiability import NAMED_CORRELATION
from ogacq.identify.noise import GaugeNoise, sigma_from_scatter, within_variance
from ogacq.identify.observations import readings_observations
from ogacq.io.loading import load_observations
from ogacq.io.machine_file import read_machine
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_INDEX, PARAM_NAMES, PARAM_SETS, effect_of, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

GOLDEN = Path(__file__).with_name("fit_golden.json")
PAPER = Path(__file__).resolve().parents[2] / "ogacq" / "examples" / "paper"
PAPER_SETS = ("experiment1_6", "experiment2_12", "experiment2_6", "experiment3_12",
              "experiment3_6")
# The noise estimate is scalar arithmetic without BLAS: its doubles are kept to 1e-9.
NOISE_RELATIVE = 1e-9
FITTED_IN_NOISE = 1e-4  # residuals, rms, sigma: in units of the gauge noise sigma
# An identified parameter's value, in units of its std: the fit stops once a step lowers
# the cost by less than 1e-12 of it (fit.py), which leaves the minimum undetermined by
# about 1e-6 sqrt(chi2) std; 30 times that where the misfit is large, 1e-4 at least.
VALUE_IN_STD = 1e-4
STALL_IN_STD = 30 * 1e-6
STD_RELATIVE = 1e-5
CORRELATION = 1e-5
CONDITION_RELATIVE = 1e-5
JACOBIAN_IN_COLUMN = 1e-5  # each derivative, in units of its column's norm
SHOWN_CORRELATION = 1e-4  # correlated_pairs are printed to 4 decimals
# refit --json rounds values and std to 6 decimals: one unit of rounding either way
JSON_QUANTUM = 1e-6

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


def floats(values) -> np.ndarray:
    """A golden list as doubles: None (NaN) and the strings of infinities included."""
    return np.array([np.nan if v is None else float(v) for v in values], dtype=float)


def within(expected, actual, tolerance, where: str) -> None:
    e, a = floats(np.ravel(expected).tolist()), floats(np.ravel(actual).tolist())
    assert e.shape == a.shape, f"{where}: {a.shape} values, expected {e.shape}"
    tolerance = np.broadcast_to(np.ravel(np.asarray(tolerance, dtype=float)), e.shape)
    judged = np.isfinite(tolerance)   # an infinite tolerance: not compared
    e_kind, a_kind = e[judged], a[judged]
    assert np.array_equal(np.isfinite(e_kind), np.isfinite(a_kind)) and np.array_equal(
        e_kind[~np.isfinite(e_kind)], a_kind[~np.isfinite(a_kind)], equal_nan=True), \
        f"{where}: {actual} != {expected}"
    finite = np.isfinite(e)
    off = np.abs(a[finite] - e[finite]) - tolerance[finite]
    assert (off <= 0).all(), (f"{where}: {a[finite]} differs from {e[finite]} by more than "
                              f"{tolerance[finite]}")


def check_noise(expected: dict, actual: dict, where: str) -> None:
    assert expected.keys() == actual.keys(), where
    for key, e in expected.items():
        a = actual[key]
        if isinstance(e, float) and isinstance(a, float):
            assert a == pytest.approx(e, rel=NOISE_RELATIVE, abs=1e-300), f"{where}.{key}"
        else:
            assert a == e, f"{where}.{key}"


def value_tolerance(names: tuple[str, ...], std: np.ndarray, fit: dict) -> np.ndarray:
    """Each identified parameter's tolerance in units of its std (inf for one the data
    do not fix, whose value only the residuals judge); never below 1e-12 of its
    plausible range."""
    residuals = floats(fit["residuals"])
    chi2 = float(np.sum(residuals**2)) / fit["noise"]["sigma_mm"] ** 2
    in_std = max(VALUE_IN_STD, STALL_IN_STD * np.sqrt(chi2))
    floor = np.array([1e-12 * effect_of(n).plausible_range for n in names])
    return np.where(np.isfinite(std), np.maximum(in_std * np.nan_to_num(std), floor), np.inf)


def check_pairs(expected: list, actual: list, correlation: np.ndarray,
                names: tuple[str, ...], where: str) -> None:
    """The named pairs as a set, each to the decimals shown; a pair within 1e-5 of the
    naming threshold may be named on one side only; the order follows |r| as shown."""
    e = {(a, b): c for a, b, c in expected}
    a = {(x, y): c for x, y, c in actual}
    index = {n: k for k, n in enumerate(names)}
    for pair in e.keys() ^ a.keys():
        r = abs(correlation[index[pair[0]], index[pair[1]]])
        assert abs(r - NAMED_CORRELATION) < 1e-5, f"{where}: pair {pair} named on one side"
    for pair in e.keys() & a.keys():
        assert abs(a[pair] - e[pair]) <= SHOWN_CORRELATION * 1.001, f"{where}: {pair}"
    shown = [abs(c) for _, _, c in actual]
    assert shown == sorted(shown, reverse=True), f"{where}: pairs not largest first"


def check_fit(expected: dict, actual: dict, names: tuple[str, ...], where: str) -> None:
    # decisions
    for key in ("dof", "converged"):
        assert actual[key] == expected[key], f"{where}.{key}"
    ie, ia = expected["identifiability"], actual["identifiability"]
    for key in ("rank", "identifiable", "reasons", "unidentified"):
        assert ia[key] == ie[key], f"{where}.identifiability.{key}"
    check_noise(expected["noise"], actual["noise"], f"{where}.noise")

    # what the data fix
    fitted = FITTED_IN_NOISE * expected["noise"]["sigma_mm"]
    within(expected["residuals"], actual["residuals"], fitted, f"{where}.residuals")
    for key in ("residual_rms_mm", "sigma_mm"):
        within([expected[key]], [actual[key]], fitted, f"{where}.{key}")
    std = floats(expected["std"])
    within(expected["values"], actual["values"], value_tolerance(names, std, expected),
           f"{where}.values")
    within(expected["std"], actual["std"], STD_RELATIVE * np.nan_to_num(std, posinf=0.0),
           f"{where}.std")
    within(ie["correlation"], ia["correlation"], CORRELATION, f"{where}.correlation")
    within([ie["condition_number"]], [ia["condition_number"]],
           CONDITION_RELATIVE * np.nan_to_num(floats([ie["condition_number"]]), posinf=0.0),
           f"{where}.condition_number")
    jac = floats(np.ravel(expected["jacobian"]).tolist()).reshape(-1, len(names)) \
        if names else np.zeros((0, 0))
    column = np.linalg.norm(jac, axis=0) if jac.size else np.zeros(len(names))
    within(expected["jacobian"], actual["jacobian"],
           np.broadcast_to(JACOBIAN_IN_COLUMN * column + 1e-300, jac.shape),
           f"{where}.jacobian")
    free = [PARAM_INDEX[n] for n in names]
    theta_tolerance = np.zeros(len(PARAM_NAMES))
    theta_tolerance[free] = value_tolerance(names, std, expected)
    within(expected["theta"], actual["theta"], theta_tolerance, f"{where}.theta")

    # the refit --json object: the same, to its rounding
    ej, aj = expected["json"], actual["json"]
    assert ej.keys() == aj.keys(), where
    for key in ("params", "dof", "identifiable"):
        assert aj[key] == ej[key], f"{where}.json.{key}"
    flat = [n.split(".") for n in names]
    for key, tolerance in (("parameters", value_tolerance(names, std, expected)),
                           ("std", STD_RELATIVE * np.nan_to_num(std, posinf=0.0))):
        assert ej[key].keys() == aj[key].keys(), f"{where}.json.{key}"
        within([ej[key][e][w] for e, w in flat], [aj[key][e][w] for e, w in flat],
               tolerance + JSON_QUANTUM, f"{where}.json.{key}")
    for key in ("residual_rms_mm", "sigma_mm"):
        within([ej[key]], [aj[key]], fitted + JSON_QUANTUM, f"{where}.json.{key}")
    cond = floats([ej["condition_number"]])
    within(cond, [aj["condition_number"]],
           CONDITION_RELATIVE * np.nan_to_num(cond) + 1e-4, f"{where}.json.condition_number")
    check_pairs(ej["correlated_pairs"], aj["correlated_pairs"], floats(
        np.ravel(ie["correlation"]).tolist()).reshape(len(names), len(names)), names,
        f"{where}.json.correlated_pairs")


@pytest.fixture(scope="module")
def golden() -> dict:
    return json.loads(GOLDEN.read_text())


@pytest.mark.parametrize("case", sorted(json.loads(GOLDEN.read_text())["fits"])
                         if GOLDEN.exists() else [])
def test_fit_unchanged(golden, case):
    result = cases()[case]
    check_fit(golden["fits"][case], plain(summary(result)), result.names, case)


def test_noise_inversion_unchanged(golden):
    expected, actual = golden["scatter"], plain(scatter_cases())
    within(expected, actual, NOISE_RELATIVE * np.abs(floats(np.ravel(expected).tolist())),
           "scatter")


def test_every_case_is_checked(golden):
    """A case added above without regenerating the file would pass unchecked."""
    assert sorted(golden["fits"]) == sorted(cases())


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    GOLDEN.write_text(json.dumps({"fits": {k: plain(summary(v)) for k, v in cases().items()},
                                  "scatter": plain(scatter_cases())}) + "\n")
    print(f"wrote {GOLDEN}")
