"""A dense scan's model evaluated at nodes along each scanned track and interpolated.

A scan at a fine step has as many repeat groups as readings (71,000 at 0.027 mm),
where the model changes by micrometres over a millimetre. What a fit changes of a
prediction is smooth along a scanned leg's track (one gauge, one approach side), so
the change is evaluated at nodes ``NODE_SPACING_MM`` apart and interpolated
linearly; the reference prediction is exact at every group. The error is an eighth
of the spacing squared times the change's curvature: 3e-8 mm for 0.1 mm over the
310 mm legs at 0.5 mm spacing; under 1e-6 mm for every parameter kind at once
(tests/diagnose/test_scan_positions.py). The groups between two nodes compress into
two rows (``NodeRows``), so a candidate costs its nodes (``NodeSpace``) with the
same sums of squares. Tracks no denser than the spacing are all nodes, and a
campaign gaining less than ``MIN_GAIN`` is evaluated at every group."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout, predict_coordinates, predict_jacobian

NODE_SPACING_MM = 0.5
MIN_GAIN = 4.0  # fewer nodes than groups by this factor, else every group is evaluated
# A group's joints within this of the line between its neighbouring nodes: on the
# track (the other joints follow the leg's own smoothly along a scan); else a node.
ON_TRACK_MM = 1e-3


@dataclass(frozen=True)
class PoseNodes:
    """``nodes`` (K,): the groups evaluated; each group's value is ``(1 - weight)`` of
    its ``left`` node's plus ``weight`` of its ``right`` node's (indices into nodes)."""

    nodes: np.ndarray
    left: np.ndarray
    right: np.ndarray
    weight: np.ndarray

    def interpolate(self, at_nodes: np.ndarray) -> np.ndarray:
        """(B, G) from values (B, K) at the nodes."""
        return at_nodes[:, self.left] * (1.0 - self.weight) + at_nodes[:, self.right] * self.weight


def pose_nodes(layout: ReadingsLayout) -> PoseNodes | None:
    """The nodes of a layout of one reading per group (None: too few saved). A track:
    one gauge, one leg, the same approach sides, ordered by the leg's own joint; a
    group whose joints are not where its neighbouring nodes put them (within
    ``ON_TRACK_MM``: not on the line between them) is a node itself."""
    n = len(layout)
    if n == 0:
        return None
    leg = np.asarray(layout.leg)
    q = layout.q_mm
    own = q[np.arange(n), leg]
    track = row_codes(np.column_stack([layout.gauge, leg, layout.lost_motion_side]))
    order = np.lexsort((own, track))
    t_sorted, q_sorted = track[order], own[order]
    is_node = _spaced(t_sorted, q_sorted, NODE_SPACING_MM)
    for _ in range(3):  # a group off its track's line becomes a node
        if is_node.sum() * MIN_GAIN > n:
            return None
        left_s, right_s, weight_s = _neighbours(is_node, q_sorted)
        joints = q[order]
        between = joints[left_s] * (1.0 - weight_s[:, None]) + joints[right_s] * weight_s[:, None]
        off = np.abs(between - joints).max(axis=1) > ON_TRACK_MM
        if not off.any():
            break
        is_node |= off
    else:
        return None
    node_pos = np.flatnonzero(is_node)  # positions in the sorted order
    # nodes numbered in the groups' own order, as a layout's subset keeps them
    rank = np.argsort(np.argsort(order[node_pos]))
    index_of = np.full(n, -1)
    index_of[node_pos] = rank
    left = np.empty(n, dtype=int)
    right = np.empty(n, dtype=int)
    weight = np.empty(n)
    left[order] = index_of[left_s]
    right[order] = index_of[right_s]
    weight[order] = weight_s
    return PoseNodes(np.sort(order[node_pos]), left, right, weight)


def row_codes(keys: np.ndarray) -> np.ndarray:
    """(n,) each row of integer ``keys`` (n, c) numbered by its rank among the distinct
    rows in lexicographic order: ``np.unique(keys, axis=0, return_inverse=True)``'s
    numbers, from one key per row (a mixed radix) instead of a sort of the rows."""
    keys = np.asarray(keys, dtype=np.int64)
    code = np.zeros(len(keys), dtype=np.int64)
    for column in keys.T:
        low = column.min(initial=0)
        code = code * (int(column.max(initial=0)) - int(low) + 1) + (column - low)
    return np.unique(code, return_inverse=True)[1].reshape(-1)


def _spaced(track: np.ndarray, q: np.ndarray, spacing_mm: float) -> np.ndarray:
    """Nodes along sorted tracks: where a track starts or ends, and wherever the
    spacing since the last node is reached. Each next node is found by bisection, so
    the loop runs over the nodes, not over every group."""
    n = len(q)
    is_node = np.zeros(n, dtype=bool)
    starts = np.flatnonzero(np.r_[True, track[1:] != track[:-1]])
    reach = spacing_mm - 1e-9

    def spaced(k: int, last: float) -> bool:
        return bool(q[k] - last >= reach)

    for lo, hi in zip(starts.tolist(), np.r_[starts[1:], n].tolist(), strict=True):
        is_node[hi - 1] = True
        k = lo
        while k < hi:
            is_node[k] = True
            last = float(q[k])
            j = int(np.searchsorted(q[lo:hi], last + reach)) + lo
            # the bisection's sum may round the other way than the difference: the
            # first group at the spacing by the difference, as a step-by-step walk finds
            j = max(j, k + 1)
            while j > k + 1 and spaced(j - 1, last):
                j -= 1
            while j < hi and not spaced(j, last):
                j += 1
            k = j
    return is_node


def _neighbours(is_node: np.ndarray, q: np.ndarray,
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each sorted group's node at or before it, the next at or after it (within its
    track: a track starts and ends with a node), and its weight between them."""
    n = len(q)
    left = np.maximum.accumulate(np.where(is_node, np.arange(n), 0))
    right = np.minimum.accumulate(np.where(is_node, np.arange(n), n)[::-1])[::-1]
    span = q[right] - q[left]
    weight = np.where(span > 0, (q - q[left]) / np.where(span > 0, span, 1.0), 0.0)
    return left, right, weight


