"""Honesty between the library and the maps: which out-of-library explanation fits
these readings as well as an effect found, and which measurement would tell them
apart.

The papers' postures read each joint at five positions, where a smooth screw error
passes for an encoder scale, a leg length, a backlash or a gauge's position. So each
library effect found is swapped for each map family fittable whatever the campaign
(a cubic screw map, each rail's bow), and each map for each library effect and other
family; a swap within ``search_rules.SWAP_CHI2`` is an alternative, the rule between
library effects. The swaps are linear about the final model: these columns barely
change over micrometres. For each pair the readings cannot tell apart, a scan is
proposed (every few millimetres along each leg, up and back down): the coarsest
whose expected chi-square gap fails the wrong one at the three-sigma rule with 95 %
probability (``separation.py``), on the exact model; ``ogacq plan --scan-step``
checks the plan itself."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ogacq.diagnose.alternatives import Alternative
from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.mapfit import MapFit, map_columns
from ogacq.diagnose.mapsearch import AxisCoverage
from ogacq.diagnose.mapspace import term_columns
from ogacq.diagnose.separation import SEPARATES_CHI2
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.observations import readings_observations
from ogacq.identify.search_rules import SWAP_CHI2
from ogacq.model.error_maps import JointHistory, MapTerm
from ogacq.model.families import FAMILIES
from ogacq.model.gauges import AXES
from ogacq.model.joint_sensitivity import JointSensitivity, joint_sensitivity
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import NOMINAL, PARAM_INDEX, effect_of
from ogacq.model.units import json_number
from ogacq.protocol.plan import ProtocolConfig, planned_layout, scan_targets

# Below this share of its own size a signature is wholly absorbed by the other
# explanation: that explanation holds it.
NESTED = 1e-9
# Scans tried, cheapest first: (step mm, cycles). Up and back down, so each
# position is read from both sides (ISO 230-2 4.3's bidirectional run).
SCANS = ((2.0, 1), (1.0, 1), (1.0, 3), (0.5, 3))


def swap_families(covs: tuple[AxisCoverage, ...], names: tuple[str, ...],
                  taken: set[str]) -> list[MapTerm]:
    """Map terms fitted whatever the campaign, each family's ``swap_terms`` on every
    axis (a cubic screw map, without its slope when the model has that axis's encoder
    scale, and each rail's bow)."""
    out = [t for cov in covs for family in FAMILIES.values()
           for t in family.swap_terms(cov.axis, cov.from_mm, cov.to_mm, names)]
    return [t for t in out if t.name not in taken and f"{t.family}.{AXES[t.axis]}" not in taken]


@dataclass(frozen=True, eq=False)
class _Linear:
    """The final model linearised: weighted columns of its library parameters and map
    terms, its weighted residual, the noise variance a swap is judged against."""

    problem: Problem
    names: tuple[str, ...]
    terms: list[MapTerm]
    columns: np.ndarray  # (m, p + K) weighted
    residual: np.ndarray  # (m,) weighted, at the final model
    rss: float
    var: float
    theta: np.ndarray
    coefficients: list[np.ndarray]
    history: JointHistory

    @cached_property
    def _sensitivity(self) -> tuple[JointSensitivity, tuple[np.ndarray, np.ndarray]]:
        sens = joint_sensitivity(self.theta, self.problem.obs.layout, self.problem.obs.machine)
        return sens, sens.along()

    def term_columns(self, term: MapTerm) -> np.ndarray:
        """(m, k) the term's weighted columns at the final model (the joints'
        sensitivities found once for every candidate)."""
        sens, along = self._sensitivity
        cols = term_columns(term, self.history, sens, along, self.problem.obs.layout.gauge)
        return self.problem.weighted(cols).T

    def without_effect(self, name: str) -> tuple[list[int], np.ndarray]:
        """The columns but library effect ``name``'s, and the residual with its
        signature back in: what a swap for it is fitted to."""
        keep = [k for k, n in enumerate(self.names) if n != name] + \
            list(range(len(self.names), self.columns.shape[1]))
        k = PARAM_INDEX[name]
        signature = self.columns[:, self.names.index(name)] * (self.theta[k] - NOMINAL[k])
        return keep, self.residual + signature

    def without_term(self, k: int) -> tuple[list[int], np.ndarray]:
        """As :meth:`without_effect` for the model's map term number ``k``."""
        start = len(self.names) + sum(t.size for t in self.terms[:k])
        stop = start + self.terms[k].size
        keep = [j for j in range(self.columns.shape[1]) if not start <= j < stop]
        return keep, self.residual + self.columns[:, start:stop] @ self.coefficients[k]

    def in_place(self, without: tuple[list[int], np.ndarray], term: MapTerm) -> np.ndarray:
        """The amplitudes of ``term`` fitted in place of what ``without`` leaves out (the
        columns kept and the target of :meth:`without_effect` or :meth:`without_term`),
        the columns scaled to unit norm first."""
        keep, target = without
        columns = np.column_stack([self.columns[:, keep], self.term_columns(term)])
        return _Projector(columns[:, :0]).fit(target, columns)[1][-term.size:]


class _Projector:
    """Fits of one target with a fixed set of columns (``rest``) and a few more that
    change: ``rest`` decomposed once, only the added columns' part beside it solved
    for each (the swaps try dozens of candidates over every reading)."""

    def __init__(self, rest: np.ndarray) -> None:
        norm = np.maximum(np.linalg.norm(rest, axis=0), 1e-300)
        self.norm = norm
        u, s, vt = np.linalg.svd(rest / norm, full_matrices=False) if rest.shape[1] \
            else (np.zeros((rest.shape[0], 0)), np.zeros(0), np.zeros((0, 0)))
        keep = s > (s[0] if len(s) else 0.0) * 1e-10
        self.u, self.s, self.vt = u[:, keep], s[keep], vt[keep]

    def _out(self, x: np.ndarray) -> np.ndarray:
        return x - self.u @ (self.u.T @ x)

    def fit(self, target: np.ndarray, columns: np.ndarray) -> tuple[float, np.ndarray]:
        """``columns`` are ``rest`` followed by the added ones: rss and coefficients of
        all of them."""
        p = len(self.norm)
        added = columns[:, p:]
        scale = np.maximum(np.linalg.norm(added, axis=0), 1e-300)
        beside = self._out(added / scale)
        left = self._out(target)
        coef_added, *_ = np.linalg.lstsq(beside, left, rcond=1e-10) if added.shape[1] \
            else (np.zeros(0),)
        rest_target = target - (added / scale) @ coef_added
        along = self.u.T @ rest_target
        coef_rest = (self.vt.T @ (along / self.s)) / self.norm if len(self.s) else \
            np.zeros(p)
        resid = left - beside @ coef_added
        return float(resid @ resid), np.concatenate([coef_rest, coef_added / scale])


def linearised(problem: Problem, noise: GaugeNoise, fitted: MapFit, history: JointHistory,
               inflation: float) -> _Linear:
    theta = fitted.theta
    # the fit's own Jacobian and weighted residual at its solution, weighted as
    # evaluating them again would
    lib = problem.weighted_jacobian(fitted.jacobian[:, :fitted.p])
    maps = problem.weighted(fitted.jacobian[:, fitted.p:].T).T if fitted.terms \
        else np.zeros((len(lib), 0))
    r = fitted.weighted_residuals
    return _Linear(problem, fitted.names, fitted.terms, np.column_stack([lib, maps]), r,
                   float(r @ r), noise.variance * inflation**2, theta, fitted.coefficients,
                   history)


def library_swaps(lin: _Linear, effects: tuple[str, ...],
                  candidates: list[MapTerm]) -> dict[str, list[tuple[MapTerm, Alternative]]]:
    """For each library effect, the map terms that take its place as well."""
    out: dict[str, list[tuple[MapTerm, Alternative]]] = {}
    blocks: dict[tuple, np.ndarray] = {}

    def block(term: MapTerm) -> np.ndarray:
        key = (term.name, tuple(sorted(term.shape.items())))
        if key not in blocks:
            blocks[key] = lin.term_columns(term)
        return blocks[key]

    for name in effects:
        keep, target = lin.without_effect(name)
        rest = lin.columns[:, keep]
        beside = _Projector(rest)
        found = []
        for candidate in candidates:
            term = candidate.kind.in_place_of(candidate, name)
            rss, coef = beside.fit(target, np.column_stack([rest, block(term)]))
            delta = (rss - lin.rss) / lin.var
            amplitude = coef[-term.size:]
            if delta < SWAP_CHI2 and term.size_mm(amplitude) <= term.kind.plausible_mm:
                theta = lin.theta.copy()
                theta[PARAM_INDEX[name]] = NOMINAL[PARAM_INDEX[name]]
                lib = [n for n in lin.names if n != name]
                theta[[PARAM_INDEX[n] for n in lib]] += coef[:len(lib)]
                found.append((term, Alternative(term.name, term.size_mm(amplitude),
                                                float(delta), theta)))
        out[name] = sorted(found, key=lambda t: t[1].delta_chi2)
    return out


def map_swaps(lin: _Linear, library: tuple[str, ...],
              candidates: list[MapTerm]) -> dict[str, list[Alternative]]:
    """For each map term of the final model, the library effects (not in the model)
    and the other map terms that take its place as well."""
    out: dict[str, list[Alternative]] = {}
    # every library column and candidate block at once: one evaluation of the model
    library_columns = lin.problem.jacobian(lin.theta, library) if library else \
        np.zeros((len(lin.residual), 0))
    blocks = {t.name: lin.term_columns(t) for t in candidates}
    for k, term in enumerate(lin.terms):
        keep, target = lin.without_term(k)
        rest = lin.columns[:, keep]
        beside = _Projector(rest)
        found = []
        for j, name in enumerate(library):
            rss, coef = beside.fit(target, np.column_stack([rest, library_columns[:, j]]))
            delta = (rss - lin.rss) / lin.var
            value = float(lin.theta[PARAM_INDEX[name]] + coef[-1])
            kind = effect_of(name)
            if delta < SWAP_CHI2 and abs(value - kind.nominal) <= kind.plausible_range:
                theta = lin.theta.copy()
                theta[PARAM_INDEX[name]] = value
                found.append(Alternative(name, value, float(delta), theta))
        for other in candidates:
            if other.name == term.name:
                continue
            rss, coef = beside.fit(target, np.column_stack([rest, blocks[other.name]]))
            delta = (rss - lin.rss) / lin.var
            size = other.size_mm(coef[-other.size:])
            if delta < SWAP_CHI2 and size <= other.kind.plausible_mm:
                found.append(Alternative(other.name, size, float(delta), lin.theta))
        out[term.name] = sorted(found, key=lambda a: a.delta_chi2)
    return out


# --- what would tell them apart ------------------------------------------------------------

@dataclass(frozen=True)
class Proposal:
    """A scan that separates ``first`` from ``second`` (effect or map names)."""

    first: str
    second: str
    step_mm: float | None  # None: none of the scans tried separates them
    cycles: int
    from_mm: float
    to_mm: float
    expected_gap: float  # chi-square by which the wrong one fits worse, on the scan
    now_gap: float  # on these readings: the second's chi-square minus the first's

    def command(self, machine_file: str = "M.toml") -> str:
        if self.step_mm is None:
            return ""
        return (f"ogacq plan --machine {machine_file} --scan-step {self.step_mm:g} "
                f"--scan-range {self.from_mm:g}:{self.to_mm:g} --cycles {self.cycles}")

    def describe(self, machine_file: str = "M.toml") -> str:
        if self.step_mm is None:
            return (f"none of the scans tried (down to {SCANS[-1][0]:g} mm, {SCANS[-1][1]} "
                    f"cycles) separates {self.first} from {self.second} (best expected gap "
                    f"{self.expected_gap:.1f}); a measurement of another kind is needed")
        return (f"to separate {self.first} from {self.second}: {self.scan_words()} (expected "
                f"chi-square gap {self.expected_gap:.0f}; on these readings {self.second} in "
                f"its place changes the chi-square by {self.now_gap:+.1f}; check with "
                f"`{self.command(machine_file)}`)")

    def scan_words(self) -> str:
        return (f"scan each leg every {self.step_mm:g} mm from {self.from_mm:+g} to "
                f"{self.to_mm:+g} mm, up and back down, {self.cycles} "
                f"cycle{'s' if self.cycles > 1 else ''}")

    def to_json(self, machine_file: str = "M.toml") -> dict:
        return {"separates": [self.first, self.second], "measurement": "scan",
                "step_mm": self.step_mm, "from_mm": self.from_mm, "to_mm": self.to_mm,
                "directions": "up and down", "cycles": self.cycles,
                "expected_chi2_gap": json_number(self.expected_gap, 1),
                "now_chi2_gap": json_number(self.now_gap, 2),
                "command": self.command(machine_file) or None,
                "text": self.describe(machine_file)}


# a scan's problem, history, and joint sensitivities with their along()
_Scan = tuple[Problem, JointHistory, tuple[JointSensitivity, tuple[np.ndarray, np.ndarray]]]


class ScanSignatures:
    """The final model's columns on each candidate scan, computed once and shared by
    every pair to separate."""

    def __init__(self, machine: MachineSpec, noise: GaugeNoise, theta: np.ndarray,
                 names: tuple[str, ...], terms: list[MapTerm]) -> None:
        self.machine, self.noise, self.theta = machine, noise, theta
        self.names, self.terms = names, terms
        # each scan's problem, history and joint sensitivities at theta with their
        # along() (every pair's columns ask for them), made once
        self._scans: dict[tuple[float, int], _Scan] = {}

    def plan(self, step: float, cycles: int) -> _Scan:
        key = (step, cycles)
        if key not in self._scans:
            config = ProtocolConfig(scan_step_mm=step, cycles=cycles)
            layout = planned_layout(config, self.machine)
            problem = Problem(readings_observations(self.machine, layout,
                                                    np.zeros(len(layout))), self.noise)
            sens = joint_sensitivity(self.theta, problem.obs.layout, self.machine)
            self._scans[key] = (problem, JointHistory.of(layout), (sens, sens.along()))
        return self._scans[key]

    def gap(self, step: float, cycles: int, first: tuple[np.ndarray, list[str], list[MapTerm]],
            second: tuple[np.ndarray, list[str], list[MapTerm]]) -> float:
        """Expected chi-square gap on the scan between two explanations, each given as
        (values, library names, map terms) of what it adds to the rest of the model;
        the smaller of the two ways."""
        problem, history, sensitivity = self.plan(step, cycles)
        rest_names = [n for n in self.names if n not in first[1] + second[1]]
        rest_terms = [t for t in self.terms if t.name not in
                      {u.name for u in first[2] + second[2]}]

        def columns(names: list[str], terms: list[MapTerm]) -> np.ndarray:
            lib = problem.jacobian(self.theta, tuple(names)) if names else \
                np.zeros((len(problem.obs), 0))
            maps = problem.weighted(map_columns(problem, self.theta, terms, history,
                                                sensitivity).T).T \
                if terms else np.zeros((len(problem.obs), 0))
            return np.column_stack([lib, maps])

        def signature(values: np.ndarray, names: list[str], terms: list[MapTerm]) -> np.ndarray:
            return columns(names, terms) @ values

        def rest_after(signal: np.ndarray, names: list[str], terms: list[MapTerm]) -> float:
            x = columns(rest_names + names, rest_terms + terms)
            norm = np.maximum(np.linalg.norm(x, axis=0), 1e-300)
            coef, *_ = np.linalg.lstsq(x / norm, signal, rcond=1e-10)
            left = signal - (x / norm) @ coef
            return float(left @ left) / self.noise.variance

        s1 = signature(*first)
        s2 = signature(*second)
        gaps = (rest_after(s1, second[1], second[2]), rest_after(s2, first[1], first[2]))
        # an explanation that holds the other (a screw map with its slope, against the
        # encoder scale) fits it whatever the scan: only the other way can fail, and a
        # scan separates them when it does
        held = [g <= NESTED * float(s @ s) / self.noise.variance
                for g, s in zip(gaps, (s1, s2), strict=True)]
        if held[0] != held[1]:
            return gaps[1] if held[0] else gaps[0]
        return min(gaps)


def propose(signatures: ScanSignatures, first: str, second: str,
            one: tuple[np.ndarray, list[str], list[MapTerm]],
            other: tuple[np.ndarray, list[str], list[MapTerm]], now_gap: float) -> Proposal:
    best = (0.0, SCANS[-1])
    machine = signatures.machine
    for step, cycles in SCANS:
        gap = signatures.gap(step, cycles, one, other)
        if gap >= SEPARATES_CHI2:
            config = ProtocolConfig(scan_step_mm=step, cycles=cycles)
            targets = scan_targets(config, machine)
            return Proposal(first, second, step, cycles, targets[0], targets[-1], gap, now_gap)
        best = max(best, (gap, (step, cycles)))
    return Proposal(first, second, None, best[1][1], machine.rho_min_mm, machine.rho_max_mm,
                    best[0], now_gap)


def exploration(machine: MachineSpec) -> Proposal:
    """The scan that maps every axis when no pair is in question: 1 mm, up and down."""
    config = ProtocolConfig(scan_step_mm=1.0, cycles=1)
    targets = scan_targets(config, machine)
    return Proposal("the effects found", "an error along q", 1.0, 1, targets[0], targets[-1],
                    math.nan, math.nan)


__all__ = ["Proposal", "ScanSignatures", "exploration", "library_swaps",
           "linearised", "map_swaps", "propose", "swap_families"]
