"""Exact kinematics of an Orthoglide-type machine, vectorised over batches.

Geometry (MODEL.md): actuator ``i`` moves its joint centre along a line
``r_i = o_i + rho_i u_i``; the TCP ``p`` satisfies ``|p - r_i| = L_i``. The
nominal machine has ``u_i = e_i``, ``o_i = 0``, ``L_i = L``. Squareness and axis
offsets tilt and shift the lines; they enter here so that every other module
sees one geometry.

Conventions for the effects (INTERCHANGE.md vocabulary):
- squareness ``xy`` (mrad) tilts the y axis toward +x in the xy plane, so the
  angle between the x and y axes is 90 deg minus the value; ``xz`` and ``yz``
  tilt the z axis toward +x and +y. The x axis defines the frame.
- axis offset ``xy`` (mm) shifts the y axis line along z; ``xz`` shifts the z
  line along y; ``yz`` shifts the z line along x (second line minus first).

Arrays: a leading batch shape ``...`` is carried through everything, the last
axis is the coordinate (3) and, for per-joint arrays, the one before is the
joint (3).
"""

from __future__ import annotations

import numpy as np

from ogacq.model.parameters import PARAM_INDEX

_SQ = [PARAM_INDEX[f"squareness.{w}"] for w in ("xy", "xz", "yz")]
_AO = [PARAM_INDEX[f"axis_offset.{w}"] for w in ("xy", "xz", "yz")]
_DL = [PARAM_INDEX[f"leg_length.{a}"] for a in "xyz"]


