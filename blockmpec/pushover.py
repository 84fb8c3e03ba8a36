r"""Capacity curves by incremental limit analysis: ``bm.pushover`` and ``blockmpec pushover``.

The collapse multiplier of the undeformed structure is one point of a curve: as the blocks move
along their mechanism the multiplier falls (a rocking block's ``lam = tan(alpha - theta)``).
:func:`pushover` traces it.  At each configuration it finds the contacts
(:mod:`blockmpec.contacts`: edge-to-edge interfaces and vertex-to-edge point contacts), solves
the limit problem with any registered method (``static-lp`` for the associative problem,
``fixed-point`` for the non-associative one, ...) through :func:`blockmpec.solve`, whose
verifier checks every configuration, and moves the blocks along the mechanism found, so far
that the control point advances by one step.

The step
--------
Free block ``i`` has the twist ``(v_i, omega_i)`` of the mechanism (centroid velocity and
angular velocity, in the structure's axes and units: :func:`_mechanism`).  It moves rigidly by
the exact motion of that twist over a parameter ``s``, a rotation by ``a_i = s omega_i`` about
its instantaneous centre (so rotations are exact, not first order):

.. math:: c_i \leftarrow c_i + s\,V(a_i)\,v_i, \qquad
          V(a) = \frac{1}{a}\begin{pmatrix} \sin a & -(1-\cos a)\\ 1-\cos a & \sin a\end{pmatrix},
          \qquad \varphi_i \leftarrow \varphi_i + a_i,

one ``s`` for all blocks, solved (Brent) so that the control point's displacement along the
live load, ``e . (q - q_0)`` with ``e = (+-1, 0)``, reaches the next multiple of the step
``max_displacement / steps``.

Second-order correction
-----------------------
Blocks that turn about different centres drift apart at their common hinges by ``O(s^2)``, and a
corner can dip into a face it slides along.  So the move is followed by a least-norm correction
of the block positions (Gauss-Newton, damped ``lsqr``; :func:`_close_contacts`) in which

* every *hinge* (a touching point whose relative velocity is zero) keeps its gap and does not slip;
* every other touching point may open but not overlap beyond its gap at the start of the step
  (an active set);
* the control point keeps its advance;
* *sliding* points (``v_n <= tan(psi) |v_t|``: they open by no more than the flow rule's
  dilatancy, ``tan(phi)`` for the associative problem) keep their gap as far as the rest allows
  (weighted rows, then the hard rows restored): a block sliding on its support stays on it, and
  an associative mechanism that needs its dilatancy (a running-bond wall) keeps the part it needs.

A step whose correction cannot meet the hinges and the advance is halved (``event = "substep"``).
If the move makes two blocks overlap deeper than the contact tolerance (a corner closing onto
another block), the step is cut back by bisection to the moment they touch (``"contact"``).  Either
way the next row resumes towards the same target.

When no multiplier holds a configuration
----------------------------------------
If the solve fails, a small LP looks for a mechanism ``u`` with ``E^T u + N_u z_u + N_f z_f = 0``,
``z >= 0``, ``f_l^T u = 0`` and ``f_d^T u > 0`` (:func:`_dead_load_mechanism`): by Farkas' lemma it
exists exactly when the static LP is infeasible, and it is the proof.  The structure then falls
along it, whatever ``lam`` is, until a contact closes (``"snap"`` rows, multiplier NaN): an arch
whose thrust line leaves a joint between its pinned hinges snaps through, closing the opened
wedge of one hinge, and goes on.  Snaps that move a vertex by more than half the smallest
block's shorter side without reaching a configuration that stands are a collapse: the curve
ends.  Without such a proof the method failed where an answer exists; :data:`RETRY_OPTIONS` are
tried, and the curve ends with the failure if none succeeds.

The curve ends at ``max_displacement``, when ``lam <= 0`` (the displacement where ``lam`` crosses 0
is interpolated into ``attrs["ultimate_displacement"]``), at a collapse, when a solve fails, or when
the control point no longer advances along the live load.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from blockmpec.contacts import CONTACT_LENGTH, CONTACT_TOLERANCE, find_contacts, pair_separation, shorter_sides
from blockmpec.contacts import contact_structure as _contact_structure
from blockmpec.errors import OptionError
from blockmpec.geometry import Structure
from blockmpec.result import Result, Status

#: The columns of the curve before the per-block position columns (a contract: see :func:`pushover`).
CURVE_COLUMNS = ("step", "displacement", "rotation", "multiplier", "status", "event", "control_x", "control_y",
                 "contacts", "point_contacts", "time_s", "retried_with")

#: A contact point is kept closed / held against slip when its normal / tangential velocity is at most
#: this fraction of the mechanism's largest vertex speed (the solvers' duals are exact to ~1e-9).
VELOCITY_TOL = 1e-6

#: At most this many solves per requested step (extra rows come from halved steps, steps cut at contact
#: events and at instabilities, and snaps).
MAX_ROWS_PER_STEP = 10

#: Bisections of a step at a contact event.
MAX_BISECTIONS = 60

#: Bisections of a step that ends where no ``lam`` holds the structure, to find where it stops standing.
INSTABILITY_BISECTIONS = 10

#: Options tried in turn, per method, when a moved configuration's solve fails (those the caller set are
#: not overridden).  The fixed point's default "dead-load" start needs the configuration to stand at
#: lam = 0; a moved one often stands only at its lam > 0 (a block on its toe), and HiGHS then fails
#: without saying "infeasible"; its simplex engine also fails now and then on moved walls where the
#: interior engine converges.  HiGHS's dual simplex (``static-lp``'s choice for small LPs) now and then
#: stops with status "Not Set" on a moved wall that its primal simplex and interior point solve.
RETRY_OPTIONS: dict[str, tuple[dict[str, Any], ...]] = {
    "fixed-point": ({"start": "associative"}, {"engine": "interior"}),
    "static-lp": ({"algorithm": "primal-simplex"}, {"algorithm": "ipm"}),
}

#: Consecutive dead-load moves (snaps) before the curve stops.
MAX_SNAPS = 20

#: A run of snaps that moves a vertex further than this fraction of the smallest free block's shorter side
#: without reaching a configuration that stands is a collapse: the curve stops.
MAX_SNAP_MOTION = 0.5


# --------------------------------------------------------------------------- poses


@dataclass
class _Poses:
    """Rigid placement of every block: ``x = R(angle) (X - c0) + c0 + shift`` for a point ``X`` of the
    undeformed structure (``c0`` its block's undeformed centroid)."""

    angle: np.ndarray  # (n,)
    shift: np.ndarray  # (n, 2)

    def copy(self) -> _Poses:
        return _Poses(self.angle.copy(), self.shift.copy())


def _rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` (..., 2) by ``angle`` (broadcast to ``v[..., 0]``)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _place(points: np.ndarray, block: np.ndarray, poses: _Poses, c0: np.ndarray) -> np.ndarray:
    """Current position of undeformed points ``points`` (m, 2) of blocks ``block`` (m,)."""
    return _rotate(points - c0[block], poses.angle[block]) + c0[block] + poses.shift[block]


def _unplace(points: np.ndarray, block: np.ndarray, poses: _Poses, c0: np.ndarray) -> np.ndarray:
    """Undeformed position of current points (inverse of :func:`_place`)."""
    return _rotate(points - c0[block] - poses.shift[block], -poses.angle[block]) + c0[block]


def _vertices(structure: Structure, poses: _Poses, c0: np.ndarray) -> np.ndarray:
    v = structure.vertices
    return _rotate(v - c0[:, None, :], poses.angle[:, None]) + (c0 + poses.shift)[:, None, :]


def _motion(twist: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``a`` (n,) and centroid displacement (n, 2) of the exact rigid motion of the twists
    ``(v_x, v_y, omega)`` (n, 3) over the parameter ``s`` (module docstring)."""
    a = twist[:, 2] * s
    small = np.abs(a) < 1e-4
    safe = np.where(small, 1.0, a)
    sinc = np.where(small, 1 - a * a / 6, np.sin(safe) / safe)
    cosc = np.where(small, a / 2 - a**3 / 24, (1 - np.cos(safe)) / safe)
    v = twist[:, :2] * s
    return a, np.column_stack([sinc * v[:, 0] - cosc * v[:, 1], cosc * v[:, 0] + sinc * v[:, 1]])


def _moved(poses: _Poses, twist: np.ndarray, s: float) -> _Poses:
    a, dc = _motion(twist, s)
    return _Poses(poses.angle + a, poses.shift + dc)


def _mechanism(ops, u: np.ndarray, n_blocks: int) -> np.ndarray:
    """The mechanism ``u`` (canonical frame, ``ops.free_blocks`` order) as twists ``(v_x, v_y, omega)``
    per structure block (n_blocks, 3), in the structure's axes and length unit (zero for fixed blocks): the
    rows of :func:`blockmpec.report.mechanism_frame` (a positive multiple of the twists; a step rescales them)."""
    from blockmpec.report import mechanism_frame

    frame = mechanism_frame(ops, np.asarray(u, float))
    out = np.zeros((n_blocks, 3))
    out[frame["block"].to_numpy()] = frame[["u_x", "u_y", "rotation"]].to_numpy()
    return out


def _velocity(twist: np.ndarray, centre: np.ndarray, block: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Velocity of points ``p`` (m, 2) of blocks ``block`` under the twists about their current centroids."""
    w = twist[block]
    r = p - centre[block]
    return np.column_stack([w[:, 0] - w[:, 2] * r[:, 1], w[:, 1] + w[:, 2] * r[:, 0]])


# --------------------------------------------------------------------------- contacts kept closed


@dataclass
class _Closed:
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


def _closed_points(contacts, structure: Structure, twist: np.ndarray, poses: _Poses, c0: np.ndarray,
                   associative: bool) -> _Closed:
    """The touching contact points and what the mechanism does there (module docstring).

    ``structure`` is the deformed one (for the interfaces' friction and dilatancy)."""
    itf = contacts.interfaces
    k, j = np.nonzero(contacts.touching)
    inc, ref = itf.plus[k], itf.minus[k]
    p, f = contacts.points[k, j], contacts.feet[k, j]
    nu, tau = itf.normal[k], itf.tangent[k]
    centre = c0 + poses.shift
    rel = _velocity(twist, centre, inc, p) - _velocity(twist, centre, ref, p)
    v_n = np.einsum("md,md->m", rel, nu)
    v_t = np.abs(np.einsum("md,md->m", rel, tau))
    coef = structure.interface_friction() if associative else structure.interface_dilatancy()
    tol = VELOCITY_TOL * _vertex_speed(twist, structure.vertices, centre)
    hinge = (np.abs(v_n) <= tol) & (v_t <= tol)
    sliding = ~hinge & (v_n <= coef[k] * v_t + tol)
    angle = poses.angle[ref]
    closed = _Closed(inc, ref, _unplace(p, inc, poses, c0), _unplace(f, ref, poses, c0),
                     _rotate(nu, -angle), _rotate(tau, -angle), hinge, sliding)
    closed.gap = _normal_gaps(closed, poses, c0)
    return closed


def _vertex_speed(twist: np.ndarray, vertices: np.ndarray, centre: np.ndarray) -> float:
    """Largest speed of a block vertex (current ``vertices`` (n, k, 2), centroids ``centre``) under the
    twists (the mechanism's velocity scale)."""
    r = vertices - centre[:, None, :]
    w = twist[:, None, :]
    vel = np.stack([w[..., 0] - w[..., 2] * r[..., 1], w[..., 1] + w[..., 2] * r[..., 0]], axis=-1)
    return float(np.max(np.linalg.norm(vel, axis=-1)))


def _gaps(closed: _Closed, poses: _Poses, c0: np.ndarray, normal_rows: np.ndarray, slip_rows: np.ndarray):
    """Constraint values and Jacobian rows at ``poses``: the change of the normal gap ``nu . (p - f)``
    since the start of the step of the points ``normal_rows`` and the slip ``tau . (p - f)`` of the points
    ``slip_rows`` (``nu``, ``tau`` turning with the reference block).  Returns values (r,), incident and reference blocks (r,) and their
    derivatives (r, 3) with respect to (shift_x, shift_y, angle)."""
    p = _place(closed.p, closed.inc, poses, c0)
    f = _place(closed.f, closed.ref, poses, c0)
    angle = poses.angle[closed.ref]
    centre = c0 + poses.shift
    rows = []
    for normal, direction, use in ((True, _rotate(closed.nu, angle), normal_rows),
                                   (False, _rotate(closed.tau, angle), slip_rows)):
        w, pp, ff = direction[use], p[use], f[use]
        inc, ref = closed.inc[use], closed.ref[use]
        value = np.einsum("md,md->m", w, pp - ff)
        if normal and closed.gap is not None:  # a normal row keeps the gap its point had at the start
            value = value - closed.gap[use]
        d_inc = np.column_stack([w, _cross(pp - centre[inc], w)])
        perp = np.column_stack([-w[:, 1], w[:, 0]])
        d_ref = np.column_stack([-w, np.einsum("md,md->m", perp, pp - ff) - _cross(ff - centre[ref], w)])
        rows.append((value, inc, ref, d_inc, d_ref))
    return [np.concatenate([r[i] for r in rows]) for i in range(5)]


def _normal_gaps(closed: _Closed, poses: _Poses, c0: np.ndarray) -> np.ndarray:
    """Normal gap of every touching point at ``poses``, shape (m,)."""
    p = _place(closed.p, closed.inc, poses, c0)
    f = _place(closed.f, closed.ref, poses, c0)
    return np.einsum("md,md->m", _rotate(closed.nu, poses.angle[closed.ref]), p - f)


def _cross(r: np.ndarray, w: np.ndarray) -> np.ndarray:
    return r[:, 0] * w[:, 1] - r[:, 1] * w[:, 0]


#: Gauss-Newton sweeps of the closing correction.
MAX_SWEEPS = 20

#: Weight of the rows that close sliding points (see :func:`_close_contacts`).
SLIDING_WEIGHT = 0.1

#: A step whose correction moves a vertex by more than this fraction of the step's largest vertex
#: motion, or whose hard rows are not met, is halved (at most :data:`MAX_HALVINGS` times).
MAX_CORRECTION = 0.25
MAX_HALVINGS = 8

#: Damping of each sweep's least-squares problem (its matrix is dimensionless, entries of order 1):
#: nearly dependent rows (one corner held by two contacts whose normals differ by a small angle) whose
#: second-order gaps disagree would otherwise ask for a correction of the gap over that angle.
CORRECTION_DAMPING = 1e-3
@dataclass
class _Anchor:
    """The control point's advance to keep through the correction: ``e . q = value`` for the
    undeformed point ``point`` of block ``block``."""

    block: int
    point: np.ndarray
    e: np.ndarray
    value: float


def _close_contacts(closed: _Closed, poses: _Poses, c0: np.ndarray, fixed: np.ndarray, size: np.ndarray,
                    length_tol: float, anchor: _Anchor | None = None) -> tuple[_Poses, bool]:
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
    :func:`_close_contacts`; ``soft`` points (or None) get rows weighted :data:`SLIDING_WEIGHT`."""
    import scipy.sparse as sp

    dof = np.full(fixed.size, -1)
    free = np.flatnonzero(~fixed)
    dof[free] = np.arange(free.size)
    soft = np.zeros_like(active) if soft is None else soft & ~active
    normal_rows = active | soft
    value, inc, ref, d_inc, d_ref = _gaps(closed, poses, c0, normal_rows, active & closed.hinge)
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
        q = _place(anchor.point[None, :], np.array([k]), poses, c0)[0]
        arm = (q - c0[k] - poses.shift[k])[None, :]
        rows.append(np.full(3, value.size))
        cols.append(3 * dof[k] + np.arange(3))
        vals.append(np.array([anchor.e[0], anchor.e[1], _cross(arm, anchor.e[None, :])[0] / size[k]]))
        value = np.append(value, float(anchor.e @ q) - anchor.value)
        weight = np.append(weight, 1.0)
    J = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                     shape=(value.size, 3 * free.size))
    return value, J, free, weight


def _sweeps(closed, poses, c0, fixed, size, length_tol, anchor, active, soft):
    """Gauss-Newton sweeps of :func:`_close_contacts` (``soft``: the points with weighted rows, or None)."""
    from scipy.sparse.linalg import lsqr

    for _ in range(MAX_SWEEPS):
        active = active | (_normal_gaps(closed, poses, c0) < np.minimum(closed.gap, 0.0) - 0.01 * length_tol)
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


def _dead_load_mechanism(ops) -> np.ndarray | None:
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


# --------------------------------------------------------------------------- input


def _check_number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise OptionError(f"{name}: expected a number; got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise OptionError(f"{name}: must be a finite number > 0; got {value!r}")
    return v


def _structure_size(structure: Structure) -> float:
    """Bounding-box diagonal of the free blocks."""
    v = structure.vertices[~structure.fixed].reshape(-1, 2)
    return float(np.hypot(*(v.max(axis=0) - v.min(axis=0))))


def _control_block(structure: Structure, control: Any) -> tuple[int | None, np.ndarray | None]:
    """``(block, point)`` of a control given as a block index or a point (None: chosen after the first solve)."""
    if control is None:
        return None, None
    n = structure.n_blocks
    if isinstance(control, (int, np.integer)) and not isinstance(control, bool):
        k = int(control)
        if not 0 <= k < n:
            raise OptionError(f"control: block {k} does not exist (there are {n} blocks, 0 to {n - 1})")
        if structure.fixed[k]:
            raise OptionError(f"control: block {k} is fixed (a support); give a free block")
        return k, structure.centroid[k]
    try:
        point = np.asarray(control, float).reshape(2)
    except (TypeError, ValueError):
        raise OptionError(f"control: expected a block index or a point (x, y); got {control!r}") from None
    if not np.all(np.isfinite(point)):
        raise OptionError(f"control: the point {control!r} must be finite")
    inside = _inward_distance(structure, point)
    k = int(np.argmax(inside))
    size = shorter_sides(structure.vertices)
    if inside[k] < -CONTACT_TOLERANCE * size[k]:
        raise OptionError(f"control: the point {point.tolist()} lies in no block")
    free_inside = np.where(structure.fixed, -np.inf, inside)
    kf = int(np.argmax(free_inside))
    if free_inside[kf] < -CONTACT_TOLERANCE * size[kf]:
        raise OptionError(f"control: the point {point.tolist()} lies in block {k}, which is fixed (a support); "
                          "give a point of a free block")
    return kf, point


def _inward_distance(structure: Structure, point: np.ndarray) -> np.ndarray:
    """Per block, the smallest distance of ``point`` inside its edges' lines (negative: outside)."""
    from blockmpec.contacts import _edges

    start, _, _, normal, _, valid = _edges(structure.vertices, structure.n_vertices)
    d = -np.einsum("nkd,nkd->nk", normal, point[None, None, :] - start)
    return np.where(valid, d, np.inf).min(axis=1)


# --------------------------------------------------------------------------- the curve


def pushover(
    structure: Structure,
    method: str = "static-lp",
    *,
    control: int | tuple[float, float] | None = None,
    max_displacement: float | None = None,
    steps: int = 20,
    contact_tolerance: float = CONTACT_TOLERANCE,
    contact_length: float = CONTACT_LENGTH,
    verify_tol: float = 1e-6,
    options: dict[str, Any] | None = None,
):
    r"""The capacity curve of a structure: its load multiplier as it moves along its mechanism.

    Parameters
    ----------
    structure : Structure
    method : str
        A registered method (``static-lp``: associative; ``fixed-point``: non-associative; any
        method whose result has a mechanism).
    control : int or (x, y), optional
        The control point: a free block's index (its centroid) or a point of a free block.
        Default: the centroid of the free block whose centroid moves fastest along the live load
        in the first mechanism.
    max_displacement : float, optional
        Displacement of the control point along the live load at which the curve stops, in the
        structure's length unit.  Default: half the median shorter side of the free blocks'
        bounding boxes (a single ``b x h`` block: ``b/2`` when ``b <= h``, where it topples).
    steps : int
        Number of equal increments of the control displacement up to ``max_displacement``.
    contact_tolerance, contact_length : float
        Contact tolerance and point-contact length, relative to the shorter side of the smaller
        block of each pair (:mod:`blockmpec.contacts`).
    verify_tol : float
        Passed to :func:`blockmpec.solve`: a step succeeds only when its residuals are at most this.
    options : dict, optional
        The method's options.

    Returns
    -------
    pandas.DataFrame
        One row per solve (``steps + 1`` rows unless the curve stops early, plus one per step cut
        at a contact event), columns:

        ``step``
            row number, 0 for the undeformed structure;
        ``displacement``
            control point's displacement along the live load from the start (structure length unit;
            positive in the sense of the live load);
        ``rotation``
            the control block's rotation from the start (radians, counter-clockwise positive in the
            structure's axes: a block toppling towards ``+x`` has a negative rotation);
        ``multiplier``
            the load multiplier ``lam`` of the configuration (NaN when the solve failed);
        ``status``
            the solve's status (``optimal``, ``converged``, ... or why it failed);
        ``control_x, control_y``
            the control point's position;
        ``contacts, point_contacts``
            number of contacts and how many of them are vertex-to-edge points;
        ``time_s``
            wall time of the step (contacts, assembly, model building and solve);
        ``block_<i>_x, block_<i>_y, block_<i>_angle``
            centroid and rotation from the start of every block ``i`` (structure indices, fixed
            blocks included): block ``i``'s vertices at a step are
            ``R(angle) (V_i - c_i) + (x, y)``, with ``V_i`` its vertices and ``c_i`` its centroid in
            ``structure`` (:func:`block_polygons` does this).

        ``attrs`` holds ``method``, ``problem``, ``control_block``, ``control_point`` (undeformed),
        ``direction`` (+1 or -1: the sense of the live load along ``x``), ``max_displacement``,
        ``steps``, ``step_size``, ``contact_tolerance``, ``contact_length``, ``stop_reason`` and
        ``ultimate_displacement`` (where ``lam`` crosses 0, linearly interpolated, or None).
        Plot ``multiplier`` against ``displacement`` for the capacity curve
        (:func:`blockmpec.pushover_plot.plot_capacity_curve`).

    Raises
    ------
    OptionError
        A control block that is fixed or absent, a control point in no free block, a
        non-positive ``max_displacement`` or ``steps``, a step larger than the structure (the
        bounding-box diagonal of its free blocks), a bad tolerance or option.
    UnknownNameError
        An unknown method.
    """
    import pandas as pd

    from blockmpec.operators import assemble
    from blockmpec.registry import get_solver
    from blockmpec.solver import solve

    if not isinstance(structure, Structure):
        raise OptionError(f"structure: expected a blockmpec Structure; got {type(structure).__name__}")
    options = dict(options or {})
    solver_cls = get_solver(method)
    solver_cls(**options)  # a bad option: OptionError before anything runs
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise OptionError(f"steps: must be an integer >= 1; got {steps!r}")
    steps = int(steps)
    verify_tol = _check_number("verify_tol", verify_tol)
    contact_tolerance = _check_number("contact_tolerance", contact_tolerance)
    contact_length = _check_number("contact_length", contact_length)
    if contact_tolerance > 0.1:
        raise OptionError(f"contact_tolerance: must be at most 0.1 (of the smaller block's shorter side); "
                          f"got {contact_tolerance:g}")
    if contact_length > 0.5:
        raise OptionError(f"contact_length: must be at most 0.5 (of the smaller block's shorter side); "
                          f"got {contact_length:g}")
    size = _structure_size(structure)
    side = shorter_sides(structure.vertices)
    if max_displacement is None:
        max_displacement = 0.5 * float(np.median(side[~structure.fixed]))
    max_displacement = _check_number("max_displacement", max_displacement)
    step_size = max_displacement / steps
    if step_size > size:
        raise OptionError(f"step: max_displacement / steps = {step_size:.6g} is larger than the structure "
                          f"(its free blocks span {size:.6g}); take more steps or a smaller max_displacement")
    control_block, control_point = _control_block(structure, control)

    c0 = structure.centroid
    n = structure.n_blocks
    fixed = structure.fixed
    poses = _Poses(np.zeros(n), np.zeros((n, 2)))
    problem = solver_cls.problem
    associative = problem == "associative"
    length_tol = contact_tolerance * float(np.min(side[~fixed]))
    block_size = np.maximum(side, np.finfo(float).tiny)
    rows: list[dict[str, Any]] = []
    direction = None
    stop_reason = "max_displacement reached"
    displacement = 0.0
    target_step = 0
    event = "start"
    snaps, snap_motion = 0, 0.0
    last_push = None  # (poses of a step as a function of s, the s taken) of the last push step
    pending = None  # poses just past an instability, to go to after recording the last ones that stand
    falling = False  # the next configuration follows an instability or a snap: check for a fall before solving

    def record(res, contacts, elapsed, retried=""):
        q = None if control_block is None else _place(control_point[None, :], np.array([control_block]),
                                                      poses, c0)[0]
        row = {
            "step": len(rows),
            "displacement": displacement,
            "rotation": np.nan if control_block is None else float(poses.angle[control_block]),
            "multiplier": float(res.multiplier) if res.success else np.nan,
            "status": res.status.value,
            "event": event,
            "control_x": np.nan if q is None else float(q[0]),
            "control_y": np.nan if q is None else float(q[1]),
            "contacts": len(contacts),
            "point_contacts": contacts.n_points,
            "time_s": elapsed,
            "retried_with": retried,
        }
        centre = c0 + poses.shift
        for i in range(n):
            row[f"block_{i}_x"] = float(centre[i, 0])
            row[f"block_{i}_y"] = float(centre[i, 1])
            row[f"block_{i}_angle"] = float(poses.angle[i])
        rows.append(row)

    def reached(d: float) -> int:
        """The steps completed at the control displacement ``d`` (the next row aims at the next one)."""
        return min(steps, max(0, int(math.floor(d / step_size + 1e-6))))

    def control_at(p: _Poses) -> float:
        return float(e @ (_place(control_point[None, :], np.array([control_block]), p, c0)[0] - control_point))

    while True:
        t0 = time.perf_counter()
        vertices = _vertices(structure, poses, c0)
        contacts = find_contacts(vertices, structure.n_vertices, fixed, tolerance=contact_tolerance,
                                 contact_length=contact_length)
        deformed = _contact_structure(structure, vertices, contacts)
        ops = assemble(deformed)
        lonely = _lonely_block(structure, contacts)
        retried, checked = "", falling
        # just past an instability or after a snap: the proof that no lam holds first, it costs one small LP
        fall = _dead_load_mechanism(ops) if checked else None
        if lonely is not None:  # it cannot stand: no solve (its equilibrium rows would read 0 = weight)
            res = Result(method=method, status=Status.INFEASIBLE, problem=problem,
                         message=f"block {lonely} touches no other block")
        elif fall is not None:  # proven: no lam holds it (a method would spend its starts and fallbacks on it)
            res = Result(method=method, status=Status.INFEASIBLE, problem=problem,
                         message="no lam holds this configuration: a mechanism on which only the dead load works")
        else:
            res = solve(ops, method, verify_tol=verify_tol, **options)
        falling = False
        if not res.success and rows:
            # a mechanism on which the dead load works and the live load does not proves that no lam holds
            # this configuration (Farkas); without one, the method failed where a solution exists: retry
            if not checked:
                fall = _dead_load_mechanism(ops)
            for retry in RETRY_OPTIONS.get(method, ()) if fall is None else ():
                if res.success or set(retry) & set(options):
                    continue
                res = solve(ops, method, verify_tol=verify_tol, **{**options, **retry})
                retried = ",".join(f"{k}={v}" for k, v in retry.items())
        if fall is not None and last_push is not None:
            # the step went past the configuration where the structure stops standing: cut it back there
            before, after = _cut_at_instability(structure, fixed, last_push, c0, contact_tolerance, contact_length)
            last_push = None
            if before is not None:
                poses, pending, event = before, after, "instability"
            else:
                poses = after
            displacement = control_at(poses)
            target_step = reached(displacement)
            continue
        last_push = None
        if direction is None:
            direction = float(ops.mirror)
            e = np.array([direction, 0.0])
        if control_block is None and res.success and res.solution.u is not None:
            twist = _mechanism(ops, res.solution.u, n)
            control_block = int(np.argmax(np.where(fixed, -np.inf, direction * twist[:, 0])))
            control_point = c0[control_block].copy()
        record(res, contacts, time.perf_counter() - t0, retried)
        if len(rows) > MAX_ROWS_PER_STEP * steps + 10:
            stop_reason = f"more than {MAX_ROWS_PER_STEP} solves per step (contact events, snaps)"
            break

        if res.success and res.solution.u is not None:
            snaps, snap_motion = 0, 0.0
            if res.multiplier <= 0:
                stop_reason = "the load multiplier reached 0"
                break
            if pending is not None:  # just past the instability, where the structure falls
                poses, pending, event = pending, None, "step"
                falling = True
                displacement = control_at(poses)
                target_step = reached(displacement)
                continue
            if target_step >= steps:
                break
            twist = _mechanism(ops, res.solution.u, n)
            rate = float(e @ _velocity(twist, c0 + poses.shift, np.array([control_block]),
                                       _place(control_point[None, :], np.array([control_block]), poses, c0))[0])
            if not rate > VELOCITY_TOL * _vertex_speed(twist, vertices, c0 + poses.shift):
                stop_reason = (f"the control point (block {control_block}) does not move along the live load in "
                               "the mechanism of this configuration")
                break
            target = (target_step + 1) * step_size
            s_full = _parameter_for(lambda s: control_at(_moved(poses, twist, s)) - target,
                                    max(target - displacement, 1e-3 * step_size) / rate)
            if s_full is None:
                stop_reason = f"the control point (block {control_block}) cannot advance by a step along this mechanism"
                break
            closed = _closed_points(contacts, deformed, twist, poses, c0, associative)
            event = "step"
        elif (fall is not None and control_block is not None and snaps < MAX_SNAPS
              and snap_motion <= MAX_SNAP_MOTION * float(np.min(side[~fixed]))):
            # no lam holds this configuration: it falls along the dead-load mechanism until a contact closes
            twist = _mechanism(ops, fall, n)
            s_full = step_size / _vertex_speed(twist, vertices, c0 + poses.shift)
            closed = _closed_points(contacts, deformed, twist, poses, c0, True)
            event = "snap"
            snaps += 1
            falling = True
        else:
            stop_reason = f"{method} did not succeed: {res.status.value}" + (f" ({res.message})" if res.message else "")
            if fall is not None and snaps:
                stop_reason = (f"the structure collapses: no lam holds it, and {snaps} moves under its dead load "
                               f"(up to {snap_motion:.3g}) reached no configuration that stands")
            break

        push = event == "step"

        def trial(s, _twist=twist, _closed=closed, _poses=poses, _push=push):
            moved = _moved(_poses, _twist, s)
            anchor = _Anchor(control_block, control_point, e, float(e @ _place(
                control_point[None, :], np.array([control_block]), moved, c0)[0])) if _push else None
            out, met = _close_contacts(_closed, moved, c0, fixed, block_size, length_tol, anchor)
            return out, met, moved

        halvings = 0
        while True:
            new, met, moved = trial(s_full)
            motion = np.max(np.linalg.norm(_vertices(structure, moved, c0) - vertices, axis=-1))
            correction = np.max(np.linalg.norm(_vertices(structure, new, c0) - _vertices(structure, moved, c0),
                                               axis=-1))
            if (met and (push or correction <= MAX_CORRECTION * motion)) or halvings >= MAX_HALVINGS:
                break
            s_full *= 0.5
            halvings += 1
        if halvings:
            event = "substep" if event == "step" else event
        cut_trial = lambda s: trial(s)[0]  # noqa: E731
        overlap = _overlaps(structure, new, c0, contact_tolerance)
        if overlap is not None:
            new, s_full = _cut_at_contact(structure, cut_trial, s_full, overlap, c0, contact_tolerance)
            if new is None:
                stop_reason = "blocks overlap and the step could not be cut back to their contact"
                break
            event = "contact" if event in ("step", "substep") else event
        if event == "snap":
            snap_motion += float(np.max(np.linalg.norm(_vertices(structure, new, c0) - vertices, axis=-1)))
        else:
            last_push = (cut_trial, s_full)
        poses = new
        displacement = control_at(poses)
        target_step = reached(displacement)

    curve = pd.DataFrame(rows)
    curve.attrs.update(
        method=method, problem=problem, control_block=control_block,
        control_point=None if control_point is None else [float(v) for v in control_point],
        direction=direction, max_displacement=max_displacement, steps=steps, step_size=step_size,
        contact_tolerance=contact_tolerance, contact_length=contact_length, stop_reason=stop_reason,
        ultimate_displacement=_ultimate(curve),
    )
    return curve


def _lonely_block(structure: Structure, contacts) -> int | None:
    touched = np.zeros(structure.n_blocks, bool)
    touched[contacts.interfaces.minus] = True
    touched[contacts.interfaces.plus] = True
    lonely = np.flatnonzero(~touched & ~structure.fixed)
    return int(lonely[0]) if lonely.size else None


def _parameter_for(f, guess: float) -> float | None:
    """The root ``s > 0`` of ``f`` (``f(0) < 0``), bracketed from ``guess`` by doubling (Brent)."""
    from scipy.optimize import brentq

    hi = guess
    for _ in range(40):
        if f(hi) >= 0:
            return float(brentq(f, 0.0, hi, xtol=1e-14 * hi, rtol=1e-14, maxiter=200))
        hi *= 2.0
        if not math.isfinite(hi):
            break
    return None


def _overlaps(structure: Structure, poses: _Poses, c0: np.ndarray, tolerance: float):
    """The pairs ``(a, b)`` overlapping by more than the contact tolerance at ``poses``, or None."""
    from blockmpec.contacts import max_penetration

    hits = max_penetration(_vertices(structure, poses, c0), structure.n_vertices, structure.fixed, tolerance)
    deep = hits[hits[:, 2] > tolerance]
    return None if deep.size == 0 else (deep[:, 0].astype(int), deep[:, 1].astype(int))


def _cut_at_contact(structure, trial, s_full, overlap, c0, tolerance):
    """Poses of the largest step ``s < s_full`` at which the blocks touch without overlapping (bisection)."""
    lo, hi = 0.0, s_full
    pairs = overlap
    side = shorter_sides(structure.vertices)
    for _ in range(MAX_BISECTIONS):
        mid = 0.5 * (lo + hi)
        poses = trial(mid)
        again = _overlaps(structure, poses, c0, tolerance)
        if again is not None:
            hi, pairs = mid, again
            continue
        a, b = pairs
        sep_a, _, sep_b, _ = pair_separation(_vertices(structure, poses, c0), structure.n_vertices, a, b)
        gap = np.maximum(sep_a, sep_b) / np.minimum(side[a], side[b])
        if np.all(gap <= tolerance):
            return poses, mid
        lo = mid
    return None, None


def _stands(structure: Structure, poses: _Poses, c0: np.ndarray, tolerance: float, length: float) -> bool:
    """Whether some ``lam`` holds the configuration (no dead-load mechanism, :func:`_dead_load_mechanism`)."""
    from blockmpec.operators import assemble

    vertices = _vertices(structure, poses, c0)
    contacts = find_contacts(vertices, structure.n_vertices, structure.fixed, tolerance=tolerance,
                             contact_length=length)
    if _lonely_block(structure, contacts) is not None:
        return False
    return _dead_load_mechanism(assemble(_contact_structure(structure, vertices, contacts))) is None


def _cut_at_instability(structure, fixed, last_push, c0, tolerance, length):
    """``(before, after)``: poses of the last step cut back to the last configuration that stands
    (None when that is where the step started) and just past it, by :data:`INSTABILITY_BISECTIONS`
    bisections of ``s``."""
    trial, s_used = last_push
    lo, hi = 0.0, s_used
    for _ in range(INSTABILITY_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _stands(structure, trial(mid), c0, tolerance, length):
            lo = mid
        else:
            hi = mid
    return (trial(lo) if lo > 0 else None), trial(hi)


def _ultimate(curve) -> float | None:
    """Displacement where the multiplier crosses 0 (linear between the last two rows), or None."""
    lam = curve["multiplier"].to_numpy(float) if len(curve) else np.zeros(0)
    if lam.size >= 2 and np.isfinite(lam[-1]) and lam[-1] <= 0 < lam[-2]:
        d = curve["displacement"].to_numpy(float)
        return float(d[-2] + (d[-1] - d[-2]) * lam[-2] / (lam[-2] - lam[-1]))
    return None


def block_polygons(structure: Structure, curve, row: int) -> list[np.ndarray]:
    """The blocks' vertices (each (k_i, 2)) at row ``row`` of a curve from :func:`pushover`."""
    r = curve.iloc[row]
    c0 = structure.centroid
    out = []
    for i in range(structure.n_blocks):
        v = structure.polygon(i) - c0[i]
        angle = float(r[f"block_{i}_angle"])
        out.append(_rotate(v, np.float64(angle)) + [float(r[f"block_{i}_x"]), float(r[f"block_{i}_y"])])
    return out




# --------------------------------------------------------------------------- command line


__all__ = ["pushover", "block_polygons", "CURVE_COLUMNS"]
