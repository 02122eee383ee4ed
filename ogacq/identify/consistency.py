"""Is a fit within the gauge noise? The one test that the diagnosis, the write-back
gate, the report, the CLI and the wizard all ask, with one noise (``noise.py``).

The residuals are taken into the space where the readings' errors are independent
(the generalised least-squares residual), where they split into the misfit of each
posture's mean (lack of fit) and the cycles' scatter about it (pure error).

- Noise stated: chi-square of the whole residual; only the posture means against
  their own variance when repeats round alike (their scatter is whole-step flips,
  not Gaussian noise).
- Noise measured from the repeats: the lack-of-fit F-test of the posture means, its
  denominator's dof Satterthwaite's (the repeats' scatter plus the rounding they
  share). Identical repeats stand for the largest scatter under which they would
  read identically 1 time in 100 (``noise.identical_repeats_scatter``).
- Tabulated deviations: chi-square against their covariance (eq. 13-14).

A misfit confined to one gauge at one posture (a knocked stand) hardly moves the
overall sum, so the worst cell is tested too, Bonferroni-corrected over the cells;
the verdict's p is the smaller of the two, doubled. With no redundancy left the
verdict is "undetermined"."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ogacq.identify.distributions import chi2_sf, f_sf
from ogacq.identify.fit import FitResult, Weighting
from ogacq.identify.identifiability import RANK_TOLERANCE
from ogacq.identify.noise import (
    IDENTICAL_REPEATS_LEVEL,
    GaugeNoise,
    GroupWhitener,
    noise_for,
    read_identically,
)
from ogacq.identify.observations import Deviation, Observations
from ogacq.model.kinematics import nominal_tcp
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.model.units import UM_PER_MM

# The level every consumer judges at. 1 % rather than 5 %: a false "inconsistent"
# sends someone to re-tune a machine or withholds a good write-back, and the
# effect search only runs past this gate, so it also bounds the rate of effects
# claimed on a machine that has none.
LEVEL = 0.01
SATTERTHWAITE_CAP = 1e6  # beyond this the denominator is known: chi-square


@dataclass(frozen=True)
class CellTest:
    """The worst cell (one gauge at one posture, or one tabulated deviation)."""

    cell: str  # "y_x at max"
    chi2: float  # its misfit in units of the noise variance
    expected: float  # what noise alone would leave there
    p_value: float  # corrected for the number of cells looked at
    cells: int


@dataclass(frozen=True)
class Verdict:
    """Whether a fit's residuals are within the gauge noise: the test, its statistic
    and p, and the worst cell."""

    state: str  # "consistent", "inconsistent" or "undetermined"
    test: str  # "chi-square", "lack-of-fit F" or "none"
    statistic: float  # chi2, or F
    dof: int
    noise_dof: float | None  # denominator dof of the F-test
    overall_p: float  # of the overall test alone
    p_value: float  # of the verdict (overall and worst cell, Bonferroni-combined)
    level: float
    rss: float  # weighted residual sum of squares, mm^2 (all of it)
    rms_mm: float  # residual rms, gauge zeros removed
    noise: GaugeNoise
    worst_cell: CellTest | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def consistent(self) -> bool:
        return self.state == "consistent"

    @property
    def judged(self) -> bool:
        return self.state != "undetermined"

    @property
    def chi2_dof(self) -> float:
        """The test statistic per degree of freedom: 1 when the fit is within the noise."""
        if not self.judged:
            return math.nan
        return self.statistic if self.test == "lack-of-fit F" else self.statistic / self.dof

    @property
    def inflation(self) -> float:
        """The Birge ratio, at least 1: the factor on a std for the misfit left unexplained."""
        chi2_dof = self.chi2_dof
        return math.sqrt(max(1.0, chi2_dof)) if math.isfinite(chi2_dof) else 1.0

    def headline(self) -> str:
        """Three words for a table: the same words everywhere."""
        return {"consistent": "within the gauge noise",
                "inconsistent": "NOT within the gauge noise",
                "undetermined": "cannot be judged"}[self.state]

    def describe(self) -> str:
        if not self.judged:
            return f"{self.headline()}: {'; '.join(self.notes)}"
        name = "chi2" if self.test == "chi-square" else "F"
        denominator = (f", {self.noise_dof:.0f}" if self.noise_dof is not None else "")
        text = (f"{self.headline()} ({self.test} test: {name}({self.dof}{denominator}) = "
                f"{self.statistic:.4g}{self._denominator_words()}, overall p = "
                f"{format_p(self.overall_p)}; per dof "
                f"{self.chi2_dof:.3g}, rms {self.rms_mm * UM_PER_MM:.3g} µm, noise "
                f"{self.noise.sigma_mm * UM_PER_MM:.3g} µm from the {self.noise.source})")
        if self.worst_cell is not None:
            c = self.worst_cell
            text += (f"; worst cell {c.cell}: chi2 {c.chi2:.3g} for {c.expected:.2g} expected, "
                     f"cell p = {format_p(c.p_value)} over {c.cells} cells; combined p = "
                     f"{format_p(self.p_value)}")
        return text + f"; judged at the {self.level:g} level"

    def _denominator_words(self) -> str:
        """What the F test's second number counts where it is no count of readings: the
        effective degrees of freedom of a posture mean's noise, of which the repeats
        measure a part and the display's rounding, known, makes up the rest
        (Satterthwaite): "F(11, 17897)" for 72 readings read as a misprint."""
        measured = self.noise.dof
        # near the repeats' own count (52 of 72 readings: 55) it reads as that count
        if self.noise_dof is None or measured is None or self.noise_dof < 1.5 * measured:
            return ""
        return (f" ({self.noise_dof:.0f}: the noise's effective degrees of freedom, "
                f"{measured} from the repeats' scatter and the rest from the display's "
                "rounding, which is known; Satterthwaite)")

    def summary(self) -> str:
        """One line for the end of a campaign: the state and the p it was judged by."""
        if not self.judged:
            return f"{self.headline()}: {'; '.join(self.notes)}"
        which = "combined p" if self.worst_cell is not None else "p"
        return (f"{self.headline()} ({self.test} test, {which} = {format_p(self.p_value)}, "
                f"judged at the {self.level:g} level)")

    def to_json(self) -> dict:
        """The verdict of INTERCHANGE.md's diagnosis JSON, exactly."""
        chi2_dof = self.chi2_dof
        return {"chi2_dof": round(chi2_dof, 4) if math.isfinite(chi2_dof) else None,
                "rms_mm": round(self.rms_mm, 6), "consistent": self.consistent}

    def to_record(self) -> dict:
        """Everything the verdict rests on, for audit records and ``--json`` beyond
        the diagnosis contract."""
        return {**self.to_json(), "verdict": self.state, "test": self.test,
                "statistic": self.statistic, "dof": self.dof, "noise_dof": self.noise_dof,
                "p_value": self.p_value, "level": self.level,
                "noise_mm": self.noise.sigma_mm, "noise_source": self.noise.source,
                "notes": list(self.notes)}