def axis_lines(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions ``u`` and base points ``o`` (..., 3, 3) of the three actuator
    lines of parameter vectors ``theta`` (..., N), row ``i`` for actuator ``i``."""
    shape = theta.shape[:-1]
    s_xy, s_xz, s_yz = (np.sin(theta[..., k] * 1e-3) for k in _SQ)
    u = np.zeros(shape + (3, 3))
    u[..., 0, 0] = 1.0
    u[..., 1, 0] = s_xy
    u[..., 1, 1] = np.sqrt(1.0 - s_xy**2)
    u[..., 2, 0] = s_xz
    u[..., 2, 1] = s_yz
    u[..., 2, 2] = np.sqrt(1.0 - s_xz**2 - s_yz**2)
    o = np.zeros(shape + (3, 3))
    o[..., 1, 2] = theta[..., _AO[0]]
    o[..., 2, 1] = theta[..., _AO[1]]
    o[..., 2, 0] = theta[..., _AO[2]]
    return u, o


def axis_line_tangents(theta: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Derivatives of :func:`axis_lines` by the ``free`` parameters (P,): ``du``
    (..., P, 3, 3) and ``do`` (P, 3, 3); zero for parameters that do not tilt or
    shift the lines. Differentiates the expressions of ``axis_lines`` term by term."""
    shape = theta.shape[:-1]
    s_xy, s_xz, s_yz = (np.sin(theta[..., k] * 1e-3) for k in _SQ)
    c_xy, c_xz, c_yz = (np.cos(theta[..., k] * 1e-3) * 1e-3 for k in _SQ)  # d sin / d mrad
    u11 = np.sqrt(1.0 - s_xy**2)
    u22 = np.sqrt(1.0 - s_xz**2 - s_yz**2)
    du = np.zeros(shape + (len(free), 3, 3))
    do = np.zeros((len(free), 3, 3))
    for k, index in enumerate(free):
        if index == _SQ[0]:
            du[..., k, 1, 0] = c_xy
            du[..., k, 1, 1] = -s_xy * c_xy / u11
        elif index == _SQ[1]:
            du[..., k, 2, 0] = c_xz
            du[..., k, 2, 2] = -s_xz * c_xz / u22
        elif index == _SQ[2]:
            du[..., k, 2, 1] = c_yz
            du[..., k, 2, 2] = -s_yz * c_yz / u22
        elif index in _AO:
            line, coordinate = {_AO[0]: (1, 2), _AO[1]: (2, 1), _AO[2]: (2, 0)}[index]
            do[k, line, coordinate] = 1.0
    return du, do


def leg_length_tangents(free: np.ndarray) -> np.ndarray:
    """(P, 3) derivatives of :func:`leg_lengths` by the ``free`` parameters."""
    return (np.asarray(free)[:, None] == np.array(_DL)[None, :]).astype(float)


def leg_lengths(theta: np.ndarray, nominal_mm: float) -> np.ndarray:
    """(..., 3) actual leg lengths."""
    return nominal_mm + theta[..., _DL]


def joint_centres(rho: np.ndarray, u: np.ndarray, o: np.ndarray) -> np.ndarray:
    """(..., 3, 3) joint centres for joint positions ``rho`` (..., 3) along their lines."""
    return o + rho[..., :, None] * u


def forward(r: np.ndarray, legs_mm: np.ndarray) -> np.ndarray:
    """TCP from the three joint centres ``r`` (..., 3, 3) and leg lengths (..., 3):
    the line the sphere equations leave pairwise subtracted, met with the first
    sphere on the origin side of the joint centres' plane (the papers' assembly mode).
    NaN where the legs cannot meet; callers decide whether that is an error."""
    # Coordinates first, each a contiguous (3, ...) array: one numpy call does a
    # vector's three components (a fit evaluates a few dozen poses, where every call
    # costs more than its arithmetic; a Monte-Carlo evaluates millions, where
    # contiguous components are what makes it fast). Dot products sum x, y, z in
    # that order, crosses are the textbook components: the same arithmetic as
    # writing every component out.
    c = np.ascontiguousarray(r.transpose(r.ndim - 2, r.ndim - 1, *range(r.ndim - 2)))
    lsq = np.asarray(legs_mm) ** 2
    l1, l2, l3 = lsq[..., 0], lsq[..., 1], lsq[..., 2]
    r1 = c[0]
    ab = c[1:] - r1  # (2, 3, ...): a = r2 - r1, b = r3 - r1
    a, b = ab[0], ab[1]
    norms = (c * c).sum(axis=1)  # (3, ...) |r_k|^2
    s1 = norms[0]
    # a . p = ca and b . p = cb, from |p - r_k|^2 - |p - r_1|^2 = L_k^2 - L_1^2
    ca = 0.5 * (norms[1] - s1 - l2 + l1)
    cb = 0.5 * (norms[2] - s1 - l3 + l1)
    gram = (ab[:, None] * ab[None, :]).sum(axis=2)  # (2, 2, ...): a.a, a.b; b.a, b.b
    gaa, gab, gbb = gram[0, 0], gram[0, 1], gram[1, 1]
    det = gaa * gbb - gab * gab
    ka = (gbb * ca - gab * cb) / det
    kb = (gaa * cb - gab * ca) / det
    # nearest point of the line to the origin, relative to r1
    d = ka * a + kb * b - r1
    n = _cross_first(a, b)
    nn = _dot(n, n)
    beta = _dot(n, d)
    disc = beta * beta - nn * (_dot(d, d) - l1)
    root = _sqrt_or_nan(disc)
    origin_side = np.where(_dot(n, r1) > 0, -1.0, 1.0)
    t = (-beta + origin_side * root) / nn
    p = r1 + d + t * n
    return p.transpose(*range(1, p.ndim), 0)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the first axis (3): x, then y, then z added (numpy reduces
    along an outer axis row after row)."""
    return np.add.reduce(a * b, axis=0)


def _cross_first(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the first axis (3)."""
    return a[_NEXT] * b[_AFTER] - a[_AFTER] * b[_NEXT]


# Component k of a x b is a[k+1] b[k+2] - a[k+2] b[k+1] (indices mod 3).
_NEXT = np.array([1, 2, 0])
_AFTER = np.array([2, 0, 1])


def forward_tangent(r: np.ndarray, p: np.ndarray, legs_mm: np.ndarray, dr: np.ndarray,
                    dlegs: np.ndarray | None) -> np.ndarray:
    """Derivatives ``dp`` (..., P, 3) of :func:`forward`'s TCP ``p`` (..., 3) given
    those of the joint centres ``dr`` (..., P, 3, 3) and of the leg lengths ``dlegs``
    (..., P, 3) (None: none moves), by implicit differentiation of ``|p - r_i|^2 =
    L_i^2``: ``(p - r_i) . (dp - dr_i) = L_i dL_i``, whose matrix (rows ``a_i = p -
    r_i``) has the inverse ``a_2 x a_3``, ``a_3 x a_1``, ``a_1 x a_2`` over the
    determinant (Cramer), once per pose. Exact, whatever assembly mode ``forward`` took."""
    legs_to_tcp = p[..., None, :] - r  # (..., 3, 3), row i: p - r_i
    rhs = np.einsum("...ik,...qik->...qi", legs_to_tcp, dr)
    if dlegs is not None:
        rhs = rhs + legs_mm[..., None, :] * dlegs
    # rows a_2, a_3, a_1 crossed with a_3, a_1, a_2: the inverse's columns, as rows
    # after[..., _NEXT], last[..., _AFTER], after[..., _AFTER], last[..., _NEXT] in one gather
    factors = legs_to_tcp.reshape(legs_to_tcp.shape[:-2] + (9,))[..., _CRAMER_FACTORS]
    rows = factors[..., 0, :, :] * factors[..., 1, :, :] \
        - factors[..., 2, :, :] * factors[..., 3, :, :]
    det = np.einsum("...k,...k->...", legs_to_tcp[..., 0, :], rows[..., 0, :])[..., None, None]
    if not det.all():  # legs in one plane: infinite derivatives, said without a warning
        with np.errstate(invalid="ignore", divide="ignore"):
            rows /= det
    else:  # NaN (legs that cannot meet) divides silently
        rows /= det
    return np.einsum("...ij,...qi->...qj", rows, rhs)


# Flat (row * 3 + coordinate) positions in a 3x3 matrix whose gather gives, for row i
# and coordinate k, the factors of component k of row i+1 x row i+2 (indices mod 3):
# row i+1's k+1, row i+2's k+2, row i+1's k+2, row i+2's k+1.
_CRAMER_FACTORS = np.array([[[3 * _NEXT[i] + _NEXT[k] for k in range(3)] for i in range(3)],
                            [[3 * _AFTER[i] + _AFTER[k] for k in range(3)] for i in range(3)],
                            [[3 * _NEXT[i] + _AFTER[k] for k in range(3)] for i in range(3)],
                            [[3 * _AFTER[i] + _NEXT[k] for k in range(3)] for i in range(3)]])


def _sqrt_or_nan(x: np.ndarray) -> np.ndarray:
    """``sqrt(x)``, NaN where ``x`` is negative, without numpy's warning; the warning
    state is only changed when there is one (entering np.errstate costs more than a
    fit's square root)."""
    if (x < 0).any():
        with np.errstate(invalid="ignore"):
            return np.sqrt(x)
    return np.sqrt(x)


def inverse(p: np.ndarray, u: np.ndarray, o: np.ndarray, legs_mm: np.ndarray) -> np.ndarray:
    """Joint positions ``rho`` (..., 3) that put the TCP at ``p`` (..., 3), each joint
    beyond the TCP along its own axis (the nominal assembly mode); NaN where a leg
    cannot reach ``p``."""
    d = p[..., None, :] - o
    along = np.einsum("...ik,...ik->...i", d, u)
    rest = legs_mm**2 - np.einsum("...ik,...ik->...i", d, d) + along**2
    with np.errstate(invalid="ignore"):
        return along + np.sqrt(rest)


def nominal_q(p: np.ndarray, leg_length_mm: float) -> np.ndarray:
    """Controller coordinates ``q`` (0 at mechanical zero) a nominal controller
    commands for TCP ``p``: ``q_i = p_i + sqrt(L^2 - p_j^2 - p_k^2) - L``."""
    p = np.asarray(p, dtype=float)
    sq = np.sum(p**2, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore"):
        return p + np.sqrt(leg_length_mm**2 - (sq - p**2)) - leg_length_mm


def nominal_tcp(q: np.ndarray, leg_length_mm: float) -> np.ndarray:
    """TCP a nominal machine reaches at controller coordinates ``q`` (..., 3)."""
    q = np.asarray(q, dtype=float)
    rho = leg_length_mm + q
    eye = np.broadcast_to(np.eye(3), q.shape[:-1] + (3, 3))
    legs = np.full(q.shape, leg_length_mm)
    return forward(rho[..., :, None] * eye, legs)
