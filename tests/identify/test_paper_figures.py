"""Every row of MODEL.md's "Figures the tool must reproduce", through the library."""

import numpy as np
import pytest

from ogacq.identify.fit import fit
from ogacq.identify.linear import design_matrix
from ogacq.identify.observations import PAPER_ORDER_12, deviations_observations
from ogacq.io.loading import load_observations
from ogacq.model.parameters import PARAM_SETS


def refit(paper_dir, paper_machine, name, params, **kw):
    obs = load_observations(paper_dir / f"{name}.csv", paper_machine)
    return fit(obs, PARAM_SETS[params], method=kw.pop("method", "linear"), **kw)


def test_exp2_offsets(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment2_12", "offsets")
    assert np.allclose(r.values, [-0.49, 0.50, -1.67], atol=0.02)
    assert r.residual_rms_mm == pytest.approx(0.138, abs=0.001)
    assert r.identifiability.identifiable
    assert r.identifiability.condition_number == pytest.approx(1.47, abs=0.01)


def test_exp2_lengths(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment2_12", "lengths")
    assert np.allclose(r.values, [0.49, -0.52, 1.69], atol=0.02)
    assert r.residual_rms_mm == pytest.approx(0.135, abs=0.001)


def test_exp2_both_is_not_identifiable(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment2_12", "both")
    assert r.residual_rms_mm == pytest.approx(0.126, abs=0.001)
    ident = r.identifiability
    assert ident.condition_number == pytest.approx(62, abs=1)
    assert not ident.identifiable
    pairs = {(a, b) for a, b, c in ident.correlated_pairs if c > 0.99}
    assert pairs == {(f"joint_offset.{a}", f"leg_length.{a}") for a in "xyz"}
    assert set(ident.unidentified) == set(PARAM_SETS["both"])


def test_exp2_both_values_span_the_published_angles(paper_machine, paper_dir):
    """The table's ranges hold the fit at asin(rho/L) and at the printed 11.0/-18.7 deg:
    with condition number 62 a 0.1 degree moves these values by 0.2 mm."""
    low = np.array([4.4, -5.6, 1.3, 4.9, -6.2, 3.0])
    high = np.array([4.7, -5.4, 1.5, 5.2, -6.0, 3.2])
    obs = load_observations(paper_dir / "experiment2_12.csv", paper_machine)
    published = np.linalg.lstsq(design_matrix(obs.labels, paper_machine, (11.0, -18.7)),
                                obs.values, rcond=None)[0]
    assert np.all((published >= low) & (published <= high))
    ours = refit(paper_dir, paper_machine, "experiment2_12", "both").values
    assert np.all((ours >= low - 0.06) & (ours <= high))


def test_exp1_six_equations_inconsistent(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment1_6", "offsets")
    assert np.allclose(r.residuals, [-0.98, 0.68, 1.07, -0.83, -0.30, 0.35], atol=0.01)
    assert r.residual_rms_mm == pytest.approx(0.76, abs=0.005)
    assert r.sigma_mm == pytest.approx(1.07, abs=0.01)
    assert r.sigma_mm > 50 * paper_machine.gauge_resolution_mm


def test_exp2_six_equations(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment2_6", "offsets")
    assert np.allclose(r.residuals, [-0.28, 0.25, 0.21, -0.14, -0.13, 0.09], atol=0.01)
    assert r.residual_rms_mm == pytest.approx(0.20, abs=0.005)
    assert r.sigma_mm == pytest.approx(0.28, abs=0.005)


def test_exp3_six_equations_nothing_left(paper_dir, paper_machine):
    r = refit(paper_dir, paper_machine, "experiment3_6", "offsets")
    assert np.allclose(r.residuals, [-0.29, 0.24, 0.25, -0.17, -0.10, 0.08], atol=0.01)
    assert r.residual_rms_mm == pytest.approx(0.21, abs=0.005)
    assert np.allclose(r.values, [0.07, 0.14, 0.00], atol=0.01)


@pytest.mark.parametrize("name", ["experiment1_6", "experiment2_6", "experiment3_6"])
def test_six_equation_both_has_rank_five(paper_dir, paper_machine, name):
    r = refit(paper_dir, paper_machine, name, "both")
    assert r.identifiability.rank == 5
    assert not r.identifiability.identifiable


@pytest.mark.parametrize(("params", "printed", "expected"),
                         [("offsets", 0.021, 0.0208), ("both", 0.74, 0.743)])
def test_eq12_14_accuracy_at_sigma_001(paper_machine, params, printed, expected):
    """sigma = 0.01 mm gives 0.021 / 0.74 mm (the paper's "0.07" matches sigma = 0.001)."""
    obs = deviations_observations(paper_machine, [(n, 0.0) for n in PAPER_ORDER_12])
    J = design_matrix(PAPER_ORDER_12, paper_machine, (11.0, -18.7))
    cols = [0, 1, 2] if params == "offsets" else list(range(6))
    A = np.linalg.pinv(J[:, cols])
    std = np.sqrt(np.diag(A @ obs.noise_cov @ A.T)) * 0.01
    assert np.allclose(std, expected, atol=0.001)
    assert np.allclose(std, printed, atol=0.005)  # printed to two digits
    # and at asin(rho / L), through the fit engine's own covariance
    r = fit(obs, PARAM_SETS[params], method="linear")
    assert np.allclose(r.std, expected, rtol=0.03)
    if params == "offsets":
        assert np.allclose(std / 10, 0.0021, atol=0.0002)  # sigma 0.001: nowhere near 0.07


def test_exact_fit_matches_linear_on_the_published_deviations(paper_dir, paper_machine):
    lin = refit(paper_dir, paper_machine, "experiment2_12", "offsets")
    exact = refit(paper_dir, paper_machine, "experiment2_12", "offsets", method="exact")
    assert exact.converged
    assert np.allclose(exact.values, lin.values, atol=0.01)


def test_gls_differs_from_ols_only_through_the_covariance(paper_dir, paper_machine):
    ols = refit(paper_dir, paper_machine, "experiment2_12", "offsets")
    gls = refit(paper_dir, paper_machine, "experiment2_12", "offsets", weighting="gls")
    # these residuals are 13x the gauge noise, so the two estimators may part by
    # more than their noise std, though not by more than the residual-scaled std (0.3)
    assert np.allclose(gls.values, ols.values, atol=0.1)
    # GLS is the efficient estimator: never a larger std than OLS
    assert np.all(gls.std <= ols.std + 1e-12)