def format_p(p: float) -> str:
    return f"{p:.3g}" if p >= 1e-4 else f"{p:.1e}"


def fit_verdict(result: FitResult, level: float = LEVEL) -> Verdict:
    """The verdict on a finished fit."""
    return judge(result.observations, result.residuals, result.jacobian,
                 result.identifiability.rank, result.noise, level)


def judge(obs: Observations, residuals: np.ndarray, jac: np.ndarray, rank: int,
          noise: GaugeNoise | None = None, level: float = LEVEL) -> Verdict:
    """The verdict on a fit of ``obs`` with ``residuals`` (observed minus predicted,
    gauge zeros removed, mm), unweighted Jacobian ``jac`` (m, p) at the solution and
    ``rank`` parameters determined."""
    noise = noise or noise_for(obs)
    weighting = Weighting(obs, "gls", noise)
    rw = weighting.residual(np.asarray(residuals, float)[None])[0]
    jw = weighting.jac(np.asarray(jac, float)[None])[0]
    basis = _column_basis(jw, rank)
    rw = rw - basis @ (basis.T @ rw)  # the GLS residual, whatever fit gave these
    rss = float(rw @ rw)
    rms = float(np.sqrt(np.mean(np.square(residuals)))) if len(residuals) else math.nan
    dof = len(obs) - obs.n_nuisance - rank
    notes = list(_noise_notes(noise))

    def verdict(state: str | None, test: str = "none", statistic: float = math.nan,
                test_dof: int = dof, noise_dof: float | None = None, overall: float = 1.0,
                cell: CellTest | None = None) -> Verdict:
        combined = overall if cell is None else min(1.0, 2.0 * min(overall, cell.p_value))
        if state is None:
            state = "consistent" if combined >= level else "inconsistent"
        return Verdict(state, test, statistic, test_dof, noise_dof, overall, combined, level,
                       rss, rms, noise, cell, tuple(notes))

    if dof <= 0 or noise.variance <= 0:
        notes.insert(0, f"no redundancy left ({dof} degrees of freedom after "
                        f"{rank} parameters and {obs.n_nuisance} gauge zeros)")
        return verdict("undetermined", test_dof=max(dof, 0))
    if not obs.raw:
        chi2 = rss / noise.variance
        cell = _deviation_cell(obs, rw, basis, noise)
        return verdict(None, "chi-square", chi2, dof, None, float(chi2_sf(dof, chi2)),
                       cell)

    groups = weighting.groups
    assert groups is not None
    u = groups.group_space(rw)
    lack_ss = float(u @ u)
    pure_dof = len(obs) - len(groups.size)
    lack_dof = dof - pure_dof
    tests_means_only = noise.measured or not noise.dithered
    if tests_means_only and lack_dof <= 0:
        notes.insert(0, "every posture was read once per cycle and the rest of the "
                        "readings measure the noise: nothing is left to test the model with")
        return verdict("undetermined", test_dof=0)
    if noise.measured:
        noise_dof = _satterthwaite(noise, groups.size, pure_dof)
        f_stat = lack_ss / noise.variance / lack_dof
        overall = (float(chi2_sf(lack_dof, f_stat * lack_dof)) if noise_dof is None
                   else float(f_sf(lack_dof, noise_dof, f_stat)))
        cell = _readings_cell(obs, groups, u, basis, noise, noise_dof)
        return verdict(None, "lack-of-fit F", f_stat, lack_dof, noise_dof, overall, cell)
    if noise.dithered:
        chi2 = rss / noise.variance
        test_dof = dof
    else:
        chi2, test_dof = lack_ss / noise.variance, lack_dof
        notes.append("the cycles' scatter about each posture mean is a few whole display "
                     "steps at most and is not tested; the posture means are")
    cell = _readings_cell(obs, groups, u, basis, noise, None)
    return verdict(None, "chi-square", chi2, test_dof, None,
                   float(chi2_sf(test_dof, chi2)), cell)


