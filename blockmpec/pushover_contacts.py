r"""The contact update of :func:`blockmpec.pushover`: contacts kept closed through a step, blocks that overlap,
configurations that no multiplier holds.

Second-order correction.  Blocks that turn about different centres drift apart at their common hinges by
``O(s^2)``, and a corner can dip into a face it slides along.  So the move is followed by a least-norm correction of
the block positions (Gauss-Newton, damped ``lsqr``; :func:`close_contacts`) in which

* every *hinge* (a touching point whose relative velocity is zero) keeps its gap and does not slip;
* every other touching point may open but not overlap beyond its gap at the start of the step (an active set);
* the control point keeps its advance;
* *sliding* points (``v_n <= tan(psi) |v_t|``: they open by no more than the flow rule's dilatancy, ``tan(phi)``
  for the associative problem) keep their gap as far as the rest allows (weighted rows, then the hard rows
  restored): a block sliding on its support stays on it, and an associative mechanism that needs its dilatancy (a
  running-bond wall) keeps the part it needs.

Contact events.  If the move makes two blocks overlap deeper than the contact tolerance (:func:`overlaps`: a
corner closing onto another block), the step is cut back by bisection to the moment they touch
(:func:`cut_at_contact`).

No multiplier.  A configuration stands for no ``lam`` exactly when (Farkas) some mechanism ``u`` with
``E^T u + N_u z_u + N_f z_f = 0``, ``z >= 0``, ``f_l^T u = 0`` has ``f_d^T u > 0`` (:func:`dead_load_mechanism`, a
small LP): the structure falls along it.  A step that goes past the configuration where the structure stops standing
is cut back there by bisection (:func:`cut_at_instability`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockmpec.contacts import contact_structure, find_contacts, pair_separation, shorter_sides
from blockmpec.geometry import Structure
from blockmpec.pushover_motion import Poses, place, rotate, unplace, velocity, vertex_speed, vertices_at

#: A contact point is kept closed / held against slip when its normal / tangential velocity is at most
#: this fraction of the mechanism's largest vertex speed (the solvers' duals are exact to ~1e-9).
VELOCITY_TOL = 1e-6

#: Bisections of a step at a contact event.
MAX_BISECTIONS = 60

#: Bisections of a step that ends where no ``lam`` holds the structure, to find where it stops standing.
INSTABILITY_BISECTIONS = 10


@dataclass
class Closed:
    """The touching contact points of a configuration, in undeformed coordinates of their blocks:
    incident point ``p``, reference foot ``f``, the reference edge's normal ``nu`` and tangent ``tau``
    (undeformed directions of the reference block).  ``hinge``: the mechanism keeps the point fixed
    on both blocks (relative velocity 0); ``sliding``: it slips and opens at most by the flow rule's
    dilatancy, ``v_n <= tan(psi) |v_t|``."""

    inc: np.ndarray
    ref: np.ndarray
    p: np.ndarray
    f: np.ndarray
    nu: np.ndarray
    tau: np.ndarray
    hinge: np.ndarray
    sliding: np.ndarray
    gap: np.ndarray | None = None


def closed_points(contacts, structure: Structure, twist: np.ndarray, poses: Poses, c0: np.ndarray,
                  associative: bool) -> Closed:
    """The touching contact points and what the mechanism does there (module docstring).

    ``structure`` is the deformed one (for the interfaces' friction and dilatancy)."""
    itf = contacts.interfaces
    k, j = np.nonzero(contacts.touching)
    inc, ref = itf.plus[k], itf.minus[k]
    p, f = contacts.points[k, j], contacts.feet[k, j]
    nu, tau = itf.normal[k], itf.tangent[k]
    centre = c0 + poses.shift
    rel = velocity(twist, centre, inc, p) - velocity(twist, centre, ref, p)
    v_n = np.einsum("md,md->m", rel, nu)
    v_t = np.abs(np.einsum("md,md->m", rel, tau))
    coef = structure.interface_friction() if associative else structure.interface_dilatancy()
    tol = VELOCITY_TOL * vertex_speed(twist, structure.vertices, centre)
    hinge = (np.abs(v_n) <= tol) & (v_t <= tol)
    sliding = ~hinge & (v_n <= coef[k] * v_t + tol)
    angle = poses.angle[ref]
    closed = Closed(inc, ref, unplace(p, inc, poses, c0), unplace(f, ref, poses, c0),
                    rotate(nu, -angle), rotate(tau, -angle), hinge, sliding)
    closed.gap = normal_gaps(closed, poses, c0)
    return closed


def gaps(closed: Closed, poses: Poses, c0: np.ndarray, normal_rows: np.ndarray, slip_rows: np.ndarray):
    """Constraint values and Jacobian rows at ``poses``: the change of the normal gap ``nu . (p - f)``
    since the start of the step of the points ``normal_rows`` and the slip ``tau . (p - f)`` of the points
    ``slip_rows`` (``nu``, ``tau`` turning with the reference block).  Returns values (r,), incident and reference
    blocks (r,) and their derivatives (r, 3) with respect to (shift_x, shift_y, angle)."""
    p = place(closed.p, closed.inc, poses, c0)
    f = place(closed.f, closed.ref, poses, c0)
    angle = poses.angle[closed.ref]
    centre = c0 + poses.shift
    rows = []
    for normal, direction, use in ((True, rotate(closed.nu, angle), normal_rows),
                                   (False, rotate(closed.tau, angle), slip_rows)):
        w, pp, ff = direction[use], p[use], f[use]
        inc, ref = closed.inc[use], closed.ref[use]
        value = np.einsum("md,md->m", w, pp - ff)
        if normal and closed.gap is not None:  # a normal row keeps the gap its point had at the start
            value = value - closed.gap[use]
        d_inc = np.column_stack([w, cross(pp - centre[inc], w)])
        perp = np.column_stack([-w[:, 1], w[:, 0]])
        d_ref = np.column_stack([-w, np.einsum("md,md->m", perp, pp - ff) - cross(ff - centre[ref], w)])
        rows.append((value, inc, ref, d_inc, d_ref))
    return [np.concatenate([r[i] for r in rows]) for i in range(5)]


def normal_gaps(closed: Closed, poses: Poses, c0: np.ndarray) -> np.ndarray:
    """Normal gap of every touching point at ``poses``, shape (m,)."""
    p = place(closed.p, closed.inc, poses, c0)
    f = place(closed.f, closed.ref, poses, c0)
    return np.einsum("md,md->m", rotate(closed.nu, poses.angle[closed.ref]), p - f)


def cross(r: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The 2D cross products ``r x w`` of rows (m,)."""
    return r[:, 0] * w[:, 1] - r[:, 1] * w[:, 0]


#: Gauss-Newton sweeps of the closing correction.
MAX_SWEEPS = 20

#: Weight of the rows that close sliding points (see :func:`close_contacts`).
SLIDING_WEIGHT = 0.1

#: Damping of each sweep's least-squares problem (its matrix is dimensionless, entries of order 1):
#: nearly dependent rows (one corner held by two contacts whose normals differ by a small angle) whose
#: second-order gaps disagree would otherwise ask for a correction of the gap over that angle.
CORRECTION_DAMPING = 1e-3


@dataclass
class Anchor:
    """The control point's advance to keep through the correction: ``e . q = value`` for the
    undeformed point ``point`` of block ``block``."""

    block: int
    point: np.ndarray
    e: np.ndarray
    value: float


def close_contacts(closed: Closed, poses: Poses, c0: np.ndarray, fixed: np.ndarray, size: np.ndarray,
                   length_tol: float, anchor: Anchor | None = None) -> tuple[Poses, bool]:
    """``poses`` corrected by a least-norm change (translations, and rotations times each block's size),
    by Gauss-Newton with damped ``lsqr``, so that

    * the *hard* rows hold: each hinge keeps its gap and does not slip, each touching point that
      overlaps by more than ``length_tol / 100`` beyond its start keeps its gap (an active set, kept
      once entered), and, with an ``anchor``, the control point keeps its advance;
    * with an ``anchor``, first, the sliding points keep their gaps too, as far as the hard rows allow
      (rows weighted :data:`SLIDING_WEIGHT`; exact for a block sliding on its support, least squares
      when the mechanism needs the dilatancy of its flow rule, as an associative wall mechanism does);
      then the hard rows alone are restored.

    A gap is the point's normal distance to its reference edge at the start of the step.  Returns the
    poses and whether the hard rows are met (to ``length_tol / 1000``)."""
    poses = poses.copy()
    active = closed.hinge.copy()
    if anchor is not None and closed.sliding.any():
        poses, active = _sweeps(closed, poses, c0, fixed, size, length_tol, anchor, active, closed.sliding)
    poses, active = _sweeps(closed, poses, c0, fixed, size, length_tol, anchor, active, None)
    value = _rows(closed, poses, c0, fixed, size, anchor, active, None)[0]
    return poses, float(np.max(np.abs(value), initial=0.0)) <= 1e-3 * length_tol


def _rows(closed, poses, c0, fixed, size, anchor, active, soft):
    """Values and sparse Jacobian (columns: free blocks' shift x, y and angle times size) of the rows of
    :func:`close_contacts`; ``soft`` points (or None) get rows weighted :data:`SLIDING_WEIGHT`."""
    import scipy.sparse as sp

    dof = np.full(fixed.size, -1)
    free = np.flatnonzero(~fixed)
    dof[free] = np.arange(free.size)
    soft = np.zeros_like(active) if soft is None else soft & ~active
    normal_rows = active | soft
    value, inc, ref, d_inc, d_ref = gaps(closed, poses, c0, normal_rows, active & closed.hinge)
    weight = np.ones(value.size)
    weight[: int(normal_rows.sum())][soft[normal_rows]] = SLIDING_WEIGHT
    rows, cols, vals = [], [], []
    r = np.arange(value.size)
    for blocks, d in ((inc, d_inc), (ref, d_ref)):
        has = dof[blocks] >= 0
        scale = np.column_stack([np.ones((has.sum(), 2)), 1.0 / size[blocks[has]]])
        for c in range(3):
            rows.append(r[has])
            cols.append(3 * dof[blocks[has]] + c)
            vals.append(weight[has] * d[has, c] * scale[:, c])
    value = weight * value
    if anchor is not None:
        k = anchor.block
        q = place(anchor.point[None, :], np.array([k]), poses, c0)[0]
        arm = (q - c0[k] - poses.shift[k])[None, :]
        rows.append(np.full(3, value.size))
        cols.append(3 * dof[k] + np.arange(3))
        vals.append(np.array([anchor.e[0], anchor.e[1], cross(arm, anchor.e[None, :])[0] / size[k]]))
        value = np.append(value, float(anchor.e @ q) - anchor.value)
        weight = np.append(weight, 1.0)
    J = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                     shape=(value.size, 3 * free.size))
    return value, J, free, weight


def _sweeps(closed, poses, c0, fixed, size, length_tol, anchor, active, soft):
    """Gauss-Newton sweeps of :func:`close_contacts` (``soft``: the points with weighted rows, or None)."""
    from scipy.sparse.linalg import lsqr

    for _ in range(MAX_SWEEPS):
        active = active | (normal_gaps(closed, poses, c0) < np.minimum(closed.gap, 0.0) - 0.01 * length_tol)
        value, J, free, weight = _rows(closed, poses, c0, fixed, size, anchor, active, soft)
        if value.size == 0 or np.max(np.abs(value / weight)) <= 1e-6 * length_tol:
            break
        y = lsqr(J, -value, damp=CORRECTION_DAMPING, atol=1e-15, btol=1e-15, conlim=1e12,
                 iter_lim=20 * (J.shape[1] + 10))[0]
        step = y.reshape(-1, 3)
        poses.shift[free] += step[:, :2]
        poses.angle[free] += step[:, 2] / size[free]
        if np.max(np.abs(y)) <= 1e-7 * length_tol:
            break
    return poses, active


def dead_load_mechanism(ops) -> np.ndarray | None:
    r"""A mechanism under which the dead load does work and the live load none, or None.

    The static LP (1) is infeasible exactly when (Farkas) some ``u`` with
    ``E^T u + N_u z_u + N_f z_f = 0``, ``z >= 0`` and ``f_l^T u = 0`` has ``f_d^T u > 0``: the
    configuration stands for no ``lam`` and falls under its own weight along ``u``.  Found by an LP
    (:func:`blockmpec.solvers.engines.highs.solve_lp`) with ``-1 <= u <= 1``; None when the largest work is
    round-off."""
    import scipy.sparse as sp

    from blockmpec.result import Status
    from blockmpec.solvers.engines.highs import solve_lp

    b3, c2 = ops.E.shape[0], ops.N_u.shape[1]
    A = sp.vstack([sp.hstack([ops.E.T, ops.N_u, ops.N_f]),
                   sp.csr_array(np.concatenate([ops.f_l, np.zeros(2 * c2)])[None, :])]).tocsr()
    status, x, value = solve_lp(-np.concatenate([ops.f_d, np.zeros(2 * c2)]), A, np.zeros(A.shape[0]),
                                np.zeros(A.shape[0]), np.r_[-np.ones(b3), np.zeros(2 * c2)],
                                np.r_[np.ones(b3), np.full(2 * c2, np.inf)])
    if status is not Status.OPTIMAL or not -value > 1e-9 * float(np.abs(ops.f_d).sum()):
        return None
    return x[:b3]


def lonely_block(structure: Structure, contacts) -> int | None:
    """The first free block that touches no other block (it cannot stand), or None."""
    touched = np.zeros(structure.n_blocks, bool)
    touched[contacts.interfaces.minus] = True
    touched[contacts.interfaces.plus] = True
    lonely = np.flatnonzero(~touched & ~structure.fixed)
    return int(lonely[0]) if lonely.size else None


def overlaps(structure: Structure, poses: Poses, c0: np.ndarray, tolerance: float):
    """The pairs ``(a, b)`` overlapping by more than the contact tolerance at ``poses``, or None."""
    from blockmpec.contacts import max_penetration

    hits = max_penetration(vertices_at(structure, poses, c0), structure.n_vertices, structure.fixed, tolerance)
    deep = hits[hits[:, 2] > tolerance]
    return None if deep.size == 0 else (deep[:, 0].astype(int), deep[:, 1].astype(int))


def cut_at_contact(structure, trial, s_full, overlap, c0, tolerance):
    """Poses of the largest step ``s < s_full`` at which the blocks touch without overlapping (bisection)."""
    lo, hi = 0.0, s_full
    pairs = overlap
    side = shorter_sides(structure.vertices)
    for _ in range(MAX_BISECTIONS):
        mid = 0.5 * (lo + hi)
        poses = trial(mid)
        again = overlaps(structure, poses, c0, tolerance)
        if again is not None:
            hi, pairs = mid, again
            continue
        a, b = pairs
        sep_a, _, sep_b, _ = pair_separation(vertices_at(structure, poses, c0), structure.n_vertices, a, b)
        gap = np.maximum(sep_a, sep_b) / np.minimum(side[a], side[b])
        if np.all(gap <= tolerance):
            return poses, mid
        lo = mid
    return None, None


def stands(structure: Structure, poses: Poses, c0: np.ndarray, tolerance: float, length: float) -> bool:
    """Whether some ``lam`` holds the configuration (no dead-load mechanism, :func:`dead_load_mechanism`)."""
    from blockmpec.operators import assemble

    vertices = vertices_at(structure, poses, c0)
    contacts = find_contacts(vertices, structure.n_vertices, structure.fixed, tolerance=tolerance,
                             contact_length=length)
    if lonely_block(structure, contacts) is not None:
        return False
    return dead_load_mechanism(assemble(contact_structure(structure, vertices, contacts))) is None


def cut_at_instability(structure, fixed, last_push, c0, tolerance, length):
    """``(before, after)``: poses of the last step cut back to the last configuration that stands
    (None when that is where the step started) and just past it, by :data:`INSTABILITY_BISECTIONS`
    bisections of ``s``."""
    trial, s_used = last_push
    lo, hi = 0.0, s_used
    for _ in range(INSTABILITY_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if stands(structure, trial(mid), c0, tolerance, length):
            lo = mid
        else:
            hi = mid
    return (trial(lo) if lo > 0 else None), trial(hi)
