"""Which effects can these data identify beside the joint offsets, and which can
they not tell apart?

An effect's signature is what it does to the observations per unit. The offsets
absorb the part of it that looks like an encoder zero error; only the rest can be
seen. From that rest follow the effect's std (at the verdict noise), the smallest
value that would show (three std), and its correlation with every other effect's
rest: above 0.99 the two are aliases that these data cannot separate at any
realistic noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS
from ogacq.identify.identifiability import INSEPARABLE_CORRELATION, RANK_TOLERANCE, assess
from ogacq.model.parameters import effect_of

ALIAS_CORRELATION = INSEPARABLE_CORRELATION
DETECTION_STDS = 3.0  # a value shows once it is this many std from zero


@dataclass(frozen=True)
class Visibility:
    name: str
    std: float  # beside the joint offsets, at the verdict noise; inf: not seen at all
    absorbed: float  # fraction of its signature (sum of squares) the offsets absorb
    aliases: tuple[tuple[str, float], ...]  # effects with a correlated visible part

    @property
    def unit(self) -> str:
        return effect_of(self.name).unit

    @property
    def visible(self) -> bool:
        return bool(np.isfinite(self.std))

    @property
    def detectable(self) -> float:
        """The smallest magnitude these data would show (three std)."""
        return DETECTION_STDS * self.std

    @property
    def identifiable(self) -> bool:
        return self.visible and self.detectable <= effect_of(self.name).plausible_range


@dataclass
class Capability:
    """What a data set can decide about the effect library."""

    n_data: int  # independent observations (gauge zeros removed)
    dof_after_offsets: int
    effect_rank: int  # independent effect directions the data see beside the offsets
    visibility: dict[str, Visibility]

    def invisible(self) -> list[str]:
        return [n for n, v in self.visibility.items() if not v.visible]

    def weak(self) -> list[str]:
        return [n for n, v in self.visibility.items() if v.visible and not v.identifiable]

    def identifiable(self) -> list[str]:
        return [n for n, v in self.visibility.items() if v.identifiable]

    @property
    def saturated(self) -> bool:
        """Fewer observations left than effect directions: any set of that many
        independent effects fits the data exactly, so the data cannot choose."""
        return self.effect_rank >= self.dof_after_offsets

    def alias_groups(self) -> list[list[str]]:
        """Effects linked by alias correlations, each group listed once."""
        seen: set[str] = set()
        groups = []
        for name in self.visibility:
            if name in seen or not self.visibility[name].aliases:
                continue
            group, todo = [], [name]
            while todo:
                n = todo.pop()
                if n in seen:
                    continue
                seen.add(n)
                group.append(n)
                todo.extend(a for a, _ in self.visibility[n].aliases if a not in seen)
            groups.append(sorted(group, key=EFFECT_PARAMETERS.index))
        return groups


def capability(jw: np.ndarray, names: tuple[str, ...], sigma_mm: float,
               n_data: int) -> Capability:
    """Visibility of every effect of the library from a weighted Jacobian ``jw``
    (m, p) whose columns are ``names`` (the offsets and every effect)."""
    col = {n: k for k, n in enumerate(names)}
    offsets = jw[:, [col[n] for n in BASE_MODEL]]
    q, s, _ = np.linalg.svd(offsets, full_matrices=False)
    q = q[:, s > s[0] * RANK_TOLERANCE]
    effects = jw[:, [col[n] for n in EFFECT_PARAMETERS]]
    rest = effects - q @ (q.T @ effects)  # what the offsets cannot absorb
    raw_norm = np.linalg.norm(effects, axis=0)
    rest_norm = np.linalg.norm(rest, axis=0)
    scale = np.array([effect_of(n).plausible_range for n in EFFECT_PARAMETERS])
    seen = rest_norm * scale > np.max(raw_norm * scale, initial=0.0) * 1e-6
    unit_rest = np.where(seen, rest / np.where(seen, rest_norm, 1.0), 0.0)
    corr = unit_rest.T @ unit_rest

    visibility = {}
    for k, name in enumerate(EFFECT_PARAMETERS):
        if seen[k]:
            ident, cov = assess(jw[:, [col[n] for n in (*BASE_MODEL, name)]], None,
                                (*BASE_MODEL, name), sigma_mm)
            std = float(np.sqrt(cov[-1, -1])) if ident.rank == len(BASE_MODEL) + 1 \
                else float("inf")
        else:
            std = float("inf")
        aliases = tuple((EFFECT_PARAMETERS[j], float(corr[k, j]))
                        for j in np.argsort(-np.abs(corr[k]))
                        if j != k and seen[j] and abs(corr[k, j]) > ALIAS_CORRELATION)
        absorbed = 1.0 - (rest_norm[k] / raw_norm[k]) ** 2 if raw_norm[k] > 0 else 1.0
        visibility[name] = Visibility(name, std if np.isfinite(std) else float("inf"),
                                      float(absorbed), aliases)

    seen_rest = rest[:, seen] * scale[seen]
    sv = np.linalg.svd(seen_rest, compute_uv=False) if seen.any() else np.zeros(0)
    effect_rank = int(np.sum(sv > sv[0] * RANK_TOLERANCE)) if len(sv) and sv[0] > 0 else 0
    return Capability(n_data, n_data - q.shape[1], effect_rank, visibility)