def _noise_notes(noise: GaugeNoise) -> list[str]:
    notes = []
    if noise.assumed:
        notes.append(f"the noise is assumed to be the {noise.step_mm:g} mm display step: "
                     "no repeats, and none stated (gauge_repeatability_mm)")
    if noise.rounding_dominated:
        mean_sd = math.sqrt(noise.shared_var) * UM_PER_MM
        notes.append(f"the {noise.step_mm * UM_PER_MM:g} µm display step dominates: the cycles "
                     f"round alike, so a posture mean is known to about ±{mean_sd:.1f} µm "
                     "however many cycles; a misfit smaller than that cannot be told "
                     "from rounding")
    if noise.measured and noise.pure_error_ss is not None and noise.dof and \
            read_identically(noise.pure_error_ss, noise.dof, noise.step_mm):
        scatter_um = (noise.scatter_mm or 0.0) * UM_PER_MM
        notes.append("the repeats read identically: the gauge scatters less than its "
                     f"display shows, and the fit is judged against the whole rounding and "
                     f"a scatter of {scatter_um:.2g} µm, the largest under which so many "
                     f"repeats read identically {IDENTICAL_REPEATS_LEVEL:.0%} of the time")
    stated, seen = noise.scatter_mm, noise.repeats_scatter_mm
    if not noise.measured and stated is not None and seen is not None and seen > 2 * stated:
        notes.append(f"the repeats scatter {seen * UM_PER_MM:.2g} µm, more than the "
                     f"{stated * UM_PER_MM:.2g} µm the machine file states")
    return notes