# An interval's direction whose weight is below this share of its largest is left out
# of its compressed rows: what it carries is at the rounding of the sums that form it
# (no source: a few orders of magnitude above the double's 2e-16 relative error).
DEGENERATE = 1e-10


@dataclass(frozen=True)
class NodeRows:
    """A dense scan's weighted group coordinates compressed to a few rows per pair of
    neighbouring nodes, exactly for residuals ``y - S I d`` (``y`` the weighted group
    residuals at a reference, ``S`` the groups' whitening, ``I`` the interpolation
    between nodes, ``d`` a change at the nodes). The groups between two nodes make a
    block ``X``; with ``X = Q R``, ``|y - X d|^2 = |y|^2 - |Q'y|^2 + |Q'y - R d|^2``,
    so a sum of squares needs ``R d``, not the groups; a gauge's zero is ``R 1``.

    ``left``, ``right``: each row's nodes, ``a``, ``b`` its coefficients there;
    ``data``: ``Q'y``; ``lost``: ``|y|^2 - |Q'y|^2`` (no change at the nodes reaches
    it); ``zeros`` (R, gauges): the gauges' zero directions, orthonormal."""

    left: np.ndarray
    right: np.ndarray
    a: np.ndarray
    b: np.ndarray
    data: np.ndarray
    lost: float
    zeros: np.ndarray

    def apply(self, at_nodes: np.ndarray) -> np.ndarray:
        """(B, R) ``R d`` of changes ``at_nodes`` (B, K)."""
        return at_nodes[:, self.left] * self.a + at_nodes[:, self.right] * self.b

    def project(self, x: np.ndarray) -> np.ndarray:
        """The gauges' zeros taken out along the last axis."""
        return x - (x @ self.zeros) @ self.zeros.T


