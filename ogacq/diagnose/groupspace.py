"""Candidate fits of raw readings on their repeat groups' means, exactly.

A repeat group's readings share one prediction unless thermal drift is modelled.
Whitened by ``noise.GroupWhitener``, a residual's part within the groups is one no
parameter changes, so the weighted rss is a constant plus the squared norm of ``G``
group coordinates, and a fit needs the model at one reading per group (24 for the
papers' plan however many cycles)."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import replace
from functools import cached_property

import numpy as np

from ogacq.diagnose.posenodes import NodeSpace, PoseNodes, node_rows, pose_nodes
from ogacq.identify.fit import Weighting
from ogacq.identify.observations import Observations
from ogacq.model.measurement import ReadingsLayout, predict_coordinates, predict_jacobian
from ogacq.model.parameters import AXES, indices

_DRIFT = np.array(indices([f"thermal_drift.{a}" for a in AXES]))


class GroupSpace:
    """The weighted residuals of raw readings as ``G`` group-mean coordinates, for
    parameter vectors without thermal drift (the caller's to check)."""

    def __init__(self, obs: Observations, weighting: Weighting) -> None:
        groups = weighting.groups
        assert groups is not None, "raw readings only"
        self.obs = obs
        self._groups = groups
        n_groups = len(groups.size)
        first = np.full(n_groups, len(obs))
        np.minimum.at(first, groups.group, np.arange(len(obs)))
        kept = np.sort(first)  # one reading per group, in the order of the readings
        self._kept = kept
        one_each = np.zeros(len(obs), dtype=bool)
        one_each[kept] = True
        self.layout = obs.layout.subset(one_each)
        self._order = groups.group[kept]  # the group of each kept reading
        means = groups.group_means(obs.values)
        within = obs.values - means[groups.group]
        # what no prediction changes: the whitened scatter about the group means
        self.constant_rss = float(np.sum(within**2)) * groups.within_scale**2
        self._mean = means[self._order]
        # a group mean's whitened coordinate per mm of residual
        self._scale = groups.mean_scale[self._order] * np.sqrt(groups.size[self._order])
        zeros = np.eye(self.layout.n_gauges)[self.layout.gauge] * self._scale[:, None]
        self._zeros = zeros / np.sqrt(np.sum(zeros**2, axis=0))  # orthonormal columns
        # the exact prediction at the last fit's start, at every group and at the nodes
        self._reference: tuple[np.ndarray, np.ndarray] | None = None

    def with_side(self, obs: Observations) -> GroupSpace:
        """This space for ``obs``, the same readings with another lost-motion side
        (``ReadingsLayout.with_side``): the groups, their means and the zeros' basis
        are the same; only the model's layout takes the new side."""
        out = copy.copy(self)
        out.obs = obs
        out.layout = self.layout.with_side(obs.layout.lost_motion_side[self._kept])
        for derived in ("_nodes", "_node_layout", "_node_layout_at_an_hour"):  # the
            # tracks follow the sides
            out.__dict__.pop(derived, None)
        out._reference = None
        return out

    def __len__(self) -> int:
        return len(self._order)

    def _project(self, x: np.ndarray) -> np.ndarray:
        """Remove what the gauge zeros absorb, along the last axis."""
        return x - (x @ self._zeros) @ self._zeros.T

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """(B, G) weighted residual coordinates: their squared norm plus
        ``constant_rss`` is the weighted residual sum of squares. A dense scan's
        are evaluated at its nodes (``posenodes.py``): the change from the exact
        prediction at the fit's start (``start_at``), interpolated."""
        return self._project((self._mean - self._predicted(theta)) * self._scale)

    def start_at(self, theta: np.ndarray) -> np.ndarray:
        """(G,) the exact residual coordinates at a fit's start ``theta`` (N,), kept as
        the reference the residuals near it are interpolated from."""
        predicted = predict_coordinates(theta[None], self.layout, self.obs.machine)
        nodes = self._nodes
        self._reference = None if nodes is None else (predicted, predicted[:, nodes.nodes])
        return self._project((self._mean - predicted) * self._scale)[0]

    def node_space(self, theta: np.ndarray) -> NodeSpace | None:
        """A dense scan's fits from ``theta`` (N,) in the compressed rows of its nodes
        (``posenodes.NodeSpace``): the same sums of squares as :meth:`residuals`
        from :meth:`start_at` there, at the cost of the nodes, not of the groups.
        None where the groups are no denser than the nodes."""
        nodes = self._nodes
        if nodes is None:
            return None
        predicted = predict_coordinates(np.asarray(theta, dtype=float)[None], self.layout,
                                        self.obs.machine)[0]
        start = self._project((self._mean - predicted) * self._scale)
        rows = node_rows(nodes, self._scale, start, self.layout.gauge)
        return NodeSpace(rows, self._node_layout, self.obs.machine, predicted[nodes.nodes],
                         self.constant_rss)

    def _predicted(self, theta: np.ndarray) -> np.ndarray:
        nodes = self._nodes
        if nodes is None or self._reference is None:
            return predict_coordinates(theta, self.layout, self.obs.machine)
        full, at_nodes = self._reference
        change = predict_coordinates(theta, self._node_layout, self.obs.machine) - at_nodes
        return full + nodes.interpolate(change)

    @cached_property
    def _nodes(self) -> PoseNodes | None:
        return pose_nodes(self.layout)

    @cached_property
    def _node_layout(self) -> ReadingsLayout:
        assert self._nodes is not None
        keep = np.zeros(len(self.layout), dtype=bool)
        keep[self._nodes.nodes] = True
        return self.layout.subset(keep)

    def reading_jacobian(self, theta: np.ndarray, free: np.ndarray) -> np.ndarray | None:
        """(n, p) every reading's unweighted Jacobian by ``free`` at ``theta`` (N),
        without drift, for a dense scan: evaluated at the nodes and interpolated as
        :meth:`residuals` interpolates a change. A drift's column is the joint
        offset's times the reading's hours: evaluated an hour in, then scaled. None
        without nodes, or where a group's readings differ in their lost motion's side."""
        nodes = self._nodes
        if nodes is None:
            return None
        readings = self.obs.layout
        row = self._row_of_reading
        if not np.array_equal(readings.lost_motion_side,
                              self.layout.lost_motion_side[row]):
            return None
        at_nodes = predict_jacobian(np.asarray(theta, dtype=float)[None],
                                    self._node_layout_at_an_hour, self.obs.machine, free)[0]
        out = nodes.interpolate(at_nodes.T).T[row]
        drift = np.flatnonzero(np.isin(free, _DRIFT))
        out[:, drift] *= (readings.t_s / 3600.0)[:, None]
        return out

    @cached_property
    def _row_of_reading(self) -> np.ndarray:
        """(n,) each reading's group's row in :attr:`layout`."""
        row_of_group = np.empty(len(self._order), dtype=int)
        row_of_group[self._order] = np.arange(len(self._order))
        return row_of_group[self._groups.group]

    @cached_property
    def _node_layout_at_an_hour(self) -> ReadingsLayout:
        """The nodes read an hour in: a drift's derivative is then its factor of pose."""
        layout = self._node_layout
        return replace(layout, t_s=np.full(len(layout), 3600.0))

    def jacobian_at(self, theta: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """(G, p) the weighted Jacobian of the named parameters at ``theta`` (without
        drift) in group coordinates, from the model at one reading per group: the
        same as the group coordinates of the readings' weighted Jacobian (its rows
        are constant within a group), without evaluating it at every reading."""
        jac = predict_jacobian(np.asarray(theta, dtype=float)[None], self.layout,
                               self.obs.machine, np.array(indices(names), dtype=int))[0]
        return self._project((jac * self._scale[:, None]).T).T