def _satterthwaite(noise: GaugeNoise, sizes: np.ndarray, pure_dof: int) -> float | None:
    """Degrees of freedom of a posture mean's variance ``w/n + c``, of which only ``w``
    is measured (with ``pure_dof``); None when ``w`` is negligible (chi-square)."""
    n = float(np.mean(sizes))
    within = noise.within_var / n
    if within <= 0:
        return None
    nu = pure_dof * ((within + noise.shared_var) / within) ** 2
    return None if nu > SATTERTHWAITE_CAP else nu


def _column_basis(jw: np.ndarray, rank: int) -> np.ndarray:
    if rank <= 0 or jw.size == 0:
        return np.zeros((jw.shape[0], 0))
    u, s, _ = np.linalg.svd(jw, full_matrices=False)
    keep = min(rank, int(np.sum(s > s[0] * RANK_TOLERANCE))) if s[0] > 0 else 0
    return u[:, :keep]


def _cells_p(blocks: np.ndarray, chi2: np.ndarray, noise_dof: float | None) -> np.ndarray:
    """Conservative p of each cell's misfit ``sum(l_i chi2_1)`` (``l_i`` the eigenvalues
    of its block of the residual covariance), for a stack of cells (C, k, k): at most
    ``l_max`` times a chi-square (or an F with the noise's dof) with as many dof as
    nonzero ``l_i``; NaN where nothing is left to test. One eigen-decomposition and one
    distribution call for all of them."""
    eig = np.linalg.eigvalsh(blocks)
    live = eig > 1e-9
    k = live.sum(axis=1)
    tested = k > 0
    out = np.full(len(blocks), np.nan)
    if not tested.any():
        return out
    scaled = chi2[tested] / eig[tested].max(axis=1)
    dof = k[tested]
    out[tested] = (chi2_sf(dof, scaled) if noise_dof is None
                   else f_sf(dof, noise_dof, scaled / dof))
    return out