def node_rows(nodes: PoseNodes, scale: np.ndarray, y: np.ndarray,
              gauge: np.ndarray) -> NodeRows:
    """The compressed rows of groups with whitening ``scale`` (G,), weighted residuals
    ``y`` (G,) at the reference, the gauges' zeros projected out (else ``|y|^2``, of
    the readings' millimetres, would swamp ``lost``), and ``gauge`` (G,),
    interpolated by ``nodes``."""
    left, right, w = _intervals(nodes)
    first, block = np.unique(left * len(nodes.nodes) + right, return_index=True,
                             return_inverse=True)[1:]
    block = block.reshape(-1)
    pairs = np.column_stack([left[first], right[first]])
    n_blocks = len(pairs)
    x = np.column_stack([scale * (1.0 - w), scale * w])  # a group's row of S I

    def per_block(values: np.ndarray) -> np.ndarray:
        return np.bincount(block, weights=values, minlength=n_blocks)

    gram = np.empty((n_blocks, 2, 2))
    gram[:, 0, 0] = per_block(x[:, 0] ** 2)
    gram[:, 0, 1] = gram[:, 1, 0] = per_block(x[:, 0] * x[:, 1])
    gram[:, 1, 1] = per_block(x[:, 1] ** 2)
    h = np.column_stack([per_block(x[:, 0] * y), per_block(x[:, 1] * y)])
    values, vectors = np.linalg.eigh(gram)  # (blocks, 2), columns of (blocks, 2, 2)
    kept = values > DEGENERATE * values[:, -1:]
    blk, j = np.nonzero(kept)
    root = np.sqrt(values[blk, j])
    v = vectors[blk, :, j]  # (R, 2)
    data = np.einsum("ri,ri->r", v, h[blk]) / root
    lost = float(np.sum(y**2) - np.sum(data**2))
    a, b = root * v[:, 0], root * v[:, 1]
    # a gauge's zero: S 1 on its groups, X (1, 1) on each block, R (1, 1) here
    gauge_of_block = np.zeros(n_blocks, dtype=int)
    gauge_of_block[block] = gauge
    row_gauge = gauge_of_block[blk]
    n_gauges = int(gauge.max()) + 1 if len(gauge) else 0
    zeros = np.zeros((len(blk), n_gauges))
    zeros[np.arange(len(blk)), row_gauge] = a + b
    norms = np.linalg.norm(zeros, axis=0)
    zeros = zeros[:, norms > 0] / norms[norms > 0]
    return NodeRows(pairs[blk, 0], pairs[blk, 1], a, b, data, lost, zeros)


def _intervals(nodes: PoseNodes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each group's pair of neighbouring nodes and its weight between them, a node's
    own group put in the interval after it (weight 0) or, at a track's end, before it
    (weight 1): two rows an interval, none more a node."""
    left, right, w = nodes.left.copy(), nodes.right.copy(), nodes.weight.copy()
    between = left != right
    after = np.full(len(nodes.nodes), -1)
    after[left[between]] = right[between]
    before = np.full(len(nodes.nodes), -1)
    before[right[between]] = left[between]
    own = ~between
    k = left[own]
    to_after, to_before = after[k] >= 0, (after[k] < 0) & (before[k] >= 0)
    rows = np.flatnonzero(own)
    right[rows[to_after]] = after[k[to_after]]
    w[rows[to_after]] = 0.0
    left[rows[to_before]] = before[k[to_before]]
    w[rows[to_before]] = 1.0
    return left, right, w


class NodeSpace:
    """Candidate fits of a dense scan's repeat groups in the rows of ``NodeRows``: the
    model evaluated at the nodes only, its change from the exact prediction at the
    fits' start ``theta`` interpolated (as ``GroupSpace.residuals`` does), and the
    sums over the groups formed once. ``constant``: what the rows leave out of the
    weighted residual sum of squares (the groups' scatter within themselves and
    between the nodes): a fit's rss is it plus the squared norm of its rows."""

    def __init__(self, rows: NodeRows, layout: ReadingsLayout, machine: MachineSpec,
                 at_start: np.ndarray, constant: float) -> None:
        self.rows, self.layout, self.machine = rows, layout, machine
        self._at_start = at_start  # (K,) the exact predictions at the nodes
        self.constant = constant + rows.lost
        self.start = rows.project(rows.data)

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """(B, R) the rows' weighted residuals of parameter vectors ``theta`` (B, N)."""
        change = predict_coordinates(theta, self.layout, self.machine) - self._at_start
        return self.rows.project(self.rows.data - self.rows.apply(change))

    def jacobian(self, theta: np.ndarray, free: np.ndarray) -> np.ndarray:
        """(R, p) the weighted Jacobian of the predictions by the parameters at
        positions ``free``, from the nodes' (the change's derivative)."""
        jac = predict_jacobian(np.asarray(theta, dtype=float)[None], self.layout,
                               self.machine, free)[0]
        return self.rows.project(self.rows.apply(jac.T)).T
