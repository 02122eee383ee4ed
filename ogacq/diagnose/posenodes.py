"""A dense scan's model evaluated at nodes along each scanned track and interpolated.

A candidate fit evaluates the exact model at every repeat group (``groupspace.py``),
and a scan at a fine step has as many groups as readings: 71,000 at 0.027 mm, where
the model changes by micrometres over a millimetre. What a fit changes of a
prediction between two parameter vectors near each other (the effects, and the
offsets a few micrometres) is smooth along a scanned leg: the same gauge, the same
approach sides, the leg's own joint moving and the others following it. So the
change is evaluated at nodes ``NODE_SPACING_MM`` apart along each such track
and interpolated linearly between them; the reference prediction is exact at every
group. The interpolation's error is an eighth of the spacing squared times the
change's curvature along ``q``: for a change of 0.1 mm over the 310 mm legs (whose
curvature is at most change / leg^2) at 0.5 mm spacing, 3e-8 mm; changes of
micrometres to tenths of a millimetre in every parameter kind at once move a
prediction by under 1e-6 mm (tests/diagnose/test_scan_positions.py).

Tracks whose positions are no denser than the spacing (the papers' postures, a scan
of 1 mm steps) are all nodes, and a campaign that gains less than ``MIN_GAIN`` from
the nodes is evaluated at every group: the same numbers as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.model.measurement import ReadingsLayout

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


def pose_nodes(layout: ReadingsLayout, spacing_mm: float = NODE_SPACING_MM) -> PoseNodes | None:
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
    keys = np.column_stack([layout.gauge, leg, layout.lost_motion_side])
    _, track = np.unique(keys, axis=0, return_inverse=True)
    track = track.reshape(-1)
    order = np.lexsort((own, track))
    t_sorted, q_sorted = track[order], own[order]
    is_node = _spaced(t_sorted, q_sorted, spacing_mm)
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


def _spaced(track: np.ndarray, q: np.ndarray, spacing_mm: float) -> np.ndarray:
    """Nodes along sorted tracks: where a track starts or ends, and wherever the
    spacing since the last node is reached."""
    n = len(q)
    is_node = np.zeros(n, dtype=bool)
    ends = np.r_[track[1:] != track[:-1], True]
    last_track, last_q = -1, -np.inf
    for k in range(n):
        if track[k] != last_track or ends[k] or q[k] - last_q >= spacing_mm - 1e-9:
            is_node[k] = True
            last_track, last_q = int(track[k]), float(q[k])
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