def _readings_cell(obs: Observations, groups: GroupWhitener, u: np.ndarray, basis: np.ndarray,
                   noise: GaugeNoise, noise_dof: float | None) -> CellTest | None:
    """The worst gauge-at-posture cell, tested on the posture means (group space):
    ``u`` is the mean part of the residual, ``basis`` the fitted directions (whitened,
    orthonormal, in reading space). Under noise alone ``u`` has covariance
    ``I - e e' - M B B' M'`` (``M`` taking reading space to group space, ``e`` each
    gauge's zero), of which each cell's block is formed. Cells of equal size are
    tested as one stack, so that thousands of postures cost no Python loop each."""
    cell_of_group = _group_cells(obs, groups.group, len(groups.size))
    fitted = groups.group_space(basis.T).T
    gauge_of_group = np.zeros(len(groups.size), dtype=int)
    gauge_of_group[groups.group] = obs.layout.gauge
    zero_dir = np.sqrt(groups.size) * groups.mean_scale
    zero_norm = np.sqrt(np.bincount(gauge_of_group, weights=zero_dir**2))
    names, first, cell = np.unique(cell_of_group, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # cells in order of first appearance
    rank_of_cell = np.empty(len(names), dtype=int)
    rank_of_cell[order] = np.arange(len(names))
    cell = rank_of_cell[cell.ravel()]
    names = names[order]
    members = np.argsort(cell, kind="stable")  # groups, cell by cell
    sizes = np.bincount(cell, minlength=len(names))
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    p = np.full(len(names), np.nan)
    chi2 = np.bincount(cell, weights=u**2, minlength=len(names)) / noise.variance
    trace = np.zeros(len(names))
    for size in sorted(set(sizes.tolist())):  # np.unique would import numpy.ma: 10 ms
        cells = np.flatnonzero(sizes == size)
        sel = members[starts[cells][:, None] + np.arange(size)]  # (C, size) groups
        e = zero_dir[sel] / zero_norm[gauge_of_group[sel[:, 0]]][:, None]
        f = fitted[sel]  # (C, size, rank)
        blocks = (np.eye(size) - e[:, :, None] * e[:, None, :]
                  - np.einsum("csr,ctr->cst", f, f))
        p[cells] = _cells_p(blocks, chi2[cells], noise_dof)
        trace[cells] = np.trace(blocks, axis1=1, axis2=2)
    if np.all(np.isnan(p)):
        return None
    worst = int(np.nanargmin(p))  # the first of equals, in order of appearance
    return CellTest(str(names[worst]), float(chi2[worst]), float(trace[worst]),
                    min(1.0, float(p[worst]) * len(names)), len(names))


def _group_cells(obs: Observations, group: np.ndarray, n_groups: int) -> np.ndarray:
    """For each repeat group, its cell: ``"y_x at max"``."""
    lay = obs.layout
    tcp = np.where(np.isfinite(lay.tcp_mm), lay.tcp_mm,
                   nominal_tcp(lay.q_mm, obs.machine.leg_length_mm))
    along = tcp[np.arange(len(lay)), lay.leg]
    first = np.zeros(n_groups, dtype=int)
    first[group[::-1]] = np.arange(len(group))[::-1]
    # each distinct position named once and joined to its gauge and leg by array
    # operations: a dense scan has as many groups as readings
    positions, at = np.unique(along[first], return_inverse=True)
    names = np.array([posture_name(p, obs.machine) for p in positions.tolist()], dtype=str)
    gauges = np.array([f"{g}_{leg} at " for g in AXES for leg in AXES], dtype=str)
    which = lay.gauge_axis[first] * len(AXES) + lay.leg[first]
    return np.char.add(gauges[which], names[at.reshape(-1)])


def posture_name(position_mm: float, machine: MachineSpec) -> str:
    for name, value in (("zero", 0.0), ("max", machine.rho_max_mm),
                        ("min", machine.rho_min_mm)):
        if abs(position_mm - value) < 1e-6:
            return name
    return f"{position_mm:+g} mm"


def _deviation_cell(obs: Observations, rw: np.ndarray, basis: np.ndarray,
                    noise: GaugeNoise) -> CellTest | None:
    """The worst tabulated deviation, its GLS residual against its own variance."""
    cov = obs.noise_cov
    chol = np.linalg.cholesky(cov)
    residual = chol @ rw  # back from the whitened space
    resid_cov = chol @ (np.eye(len(rw)) - basis @ basis.T) @ chol.T  # units sigma^2
    expected = resid_cov.diagonal() / cov.diagonal()
    chi2 = residual**2 / (noise.variance * cov.diagonal())
    p = _cells_p(expected[:, None, None], chi2, None)
    if np.all(np.isnan(p)):
        return None
    worst = int(np.nanargmin(p))  # the first of equals
    deviation = Deviation.parse(obs.labels[worst])  # every label is (deviations_observations)
    return CellTest(f"{deviation.gauge.key} at {deviation.posture}", float(chi2[worst]),
                    float(expected[worst]), min(1.0, float(p[worst]) * len(p)), len(p))
