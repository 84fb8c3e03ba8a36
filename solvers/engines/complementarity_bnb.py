r"""A branch-and-bound over the complementarity pairs of (3) with a lifted LP bound (no big-M).

Notation of :mod:`blockmpec.formulations.mpec_milp`: ``w = (lam, x, u, z)``, pair rows
``G x <= 0`` with slacks ``s = -G x``, ``B = F - G_x^T`` (the friction work), work
identity (W) at every solution of (3) in the normalisation ``f_l^T u = 1``::

    lam = -f_d^T u + sum_e B_e x_{r_e} z_{i_e}.

Lifted relaxation (level-one RLT with the multipliers).  For each pair ``i`` that
appears in ``B`` (the friction pairs) let ``x^(i) := z_i x`` and ``zeta_i := z_i lam``.
Multiplying equilibrium and ``G x <= 0`` by ``z_i >= 0``, and using ``s_i z_i = 0``::

    E x^(i) + zeta_i f_l + f_d z_i = 0,   G x^(i) <= 0,   G_i x^(i) = 0,
    lam_lower z_i <= zeta_i <= lam_upper z_i,

so (W) becomes the *linear* ``lam = -f_d^T u + sum_e B_e x^(i_e)_{r_e}``.  (The rows ``G_i x^(i) = 0``
of each copy's own pair hold at every node; before issue 12's second round they were only set
once pair ``i`` was branched active.)

Products with the mechanism (``lifting`` of :class:`~blockmpec.solvers.milp.MILPOptions`):

* (M) ``v := lam u`` and ``zeta_j := lam z_j`` for *every* pair: compatibility and ``f_l^T u = 1``
  times ``lam`` give ``E^T v + F zeta = 0`` and ``f_l^T v = lam``.  When ``E^T`` is injective
  (every block tied to the supports) ``u`` is a linear function of ``z`` and (M) says
  ``lam = sum_i c_i zeta_i`` with ``c_i`` the live work of multiplier ``i``: the static field's
  ``lam`` is tied to the copies' ``zeta_i / z_i``.
* (X) ``W[r, :] := x_r u`` for the tied forces ``r`` (``lifting="rlt"``: every normal and
  tangential force; needs a copy for every pair): compatibility and ``f_l^T u = 1`` times ``x_r``
  give ``E^T W[r, :] + sum_i F[:, i] x^(i)_r = 0`` and ``f_l^T W[r, :] = x_r``.  So for each ``r`` the
  vector ``(x^(i)_r)_i = x_r z`` is itself a compatible multiplier vector whose mechanism does live
  work ``x_r``: with ``E^T`` injective, ``x_r = sum_i c_i x^(i)_r``, which ties the copies to *one*
  static field (the coupling the normal-force bound of ``studies/lab/normal_force_bound.py`` lacked).
  The products of equilibrium with ``u_k`` and of the active pair rows with ``u_k`` are implied
  when ``E^T`` is injective and are left out.  Measured root bounds (``studies/lab/certificate_study.py``):
  2x2 running bond 0.16 -> 0.65, 3x2 0 -> 0.65, 2x4 0.07 -> 0.65 (each the certified minimum); tying the
  normal forces alone gave 0.40 on 2x4, all forces (moments too) the same 0.65 at twice the LP time.
  ``lifting="rlt-full"`` ties every force, the moments too: on the 5x2 running-bond wall the root
  bound is then the minimum 0.6, where tying normal and tangential forces gave 0.5578 (a gap that
  branching on pairs or on ``lam`` hardly moved: child bounds 0.5578-0.5667, 0.5605 after 5 nodes).

Branching on ``lam`` (``lam_branching``): a node carries ``[a, b]`` (``b`` capped by the incumbent)
with ``a z_i <= zeta_i <= b z_i`` in every copy and ``a <= lam <= b``, valid since ``z_i >= 0``;
bisection of ``[bound, b]`` competes with the pair candidates in strong branching.  Together with
compatibility, ``f_l^T u = 1``, ``z >= 0`` and the static part ``E x + lam f_l + f_d = 0``,
``G x <= 0``, every solution of (3) gives a feasible point, so the LP minimum of ``lam``
is a lower bound.  (At the root it equals the conditional-OBBT bound
:meth:`~blockmpec.solvers.milp.MILPSolver._dissipation_minimum`.)

Branching on a pair ``j`` splits the solutions of (3) exactly (no big-M):

* ``active``: ``s_j = 0``, so ``G_j x = 0`` and ``G_j x^(i) = -s_j z_i = 0`` in *every* copy
  (this is where the copies couple: a sliding joint forces its friction rows tight in the
  static field of every other sliding pair, and the friction work bound moves);
* ``inactive``: ``z_j = 0`` (so the copy ``j`` vanishes: ``zeta_j = 0``).

Dormant rows (``root_lp="ipm"``).  Any subset of the rows above gives a relaxation (every lifted
point of (3) satisfies each row), so dropping rows can only lower the LP minimum: the bound stays
valid.  With ``root_lp="ipm"`` the root LP is first solved by HiGHS's interior point without
crossover (a few seconds where the dual simplex needed minutes: the lifted LP is very degenerate,
most copies are zero); the copy pair rows ``G_j x^(i) <= 0`` (``j != i``, the bulk of the rows)
whose dual there is zero within ``DORMANT_DUAL_TOL`` are made *dormant* (free), and every node LP,
the root included, is then solved by the dual simplex on the remaining rows.  After each optimal
node LP the dormant rows violated at its point are woken (globally: they are valid at every node)
and the LP is re-solved, at most ``SEPARATION_ROUNDS`` times; a pair branched active still has all
its rows ``G_j x^(i) = 0`` imposed.  The interior point's row duals ``y`` also give a bound by weak
duality (:func:`dual_bound`: ``lam >= sum_r min_{[l_r, u_r]} y_r t + sum_j min_{[cl_j, cu_j]} d_j w_j``,
``d = c - A^T y``); the interior point runs on the LP without the cap ``lam <= incumbent`` (with the cap
it stopped short on the 4x2 wall), and when that bound meets the incumbent within ``INTERIOR_CLOSE_TOL``
the root is closed with no simplex at all.  The interior point is HiGHS's IPX (``INTERIOR_SOLVER``;
HiGHS's own "ipm" choice runs HiPO first, which stalled on the 4x3 wall).  Measured (CPU s): root LP of
the 4x2 / 5x2 / 4x3 running-bond walls 1.8 / 7.1 / 25.8 s by IPX (HiGHS's "ipm": 4.5 / 15.4 / 42 s)
against 21 / > 600 / > 600 s by the dual simplex.  IPX's first run's dual bound is 8e-10 below the 4x2
minimum and 2.8e-12 below the 4x3 one, so the 4x3 wall is certified at the root by one run (HiGHS's
"ipm": 3.8e-7 below; a second run without the dormant rows, 5.8e-10 below, is what
:meth:`ComplementarityBnB.interior_root` does when the first does not close the root).  The dual
simplex on the remaining rows: 4.0 s (4x2), 7.5-36 s (5x2), > 200 s (4x3).

Null-space coordinates (``root_lp="ipm"`` with ``lifting="rlt-full"``).  Most rows of the lifted LP say that
the static field, every copy and the products with ``u`` are static or kinematic fields.
:mod:`~blockmpec.solvers.linalg.null_space` solves equilibrium and compatibility once (a spanning tree of the
contact graph gives a sparse basis of self-stresses) and writes the root LP in the remaining coordinates: the same
LP, the same minimum, with every copy's equilibrium rows and all of ``W = x u^T`` gone (2x15 running-bond wall:
166,078 x 87,359 -> 105,535 x 38,906).  IPX solves it 3-4x faster (``python studies/lab/root_lp_engines.py --engines
2x4,5x2,4x3,2x8 --only ipx,ipx-null-space``, CPU s, lifted -> null-space, same bound to 1e-9: 2x4 1.59 -> 0.40, 5x2
8.32 -> 2.85, 4x3 26.6 -> 6.92, 2x8 38.2 -> 8.55), and the 2x13 and 2x15 walls, whose lifted root LP gave no bound
in 1,500 s, in 61 s and 123 s.  Its pair rows are rows of the lifted LP, one to one, so their
duals pick the dormant rows as before; the node LPs stay on the lifted LP.  ``root_lp="ipm-lifted"`` solves the
lifted LP (``"ipm"`` before).

Row generation (``root_lp="ipm-rows"``, :meth:`ComplementarityBnB.generated_root`): the root LP by rounds of the
same interior point, the first without the copy friction rows and the moments' rows (X), each next one with the
left-out rows violated at the last point added; every round's dual bound is valid (a relaxation).  Measured
(``studies/lab/root_rows.py``, rlt-full, CPU s to certify, against ``root_lp="ipm"`` in the same run): 2x4 6.5 / 3.8,
5x2 90 / 21, 4x3 219 / 20, 3x4 149 / 17, with 4-6 rounds whose bound stays near 0 until most rows are back (4x3:
-1.6e-9, 0.14, 0.31, 0.38, 0.63, 0.636 = the minimum, the last LP 26k of the 30k rows): the reduced LPs are not
cheaper for the interior point (4x3: 12 s for round 0's 19k rows, 35-52 s for each later round, 26 s for the whole
LP without the moments).  Without the unilateral rows too the copies are nearly free and round 0 on the 4x3 wall had
not ended after 200 s.  So it stays an option, not the default.

Node LPs in null-space coordinates (issue 41).  With the root in null-space coordinates (``root_lp="ipm"``,
``rlt-full``) every node LP is solved there too (:class:`NullSpaceNodes`: the same LP, its pair rows, ``zeta`` rows,
``lam`` and ``z`` columns mapped one to one), by HiGHS's interior point without crossover (``node_lp="interior"``;
its duals give the node's bound through :func:`dual_bound`, valid whatever the point).  Measured on issue 41's
9-block door wall (load 3-5): 0.5-0.6 s a node LP, where the dual simplex warm-started from the parent's basis took
0.4-22 s, hit 7,272-iteration limits on most strong-branching children at mu 0.8, and once cycled (338k iterations
in 144 s).  An infeasible node LP gives the interior point no duals; then the LP without the cap ``lam <=
incumbent`` prunes it if its bound reaches the cap, and failing that the dual simplex on a sparse relaxation (the
root's dormant rows left out) prunes it only on a *checked* Farkas certificate (:func:`proves_infeasible`; a
relaxation's infeasibility is the node's).  A node LP left undecided keeps its parent's bound.

Strong branching with fixings.  Both children of up to ``strong`` candidates (``ROOT_STRONG`` at the root) are
solved; a candidate one of whose children is pruned (infeasible, or bounded at the incumbent) is *fixed* to the
other child in the node itself, whose LP becomes the node's (a domain reduction: no new node), and the candidates
are evaluated again on the reduced node (``FIXING_ROUNDS``); a node whose every candidate closes both children is
closed.  On the door wall at mu 0.8 (root bound 0.6245, minimum 0.7058) the root alone is closed this way: ~80
node LPs, no branching (mu 0.65: 6 s; mu 0.8: 127-160 s at load 3).

A node whose pairs are all fixed (a leaf) is one pattern: its minimum is the exact
polish of the pattern (:meth:`MILPSolver.polish`).  Nodes are explored best-bound first;
on the lifted LP (``node_lp="simplex"``, or without null-space coordinates) the LP is warm-started from the previous
node (HiGHS re-solves after bound changes).  An LP that is not optimal never prunes (its node keeps the parent's
bound); an infeasible LP is pruned on a checked Farkas certificate, or after a cold re-solve that says infeasible
again and whose certificate checks.  Branching picks the
free pair with the largest complementarity violation ``z_j s_j`` of the LP point, plus
its friction-work defect ``|B_e (x^(i)_r - z_i x_r)|`` (the copy and the static field
disagree on the normal force that dissipates).
"""

from __future__ import annotations

import heapq
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.formulations.compiled import FRICTION
from blockmpec.result import Status
from blockmpec.solvers.engines.highs import (
    change_applied,
    highs_lp,
    highs_status,
    new_highs,
    set_deadline,
    set_feasibility_tolerances,
    use_interior_point,
)
from blockmpec.solvers.engines.mip import MIPRun, _Tracer

#: a node is pruned when its bound is within this (times max(1, |incumbent|)) of the incumbent
PRUNE_TOL = 1e-9
#: complementarity violation below which a pair of the LP point counts as satisfied
VIOLATION_TOL = 1e-9
#: feasibility tolerances of the lifted LPs: a first solve at the loose one, the answer at the tight one
LOOSE_LP_TOL = 1e-7
LP_TOL = 1e-9
#: lam_branching: a node's interval [bound, min(b, incumbent)] is bisected only while wider than this (relative)
LAM_SPLIT_TOL = 1e-6
#: root_lp="ipm": a copy pair row whose interior-point dual is at most this (absolute, per-block units) is dormant
DORMANT_DUAL_TOL = 1e-7
#: a dormant row violated by more than this at a node's LP point is woken
SEPARATION_TOL = 1e-9
#: re-solves of one node LP after waking violated dormant rows
SEPARATION_ROUNDS = 3
#: simplex iterations of one node LP solve at most: ``max(NODE_LP_ITERATIONS, rows + columns)`` (a
#: warm node LP of the 9-block door wall takes 0-600; the dual simplex was seen to cycle there, 338k iterations)
NODE_LP_ITERATIONS = 5_000
#: :func:`proves_infeasible`: a Farkas value must exceed this times the size of its terms
FARKAS_MARGIN = 1e-7
#: strong branching with fixings: rounds of candidates per node at most (each after a fixing)
FIXING_ROUNDS = 5
#: strong branching: candidates evaluated at the root (every other node: ``strong``)
ROOT_STRONG = 16
#: ``"ipm"``: the root LP by the interior point, in the null-space coordinates of
#: :mod:`~blockmpec.solvers.linalg.null_space` where the lifting allows (``rlt-full``; the lifted LP otherwise);
#: ``"ipm-lifted"``: the same on the lifted LP itself (``"ipm"`` before the null-space coordinates);
#: ``"ipm-rows"``: row generation on the lifted LP
ROOT_LPS = ("simplex", "ipm", "ipm-rows", "ipm-lifted")
#: root_lp="ipm-rows": interior-point rounds of the root's row generation at most (each adds the rows violated at
#: the previous round's point)
ROOT_ROW_ROUNDS = 30
#: root_lp="ipm-rows": a left-out row violated by more than this (absolute, per-block units; IPX's primal
#: feasibility tolerance) at an interior point's primal point is added for the next round
ROOT_ROW_TOL = 1e-7
#: root_lp="ipm": the root is closed when the interior point's dual bound is within this (times max(1, |incumbent|))
#: of the incumbent (= CERTIFICATE_TOL of milp, which then checks the reported gap against the same tolerance)
INTERIOR_CLOSE_TOL = 1e-7
#: root_lp="ipm" in null-space coordinates: HiGHS's primal and dual feasibility tolerances of the interior point.
#: At HiGHS's default (1e-7) IPX ended "optimal" on the 6x3 running-bond wall's null-space LP with reduced costs
#: up to 7e-8 on free columns, which give no bound; at 1e-10 the largest was 8e-10 and the bound 0.57533 (86 s
#: against 83 s CPU)
NULL_SPACE_IPM_TOL = 1e-10
#: root_lp="ipm" in null-space coordinates: the second interior point (on the LP without its zero-dual rows) runs only
#: when the first one's finite bound is within this (times max(1, |incumbent|)) of the incumbent
NULL_SPACE_SETTLED_GAP = 1e-5
#: root_lp="ipm": HiGHS's interior point.  "ipx", not HiGHS's "ipm" (which in 1.15 runs HiPO first and IPX only
#: after HiPO stalls): one run on each root LP, IPX against "ipm" (CPU s; first run, second run):
#: 4x3 wall 25.8 / 6.9 s against 42.0 / 16.5 s, dual bound 2.8e-12 against 3.8e-7 below the minimum after the
#: first run; 5x2 7.1 / 2.3 against 15.4 / 3.8; 2x4 1.2 / 0.6 against 4.0 / 1.1; 3x2 0.4 / 0.3 against 2.0 / 0.9.
#: On the 4x3 wall HiPO stopped after 26 iterations (23 s, "no progress") and IPX restarted from scratch.
INTERIOR_SOLVER = "ipx"


def _meets(bound: float, target: float) -> bool:
    """``root_lp="ipm"``: the dual ``bound`` closes the root at the incumbent's ``target`` (finite) within
    ``INTERIOR_CLOSE_TOL`` (times ``max(1, |target|)``); never without an incumbent."""
    return bool(np.isfinite(target) and target - bound <= INTERIOR_CLOSE_TOL * max(1.0, abs(target)))


def _checked(status) -> None:
    """A HiGHS model change that was not applied (e.g. repeated indices) must not go unnoticed."""
    if not change_applied(status):
        raise RuntimeError("HiGHS rejected a change of the lifted LP")


@dataclass
class _Layout:
    n: int
    lam: int
    x: slice
    u: slice
    z: slice
    copies: list  # per copy: (pair i, x-slice or None, zeta column)
    static_pair_rows: np.ndarray  # row of G_j x in the static block, per pair j
    copy_pair_rows: dict  # pair j -> rows of G_j x^(i) over copies
    zeta_lower_rows: np.ndarray  # rows zeta_i - a z_i >= 0, per copy
    zeta_upper_rows: np.ndarray  # rows zeta_i - b z_i <= 0, per copy
    own_rows: np.ndarray  # row of G_i x^(i) in copy i (always active: s_i z_i = 0)
    copy_x: dict  # pair i -> x-slice of its copy (friction pairs and, with all_copies, every pair)
    v: slice | None = None  # lam u (lam_mechanism)
    w: slice | None = None  # W[t, k] = x_{tied[t]} u_k (force_mechanism)
    tied: np.ndarray | None = None
    tied_rows: np.ndarray | None = None  # rows (X) of x_{tied[t]}: tied_rows[t] (compatibility times x_r, then f_l^T u)

    def lift(self, lam: float, x: np.ndarray, u: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The lifted point of ``(lam, x, u, z)``: every product column set to its product (a point of (3)
        in the normalisation ``f_l^T u = 1`` satisfies every row of the lifted LP; the tests check it)."""
        out = np.zeros(self.n)
        out[self.lam], out[self.x], out[self.u], out[self.z] = lam, x, u, z
        for i, xi, zeta in self.copies:
            if xi is not None:
                out[xi] = z[i] * x
            out[zeta] = z[i] * lam
        if self.v is not None:
            out[self.v] = lam * u
        if self.w is not None:
            out[self.w] = np.outer(x[self.tied], u).ravel()
        return out


def lifted_lp(form, B: sp.coo_array, lam_lower: float, lam_upper: float, slack_max: np.ndarray | None = None,
              all_copies: bool = False, lam_mechanism: bool = False, force_mechanism: bool = False,
              static_copies: str = "all"):
    """The lifted relaxation's matrices: (A, row_lower, row_upper, col_lower, col_upper, c, layout).

    ``all_copies``: a static copy ``x^(i)`` for every pair (not only the friction pairs of ``B``);
    ``lam_mechanism``: the products ``v = lam u`` and ``zeta_j = lam z_j`` for every pair (a bare
    ``zeta_j`` where pair ``j`` has no copy) with compatibility times ``lam`` and ``f_l^T u = 1``
    times ``lam`` (rows (M) of the module docstring); ``force_mechanism`` (needs both): the products
    ``W = x u^T`` with compatibility and ``f_l^T u = 1`` times each ``x_r`` (rows (X) of the module
    docstring).  ``static_copies="friction"``: the copies of the other pairs are bare products (columns of
    the rows (X) only, without their own statics).
    """
    if force_mechanism is not False and force_mechanism is not None and not (all_copies and lam_mechanism):
        raise ValueError("force_mechanism needs all_copies and lam_mechanism")
    nx = form.x.stop - form.x.start
    nu = form.u.stop - form.u.start
    npair = form.n_pairs
    E = form.block(form.equilibrium, form.x)
    f_l, f_d = form.f_l, form.f_d
    Gx = form.pair_matrix
    Ecomp = form.block(form.compatibility, form.u)
    F = form.block(form.compatibility, form.z)
    friction = set(int(i) for i in np.unique(B.col))
    # columns: lam | x | u | z | (x^(i), zeta_i) per copy | zeta_j per bare pair | v
    lam, xs = 0, slice(1, 1 + nx)
    us = slice(xs.stop, xs.stop + nu)
    zs = slice(us.stop, us.stop + npair)
    col = zs.stop
    copies = []
    for i in range(npair):
        if i in friction or all_copies:
            copies.append((i, slice(col, col + nx), col + nx))
            col += nx + 1
    if lam_mechanism:
        for i in range(npair):
            if not (i in friction or all_copies):
                copies.append((i, None, col))
                col += 1
        vs = slice(col, col + nu)
        col += nu
    tied = None
    if force_mechanism is not False and force_mechanism is not None:
        tied = np.arange(nx) if force_mechanism is True else np.asarray(force_mechanism, dtype=int)
        nt = tied.size
        ws = slice(col, col + nt * nu)  # W[t, k] = x_{tied[t]} u_k at ws.start + t * nu + k
        col += nt * nu
    n = col
    blocks, lo, hi = [], [], []
    count = [0]

    def add(M, lower, upper):
        M = sp.csr_array(M)
        blocks.append(M)
        lo.append(np.broadcast_to(np.asarray(lower, float), (M.shape[0],)))
        hi.append(np.broadcast_to(np.asarray(upper, float), (M.shape[0],)))
        count[0] += M.shape[0]
        return np.arange(count[0] - M.shape[0], count[0])

    def place(M, start):
        M = sp.coo_array(M)
        return sp.csr_array((M.data, (M.row, M.col + start)), shape=(M.shape[0], n))

    def column(vec, c):
        vec = np.asarray(vec, float)
        return sp.csr_array((vec, (np.arange(vec.size), np.full(vec.size, c))), shape=(vec.size, n))

    # static: E x + lam f_l = -f_d ; G x <= 0
    add(place(E, xs.start) + column(f_l, lam), -f_d, -f_d)
    static_pair_rows = add(place(Gx, xs.start), -np.inf, 0.0)
    # kinematic: E^T u + F z = 0 ; f_l^T u = 1
    add(place(Ecomp, us.start) + place(F, zs.start), 0.0, 0.0)
    add(place(f_l.reshape(1, -1), us.start), 1.0, 1.0)
    # copies
    copy_pair_rows = {j: [] for j in range(npair)}
    zeta_lower_rows, zeta_upper_rows, own_rows = [], [], []
    for i, xi, zeta in copies:
        if xi is not None and (static_copies == "all" or i in friction):
            add(place(E, xi.start) + column(f_l, zeta) + column(f_d, zs.start + i), 0.0, 0.0)
            rows = add(place(Gx, xi.start), -np.inf, 0.0)
            for j in range(npair):
                copy_pair_rows[j].append(rows[j])
            own_rows.append(rows[i])
            if slack_max is not None:
                # s_j z_i <= slack_max_j z_i:  -G x^(i) - slack_max z_i <= 0
                add(place(-Gx, xi.start) - column(slack_max, zs.start + i), -np.inf, 0.0)
        # lam_lower z_i <= zeta_i <= lam_upper z_i
        zeta_lower_rows.append(add(column([1.0], zeta) - column([lam_lower], zs.start + i), 0.0, np.inf)[0])
        zeta_upper_rows.append(add(column([1.0], zeta) - column([lam_upper], zs.start + i), -np.inf, 0.0)[0])
    copy_x = {i: xi for i, xi, _ in copies if xi is not None}
    if lam_mechanism:
        # lam (E^T u + F z) = 0:  E^T v + F zeta = 0 ;  lam f_l^T u = lam:  f_l^T v - lam = 0
        zeta_of = np.array([next(c[2] for c in copies if c[0] == j) for j in range(npair)])
        Fc = sp.coo_array(F)
        add(place(Ecomp, vs.start) + sp.csr_array((Fc.data, (Fc.row, zeta_of[Fc.col])), shape=(Fc.shape[0], n)),
            0.0, 0.0)
        add(place(f_l.reshape(1, -1), vs.start) - column([1.0], lam), 0.0, 0.0)
    if tied is not None:
        I_t = sp.identity(nt, format="csr")
        # x_r (E^T u + F z) = 0:  E^T W[r, :] + sum_i F[:, i] x^(i)_r = 0   (rows t * ncomp + q, r = tied[t])
        Fc = sp.coo_array(F)
        ncomp = Fc.shape[0]
        rr = (np.arange(nt)[:, None] * ncomp + Fc.row[None, :]).ravel()
        cc = (np.array([copy_x[int(i)].start for i in Fc.col])[None, :] + tied[:, None]).ravel()
        vv = np.broadcast_to(Fc.data[None, :], (nt, Fc.nnz)).ravel()
        compat_rows = add(place(sp.kron(I_t, Ecomp), ws.start) + sp.csr_array((vv, (rr, cc)), shape=(nt * ncomp, n)),
                          0.0, 0.0)
        # x_r (f_l^T u - 1) = 0:  f_l^T W[r, :] - x_r = 0
        pick = sp.csr_array((np.ones(nt), (np.arange(nt), tied)), shape=(nt, nx))
        norm_rows = add(place(sp.kron(I_t, f_l.reshape(1, -1)), ws.start) - place(pick, xs.start), 0.0, 0.0)
        tied_rows = np.hstack([compat_rows.reshape(nt, ncomp), norm_rows[:, None]])
    # work identity: lam + f_d^T u - sum_e B_e x^(i_e)_{r_e} = 0
    identity = column([1.0], lam) - place(-f_d.reshape(1, -1), us.start)
    for e in range(B.nnz):
        i, r = int(B.col[e]), int(B.row[e])
        identity = identity - sp.csr_array(([B.data[e]], ([0], [copy_x[i].start + r])), shape=(1, n))
    add(identity, 0.0, 0.0)
    A = sp.csr_array(sp.vstack(blocks, format="csr"))
    A.sum_duplicates()
    col_lower = np.full(n, -np.inf)
    col_upper = np.full(n, np.inf)
    col_lower[zs] = 0.0
    col_lower[lam], col_upper[lam] = lam_lower, lam_upper
    c = np.zeros(n)
    c[lam] = 1.0
    layout = _Layout(n, lam, xs, us, zs, copies, static_pair_rows,
                     {j: np.array(r, dtype=int) for j, r in copy_pair_rows.items()}, np.array(zeta_lower_rows),
                     np.array(zeta_upper_rows), np.array(own_rows, dtype=int), copy_x,
                     vs if lam_mechanism else None, ws if tied is not None else None, tied,
                     tied_rows if tied is not None else None)
    return A, np.concatenate(lo), np.concatenate(hi), col_lower, col_upper, c, layout


def _sign_cleaned(A, c, row_lower, row_upper, col_lower, col_upper, y) -> tuple:
    """``(y, d, open)``: the row duals with every entry of the wrong sign for its row set to 0 (a one-sided row's,
    a free row's), the reduced costs ``d = c - A^T y`` and the columns whose ``d`` points at an open bound (a
    positive ``d`` on a column without lower bound, a negative one without upper bound)."""
    lower_open, upper_open = ~np.isfinite(row_lower), ~np.isfinite(row_upper)
    y = np.array(y, dtype=float)
    y[lower_open & (y > 0)] = 0.0
    y[upper_open & (y < 0)] = 0.0
    y[lower_open & upper_open] = 0.0
    d = c - A.T @ y
    unbounded = ((d > 0) & ~np.isfinite(col_lower)) | ((d < 0) & ~np.isfinite(col_upper))
    return y, d, unbounded


def open_reduced_cost(A, c, row_lower, row_upper, col_lower, col_upper, y) -> float:
    """The largest reduced cost towards an open column bound left by the row duals ``y`` (signs cleaned as in
    :func:`dual_bound`): above ``LP_TOL`` the uncorrected dual bound is ``-inf``."""
    _, d, unbounded = _sign_cleaned(sp.csc_array(A), c, row_lower, row_upper, col_lower, col_upper, y)
    return float(np.abs(d[unbounded]).max(initial=0.0))


def dual_bound(A, c, row_lower, row_upper, col_lower, col_upper, y, tol: float = LP_TOL,
               correct: bool = True) -> float:
    r"""A lower bound on ``min c^T w`` s.t. ``row_lower <= A w <= row_upper``, ``col_lower <= w <= col_upper``
    from row duals ``y`` (any ``y``; weak duality).

    With ``d = c - A^T y``, for every feasible ``w``: ``c^T w = y^T (A w) + d^T w >=
    sum_r min_{t in [l_r, u_r]} y_r t + sum_j min_{w_j in [cl_j, cu_j]} d_j w_j``.  ``y_r`` of the wrong
    sign for a one-sided row is set to 0 first (its term would be ``-inf``).  The interior point's ``y``
    leaves small reduced costs ``d_j`` on the free columns (about 1e-9); ``correct``: where they give
    ``-inf``, a least-squares correction of ``y`` on the equality rows and the inequality rows with
    ``|y_r| > DORMANT_DUAL_TOL`` is tried (kept only if its bound is larger).  A reduced cost at most ``tol`` in size on an unbounded side counts
    as zero, the dual feasibility tolerance under which every simplex LP of this engine is accepted
    as optimal (so this bound is held to the standard of the simplex bounds, not beyond);
    a larger one gives ``-inf``.
    """
    A = sp.csc_array(A)
    lower_open, upper_open = ~np.isfinite(row_lower), ~np.isfinite(row_upper)
    col_lower_open, col_upper_open = ~np.isfinite(col_lower), ~np.isfinite(col_upper)

    def value(y):
        y, d, unbounded = _sign_cleaned(A, c, row_lower, row_upper, col_lower, col_upper, y)
        if np.abs(d[unbounded]).max(initial=0.0) > tol:
            return -np.inf, y, d
        with np.errstate(invalid="ignore"):
            rows = np.where(y > 0, y * np.where(lower_open, 0.0, row_lower),
                            np.where(y < 0, y * np.where(upper_open, 0.0, row_upper), 0.0))
            cols = np.where(unbounded, 0.0, np.where(d > 0, d * np.where(col_lower_open, 0.0, col_lower),
                                                     np.where(d < 0, d * np.where(col_upper_open, 0.0, col_upper),
                                                              0.0)))
        return float(rows.sum() + cols.sum()), y, d

    best, y, d = value(np.asarray(y, float))
    if correct and best == -np.inf:  # (measured: where the plain bound was finite, the correction moved it by 3e-9)
        from scipy.sparse.linalg import lsqr

        # columns whose reduced cost should vanish: the free ones and every one with a small reduced cost (lam's
        # among them: its small d times its bounds was measured to cost 4e-7 of the bound on the 4x3 wall)
        cols = (col_lower_open & col_upper_open) | (np.abs(d) <= 1e-5)
        rows = ~(lower_open | upper_open) | ((lower_open ^ upper_open) & (np.abs(y) > DORMANT_DUAL_TOL))
        M = sp.csr_array(A[:, cols])[rows].T
        y2 = y.copy()
        y2[rows] += lsqr(M, d[cols], atol=1e-16, btol=1e-16, iter_lim=200)[0]
        best = max(best, value(y2)[0])
    return best


def proves_infeasible(A, row_lower, row_upper, col_lower, col_upper, ray) -> bool:
    r"""Whether ``ray`` (row multipliers, either sign) proves ``row_lower <= A w <= row_upper``,
    ``col_lower <= w <= col_upper`` infeasible (Farkas).

    For every feasible ``w`` and any ``y``: ``0 = y^T A w - (A^T y)^T w >= sum_r min_{[l_r, u_r]} y_r t +
    sum_j min_{[cl_j, cu_j]} (-A^T y)_j w_j``, the dual bound of the zero objective (:func:`dual_bound` with
    ``c = 0``); a positive value is a contradiction.  ``y`` is scaled to ``max |y_r| = 1`` and the value must
    exceed ``FARKAS_MARGIN`` times the size of its terms, so round-off cannot make a proof.  Reduced costs of at
    most ``LP_TOL`` on an unbounded side count as zero, as in every bound of this engine."""
    ray = np.asarray(ray, float)
    size = np.abs(ray).max(initial=0.0)
    if not np.isfinite(size) or size == 0.0:
        return False
    A = sp.csc_array(A)
    zero = np.zeros(A.shape[1])
    for y in (ray / size, -ray / size):
        value = dual_bound(A, zero, row_lower, row_upper, col_lower, col_upper, y, correct=False)
        if not np.isfinite(value):
            continue
        y_clean, d, _ = _sign_cleaned(A, zero, row_lower, row_upper, col_lower, col_upper, y)
        bounds = np.where(np.isfinite(row_lower), np.abs(row_lower), 0.0) + np.where(np.isfinite(row_upper),
                                                                                     np.abs(row_upper), 0.0)
        cols = np.where(np.isfinite(col_lower), np.abs(col_lower), 0.0) + np.where(np.isfinite(col_upper),
                                                                                  np.abs(col_upper), 0.0)
        scale = float(np.abs(y_clean) @ bounds + np.abs(d) @ cols) + 1.0
        if value > FARKAS_MARGIN * scale:
            return True
    return False


class NullSpaceNodes:
    r"""The node LPs of the branch and bound in the null-space coordinates of
    :mod:`~blockmpec.solvers.linalg.null_space`, behind the HiGHS calls the search makes on the lifted LP.

    The search changes only bounds of pair rows (static and copy), of the ``zeta`` rows and their ``z``
    coefficients, and bounds of ``lam`` and ``z``; each is a row or column of the null-space LP too: a lifted row
    ``r`` kept there is ``A_r T xi``, with its bounds shifted by ``A_r offset`` (the dead-load tree solution), and
    ``lam``, ``z_i``, ``zeta_i`` are columns of both (``T`` is the identity there, so a ``zeta`` row's ``z``
    coefficient is the same number).  The two LPs have the same points (``w = offset + T xi``) and the same
    minimum at every node, so every bound and point of the search is unchanged.

    Two HiGHS instances take every change: ``full``, the whole LP (for the interior point: 0.5-0.6 s a node LP of
    the 9-block door wall with every row, 1-3 s without the dormant rows and their separation rounds), and
    ``sparse``, the LP without the rows that are free or ``sleeping`` (the dormant rows of the root; a sleeping row
    is appended once it is set to an equality, an active pair's row, and stays): a relaxation, for the dual simplex,
    whose Farkas proofs of infeasibility hold for the whole LP (the door wall at mu 0.8: 5,479 rows, 3,152 of them
    sleeping).  ``use("full" | "sparse")`` picks the instance that runs, answers and gives points (in lifted
    coordinates); every model change goes to both.
    """

    def __init__(self, reduced, A_lifted, layout, n_pairs: int, row_lower, row_upper, sleeping=None):
        self.T, self.offset = sp.csr_array(reduced.T), np.asarray(reduced.offset, float)
        n_rows = A_lifted.shape[0]
        self.row = np.full(n_rows, -1, dtype=np.int64)  # lifted row -> row of the null-space LP
        mapped = np.flatnonzero(reduced.lifted_row >= 0)
        self.row[reduced.lifted_row[mapped]] = mapped
        self.shift = np.asarray(A_lifted @ self.offset, float)
        self.M = sp.csr_array(reduced.A)
        n_reduced = self.M.shape[1]
        q = (n_reduced - 1 - 2 * n_pairs) // (n_pairs + 1)
        self.col = np.full(A_lifted.shape[1], -1, dtype=np.int64)  # lifted column -> column (lam, z, zeta)
        self.col[layout.lam] = 0
        self.col[layout.z.start:layout.z.stop] = 1 + q + np.arange(n_pairs)
        for i, _, zeta in layout.copies:
            self.col[zeta] = 1 + q + n_pairs + i
        # the null-space LP's rows with the lifted LP's current bounds
        lower, upper = np.array(reduced.row_lower, float), np.array(reduced.row_upper, float)
        lifted = reduced.lifted_row[mapped]
        lower[mapped] = np.asarray(row_lower, float)[lifted] - self.shift[lifted]
        upper[mapped] = np.asarray(row_upper, float)[lifted] - self.shift[lifted]
        self.sleeping = np.zeros(self.M.shape[0], dtype=bool)  # rows the sparse LP leaves out until an equality
        if sleeping is not None:
            self.sleeping[self.row[np.asarray(sleeping, dtype=np.int64)]] = True
        held = (np.isfinite(lower) | np.isfinite(upper)) & ~self.sleeping
        self.position = np.full(self.M.shape[0], -1, dtype=np.int64)  # null-space row -> sparse LP row (-1: out)
        self.position[held] = np.arange(int(held.sum()))
        self.full = new_highs()
        self.full.passModel(highs_lp(self.M, reduced.c, lower, upper, reduced.col_lower, reduced.col_upper))
        self.sparse = new_highs()
        self.sparse.passModel(highs_lp(self.M[np.flatnonzero(held)], reduced.c, lower[held], upper[held],
                                       reduced.col_lower, reduced.col_upper))
        self.h = self.full

    @classmethod
    def of(cls, reduced, A_lifted, layout, n_pairs: int, rows_used: np.ndarray, row_lower, row_upper,
           sleeping=None):
        """The node LPs, or None when a row the search changes (``rows_used``) is not a row of the null-space LP
        (it vanished: its value is a constant there)."""
        row = np.full(A_lifted.shape[0], -1, dtype=np.int64)
        row[reduced.lifted_row[reduced.lifted_row >= 0]] = 1
        if np.any(row[rows_used] < 0):
            return None
        return cls(reduced, A_lifted, layout, n_pairs, row_lower, row_upper, sleeping)

    def use(self, which: str) -> None:
        """Run, answer and give points from the ``"full"`` or the ``"sparse"`` LP."""
        self.h = self.full if which == "full" else self.sparse

    @property
    def n_rows(self) -> int:
        """Rows of the sparse LP now."""
        return int((self.position >= 0).sum())

    def _null_rows(self, rows) -> np.ndarray:
        r = self.row[np.asarray(rows, dtype=np.int64)]
        if np.any(r < 0):
            raise RuntimeError("null-space node LP: a changed row is not in the LP")
        return r

    def _cols(self, cols) -> np.ndarray:
        c = self.col[np.asarray(cols, dtype=np.int64)]
        if np.any(c < 0):
            raise RuntimeError("null-space node LP: a changed column is not in the LP")
        return c

    def changeRowsBounds(self, n, rows, lower, upper):  # noqa: N802 (HiGHS's name)
        rows = np.asarray(rows, dtype=np.int64)
        nr = self._null_rows(rows)
        lower = np.asarray(lower, float) - self.shift[rows]
        upper = np.asarray(upper, float) - self.shift[rows]
        status = self.full.changeRowsBounds(int(nr.size), nr.astype(np.int32), lower, upper)
        if not change_applied(status):
            return status
        at = self.position[nr]
        held = at >= 0
        status = self.sparse.changeRowsBounds(int(held.sum()), at[held].astype(np.int32), lower[held], upper[held])
        if not change_applied(status):
            return status
        # a row outside the sparse LP is appended once its bounds are set (a sleeping one: to an equality)
        add = ~held & (np.isfinite(lower) | np.isfinite(upper)) & (~self.sleeping[nr] | (lower == upper))
        if add.any():
            new, first = nr[add], self.n_rows
            sub = self.M[new]
            status = self.sparse.addRows(int(new.size), lower[add], upper[add], int(sub.nnz),
                                         sub.indptr[:-1].astype(np.int32), sub.indices.astype(np.int32), sub.data)
            self.position[new] = first + np.arange(new.size)
        return status

    def changeColBounds(self, col, lower, upper):  # noqa: N802
        c = int(self._cols([col])[0])
        status = self.full.changeColBounds(c, float(lower), float(upper))
        return self.sparse.changeColBounds(c, float(lower), float(upper)) if change_applied(status) else status

    def changeColsBounds(self, n, cols, lower, upper):  # noqa: N802
        c = self._cols(cols).astype(np.int32)
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        status = self.full.changeColsBounds(int(n), c, lower, upper)
        return self.sparse.changeColsBounds(int(n), c, lower, upper) if change_applied(status) else status

    def changeCoeff(self, row, col, value):  # noqa: N802
        nr = int(self._null_rows([row])[0])
        c = int(self._cols([col])[0])
        self.M[nr, c] = float(value)  # the z coefficient of a zeta row, for when the row is appended
        status = self.full.changeCoeff(nr, c, float(value))
        if not change_applied(status) or self.position[nr] < 0:
            return status
        return self.sparse.changeCoeff(int(self.position[nr]), c, float(value))

    def lift(self, xi: np.ndarray) -> np.ndarray:
        """The lifted point ``offset + T xi`` of a point ``xi`` of the null-space LP."""
        return self.offset + self.T @ np.asarray(xi, float)

    def getSolution(self):  # noqa: N802
        """HiGHS's solution with ``col_value`` in the lifted coordinates (``offset + T xi``)."""
        from types import SimpleNamespace

        sol = self.h.getSolution()
        return SimpleNamespace(col_value=self.lift(sol.col_value), value_valid=sol.value_valid,
                               dual_valid=sol.dual_valid)

    def getLp(self):  # noqa: N802
        raise AttributeError("the null-space node LPs have no lifted LP to return")

    def __getattr__(self, name):
        return getattr(self.h, name)


class ComplementarityBnB:
    """Best-bound branch and bound over the pairs (and, ``lam_branching``, over ``lam``); see the
    module docstring.

    ``polish(active) -> Solution | None`` gives the exact point (and leaf value) of a pattern.
    """

    def __init__(self, form, B, lam_lower, lam_upper, polish, fixed_active=None, fixed_idle=None, strong=4,
                 slack_max=None, lam_branching=False, all_copies=False, lam_mechanism=False, force_mechanism=False,
                 own_pair_active=True, static_copies="all", root_lp="simplex", null_space_nodes=True,
                 node_lp="interior"):
        if root_lp not in ROOT_LPS:
            raise ValueError(f"root_lp must be one of {ROOT_LPS}; got {root_lp!r}")

        A, rl, ru, cl, cu, c, layout = lifted_lp(form, B, lam_lower, lam_upper, slack_max, all_copies=all_copies,
                                                 lam_mechanism=lam_mechanism, force_mechanism=force_mechanism,
                                                 static_copies=static_copies)
        self.form, self.B, self.layout, self.polish = form, B, layout, polish
        self.rl0, self.ru0, self.cl0, self.cu0 = rl, ru, cl, cu
        h = new_highs()
        self.deadline: Deadline = NEVER
        h.passModel(highs_lp(A, c, rl, ru, cl, cu))
        self.h = h
        self.root_lp = root_lp
        self.static_copies = static_copies
        #: the root LP was solved in null-space coordinates (root_lp="ipm" with the rlt-full lifting)
        self.null_space_root = False
        #: with the root in null-space coordinates, solve the node LPs there too (:class:`NullSpaceNodes`)
        self.null_space_nodes = bool(null_space_nodes)
        self.nodes_in_null_space = False
        #: node LPs in null-space coordinates: "interior" (HiGHS's interior point first, the dual simplex for what
        #: it leaves open) or "simplex" (the dual simplex from the parent's basis first)
        self.node_lp = node_lp
        npair = form.n_pairs
        # candidates for dormancy: the copy pair rows G_j x^(i) <= 0 with j != i
        own = np.zeros(A.shape[0], dtype=bool)
        own[layout.own_rows] = True
        rows = np.concatenate([layout.copy_pair_rows[j] for j in range(npair)]) if npair else np.zeros(0, int)
        #: the rows that may be made dormant (left out of the node LPs until a point violates them): the copy pair
        #: rows ``G_j x^(i) <= 0`` with ``j != i``, sorted lifted row indices
        self.dormant_candidates = np.sort(rows[~own[rows]]).astype(np.int32)
        #: the lifted LP's constraint matrix ``A`` (CSC; its rows and columns as in :func:`lifted_lp`)
        self.lifted_matrix = sp.csc_array(A)
        self._sleep_matrix = sp.csr_array(A)[self.dormant_candidates]
        self.dormant = np.zeros(A.shape[0], dtype=bool)
        #: the dormant rows are free in the node LPs (False: node_lp="interior" in null-space coordinates, where
        #: they sleep only in the dual simplex's sparse LP)
        self.dormant_free = True
        # rows (X) of the forces other than normal and tangential ones (the moments, lifting="rlt-full"): left out
        # of the root's first interior point (see interior_root)
        late = np.zeros(A.shape[0], dtype=bool)
        if layout.tied is not None:
            nt_forces = np.isin(layout.tied, np.r_[form.n, form.t])
            late[layout.tied_rows[~nt_forces].ravel()] = True
        self._late_rows = late
        self.woken = 0
        self.ipm_time = 0.0
        self.ipm_bound = None
        self.crossover_runs = 0  # interior points re-run with crossover (_interior_bound)
        #: seconds from the start of the root LP (:meth:`interior_root`, :meth:`generated_root`) to the end of each
        #: stage that ran: ``"null_space_build"`` (the LP in null-space coordinates built), ``"ipm0"`` (the run
        #: without the moments' rows), ``"ipm1"`` (the run on the whole LP), ``"ipm"`` (the root LP done)
        self.root_timing = {}
        self.root = np.zeros(npair, dtype=np.int8)  # 0 free, 1 active, -1 inactive
        if fixed_active is not None:
            self.root[fixed_active] = 1
        if fixed_idle is not None:
            self.root[fixed_idle & (self.root == 0)] = -1
        self.n_lps = 0
        self.interior_nodes = 0  # node LPs bounded by the interior point (_interior_node)
        self.iteration_limit = max(NODE_LP_ITERATIONS, sum(A.shape))
        self.last_basis = None
        self.strong = max(1, int(strong))
        self.root_strong = max(self.strong, ROOT_STRONG)
        self.fixings = 0  # pairs fixed in a node by strong branching
        self.farkas_proofs = 0  # node LPs pruned as infeasible on a checked Farkas certificate
        self.unproven_closures = 0  # leaves closed because their pattern LP had no point (HiGHS's word)
        self.lam_lower, self.lam_cap = float(lam_lower), float(lam_upper)
        self.lam_upper = float(lam_upper)
        self.lam_branching = bool(lam_branching)
        self.own_pair_active = bool(own_pair_active)
        self._interval = (float(lam_lower), float(lam_upper))  # the (a, b) now in the LP's zeta rows
        self.lam_splits = 0
        # the x-slices of the copies, by pair (for the work defect of _candidates)
        self._work_copy = np.array([layout.copy_x[int(i)].start + int(r) for i, r in zip(B.col, B.row)], dtype=int)

    def _changed_rows(self) -> np.ndarray:
        """The lifted rows whose bounds or coefficients the search changes (pair rows, ``zeta`` rows)."""
        lay = self.layout
        parts = [lay.static_pair_rows, lay.zeta_lower_rows, lay.zeta_upper_rows, lay.own_rows, self.dormant_candidates]
        parts += [lay.copy_pair_rows[j] for j in range(self.form.n_pairs)]
        return np.concatenate([np.asarray(p, dtype=np.int64).ravel() for p in parts])

    def _set_interval(self, a: float, b: float) -> None:
        """``a <= lam <= b`` and ``a z_i <= zeta_i <= b z_i`` in every copy (coefficients changed in place)."""
        lay, h = self.layout, self.h
        _checked(h.changeColBounds(lay.lam, a, b))
        if (a, b) == self._interval:
            return
        pa, pb = self._interval
        for (i, _, _), lo_row, hi_row in zip(lay.copies, lay.zeta_lower_rows, lay.zeta_upper_rows):
            if a != pa:
                _checked(h.changeCoeff(int(lo_row), int(lay.z.start + i), -a))
            if b != pb:
                _checked(h.changeCoeff(int(hi_row), int(lay.z.start + i), -b))
        self._interval = (a, b)

    def apply_node(self, state: np.ndarray, a: float, b: float) -> None:
        """Set the LP HiGHS holds to the node LP of the pattern ``state`` over ``a <= lam <= b``.

        Every pair row (static and copies) gets ``-inf <= G_i x <= 0`` (``+inf`` above for a dormant row while
        dormant rows are free); the rows of the active pairs (``state_i = 1``) and, with ``own_pair_active``,
        every copy's own pair row get ``G_i x = 0``; ``z_i = 0`` for the idle pairs (``state_i = -1``), else
        ``0 <= z_i``; and ``a <= lam <= min(b, lam_cap)`` with ``a z_i <= zeta_i <= b z_i`` in every copy.

        Parameters
        ----------
        state : ndarray of int8, shape (n_pairs,)
            ``1`` active, ``-1`` idle, ``0`` free.
        a, b : float
            The node's interval of ``lam``.
        """
        lay, h = self.layout, self.h
        rows = np.concatenate([lay.static_pair_rows] + [lay.copy_pair_rows[j] for j in range(state.size)])
        active_rows = [lay.static_pair_rows[state == 1]] + [lay.copy_pair_rows[j] for j in np.flatnonzero(state == 1)]
        if self.own_pair_active:
            active_rows.append(lay.own_rows)
        active_rows = np.unique(np.concatenate(active_rows))  # HiGHS ignores a set with repeated indices
        lower = np.full(rows.size, -np.inf)
        # a dormant row is free (dropped: a relaxation), unless the node LPs hold every row (dormant_free False)
        upper = np.where(self.dormant[rows] & self.dormant_free, np.inf, 0.0)
        _checked(h.changeRowsBounds(rows.size, rows.astype(np.int32), lower, upper))
        if active_rows.size:
            _checked(h.changeRowsBounds(active_rows.size, active_rows.astype(np.int32), np.zeros(active_rows.size),
                                        np.zeros(active_rows.size)))
        zc = np.arange(lay.z.start, lay.z.stop, dtype=np.int32)
        _checked(h.changeColsBounds(zc.size, zc, np.zeros(zc.size), np.where(state == -1, 0.0, np.inf)))
        self._set_interval(a, min(b, self.lam_cap))

    def solve_node(self, state: np.ndarray, a: float, b: float):
        """``(status, bound, point)`` of the node LP of the pattern ``state`` over ``a <= lam <= b``
        (:meth:`apply_node`): ``bound`` is the LP's minimum of ``lam``, a lower bound on ``lam`` over every solution
        of (3) with that pattern in that interval; ``point`` its lifted point (None unless ``OPTIMAL``).

        The dual simplex from the last basis (:meth:`_run`).  An infeasible LP is pruned only on a proof: HiGHS's
        dual ray checked as a Farkas certificate (:func:`proves_infeasible`), else a cold re-solve that says
        infeasible again.  A solve that ends otherwise (its iteration limit: the degenerate lifted LPs were seen
        to cycle, 338k iterations in 144 s on the 9-block door wall) is repaired by a cold re-solve, then by the
        interior point (:meth:`_interior_node`, a valid dual bound without a basis); failing both the status is
        returned and the node keeps its parent's bound."""
        if a > min(b, self.lam_cap):
            return Status.INFEASIBLE, None, None
        self.apply_node(state, a, b)
        if self.node_lp == "interior" and self.nodes_in_null_space:
            return self._interior_node_lp(a, b)
        st = self._run()
        if st is Status.INFEASIBLE and self._infeasibility_proven():
            return Status.INFEASIBLE, None, None
        if st is not Status.OPTIMAL and st is not Status.TIME_LIMIT and st is not Status.INFEASIBLE:
            # the interior point with its crossover: a bound and a basis to go on from
            ist, ibound, iv = self._interior_node(crossover=True)
            if ist is Status.OPTIMAL:
                return ist, ibound, iv
        if st is not Status.OPTIMAL and st is not Status.TIME_LIMIT:
            # confirmed (or repaired) by a cold re-solve: warm re-solves after coefficient changes were
            # seen to end without an optimal status on LPs that are optimal cold
            self.h.clearSolver()
            st = self._run()
            if st is Status.INFEASIBLE and not self._infeasibility_proven():
                st = Status.ERROR  # not pruned: the node keeps its parent's bound
        if st is not Status.OPTIMAL:
            return st, None, None
        v = np.asarray(self.h.getSolution().col_value, float)
        value, basis = float(self.h.getInfo().objective_function_value), self.h.getBasis()
        for _ in range(SEPARATION_ROUNDS if self.dormant_free and self.dormant.any() else 0):
            if not self._wake(v):
                break
            if self._run() is not Status.OPTIMAL:
                break  # the last optimal LP (fewer rows: a relaxation of this one) gives the bound
            v = np.asarray(self.h.getSolution().col_value, float)
            value, basis = float(self.h.getInfo().objective_function_value), self.h.getBasis()
        self.last_basis = basis
        return Status.OPTIMAL, value, v

    def _interior_node_lp(self, a: float, b: float):
        """``node_lp="interior"``: (status, bound, point) of the node LP (its bounds applied) by the interior point.

        An infeasible LP gives the interior point no bound; then the same LP without the cap ``lam <= incumbent``
        (a relaxation) is solved, whose bound prunes the node if it reaches the cap; failing that the dual simplex
        from the last basis, within its iteration limit, prunes it on a Farkas proof
        (:meth:`_infeasibility_proven`).  Otherwise the node keeps its parent's bound (``ERROR``)."""
        st, bound, v = self._interior_node()
        if st is Status.OPTIMAL or st is Status.TIME_LIMIT:
            return st, bound, v
        cap = min(b, self.lam_cap)
        if cap < min(b, self.lam_upper):
            self._set_interval(a, min(b, self.lam_upper))
            ust, ubound, uv = self._interior_node()
            self._set_interval(a, cap)
            if ust is Status.OPTIMAL and ubound >= cap - PRUNE_TOL * max(1.0, abs(cap)):
                return ust, ubound, uv
        self.h.use("sparse")
        try:
            st = self._run()
            if st is Status.INFEASIBLE:
                return (Status.INFEASIBLE, None, None) if self._infeasibility_proven() else (Status.ERROR, None, None)
            if st is Status.OPTIMAL:  # the sparse LP is a relaxation: its minimum bounds the node's
                v = np.asarray(self.h.getSolution().col_value, float)
                return st, float(self.h.getInfo().objective_function_value), v
            return st, None, None
        finally:
            self.h.use("full")

    def _node_arrays(self) -> tuple:
        """``(A, c, row_lower, row_upper, col_lower, col_upper)`` of the node LP HiGHS holds now (in null-space
        coordinates when the nodes are solved there) and the map of its points to lifted ones."""
        h = self.h.h if isinstance(self.h, NullSpaceNodes) else self.h
        lp = h.getLp()
        a = lp.a_matrix_
        A = sp.csc_array((np.asarray(a.value_), np.asarray(a.index_), np.asarray(a.start_)),
                         shape=(lp.num_row_, lp.num_col_))
        lift = self.h.lift if isinstance(self.h, NullSpaceNodes) else (lambda xi: xi)
        return (A, np.asarray(lp.col_cost_), np.asarray(lp.row_lower_), np.asarray(lp.row_upper_),
                np.asarray(lp.col_lower_), np.asarray(lp.col_upper_)), lift

    def _infeasibility_proven(self) -> bool:
        """HiGHS's dual ray of the infeasible node LP is a Farkas certificate (:func:`proves_infeasible`)."""
        h = self.h.h if isinstance(self.h, NullSpaceNodes) else self.h
        try:
            _, has_ray, ray = h.getDualRay()
        except Exception:  # noqa: BLE001 - no ray: the cold re-solve decides
            return False
        if not has_ray:
            return False
        arrays, _ = self._node_arrays()
        A, _, rl, ru, cl, cu = arrays
        proven = proves_infeasible(A, rl, ru, cl, cu, np.asarray(ray, float))
        self.farkas_proofs += int(proven)
        return proven

    def _interior_node(self, crossover: bool = False):
        """The node LP by HiGHS's interior point (with its crossover if ``crossover``): ``(OPTIMAL, dual bound,
        lifted point)`` when its duals give a finite bound (:func:`dual_bound`: valid whatever the point), else
        ``(ERROR, None, None)``.  A crossover's basis becomes the node LP's (the children start from it)."""
        if self.deadline.expired():
            return Status.TIME_LIMIT, None, None
        (A, c, rl, ru, cl, cu), lift = self._node_arrays()
        self.interior_nodes += 1
        tolerance = NULL_SPACE_IPM_TOL if self.nodes_in_null_space else None
        y, xi, basis = self.interior_solution(A, c, rl, ru, cl, cu, crossover=crossover, tolerance=tolerance,
                                               basis=True)
        bound = -np.inf if y is None or xi is None else dual_bound(A, c, rl, ru, cl, cu, y)
        if not np.isfinite(bound) and not crossover and y is not None and not self.deadline.expired():
            # an interior point that stopped short (reduced costs left on free columns, as at the root: see
            # _interior_bound) is repaired by its crossover; an infeasible LP gives no duals and is left to the caller
            self.crossover_runs += 1
            y, xi, basis = self.interior_solution(A, c, rl, ru, cl, cu, crossover=True, tolerance=tolerance,
                                                   basis=True)
            bound = -np.inf if y is None or xi is None else dual_bound(A, c, rl, ru, cl, cu, y)
        if not np.isfinite(bound):
            return Status.ERROR, None, None
        if basis is not None and basis.valid:
            self.h.setBasis(basis)
            self.last_basis = basis
        return Status.OPTIMAL, float(bound), lift(np.asarray(xi, float))

    def _wake(self, v: np.ndarray) -> bool:
        """Wake the dormant rows violated at ``v`` (bound ``<= 0`` again); True if any."""
        rows = self.dormant_candidates
        bad = self.dormant[rows] & (self._sleep_matrix @ v > SEPARATION_TOL)
        if not bad.any():
            return False
        wake = rows[bad]
        self.dormant[wake] = False
        self.woken += int(wake.size)
        _checked(self.h.changeRowsBounds(wake.size, wake, np.full(wake.size, -np.inf), np.zeros(wake.size)))
        return True

    def lp_arrays(self) -> tuple:
        """The lifted LP's cost and bounds as HiGHS holds it now (the node's bounds applied, dormant rows free).

        Returns
        -------
        tuple of ndarray
            ``(c, row_lower, row_upper, col_lower, col_upper)``; the LP is ``min c^T v`` subject to
            ``row_lower <= A v <= row_upper``, ``col_lower <= v <= col_upper`` with ``A`` :attr:`lifted_matrix`.
        """
        lp = self.h.getLp()
        return (np.asarray(lp.col_cost_), np.asarray(lp.row_lower_), np.asarray(lp.row_upper_),
                np.asarray(lp.col_lower_), np.asarray(lp.col_upper_))

    def interior_root(self, target: float = np.inf, record=None) -> float:
        """A lower bound on ``lam`` at the root: ``root_lp="ipm"``, the root LP (its bounds already applied by
        :meth:`apply_node`) by HiGHS's interior point without
        crossover, at most three times.  With the moments' products in the LP (``lifting="rlt-full"``) and an
        incumbent (``target`` finite), a run without their rows (X) comes first (a relaxation: the LP of
        ``lifting="rlt"``), and closes the root if its dual bound meets ``target`` within ``INTERIOR_CLOSE_TOL``
        (3x4 wall: the LP with the moments did not finish in 60 s, the one without certified it in 14 s).
        Then the first run on the whole LP picks the dormant rows: the candidate rows whose dual
        is zero within ``DORMANT_DUAL_TOL`` (only a choice: any choice keeps the bound valid; an interior
        point that fails or runs out of time leaves every row in place).  When its dual bound
        (:func:`dual_bound`) is already within ``INTERIOR_CLOSE_TOL`` of ``target`` (the incumbent) the root
        is closed and nothing else runs.  Otherwise the second run, on the LP without the dormant rows (a
        relaxation: smaller, and measured to converge closer), may still close it.  A run that gives no finite
        bound is repeated once with crossover (:meth:`_interior_bound`).  Returns the larger of
        their dual bounds (``-inf`` if none); ``record(bound)`` (if given) is called with the bound so far after
        each run that gave one (the trace: a time-out after the first run still shows its bound)."""
        t0 = time.perf_counter()
        c, rl, ru, cl, cu = self.lp_arrays()
        A = self.lifted_matrix
        late = self._late_rows
        to_lifted = None  # the lifted row of each row of the LP solved (None: the lifted LP itself)
        reduced = self.null_space_root_lp(c, rl, ru, cl, cu) if self.root_lp == "ipm" else None
        if reduced is not None:
            # the same LP in null-space coordinates (its rows (X) hold every moment's product already)
            A, c, rl, ru, cl, cu = reduced.arrays
            late = np.zeros(A.shape[0], dtype=bool)
            to_lifted = reduced.lifted_row
            self.null_space_root = True
            self.root_timing["null_space_build"] = time.perf_counter() - t0

        tolerance = NULL_SPACE_IPM_TOL if reduced is not None else None

        def bound_without(drop: np.ndarray) -> float:
            """The dual bound of one interior point on the LP without the rows ``drop`` (a relaxation)."""
            keep = ~drop
            Ar = sp.csc_array(sp.csr_array(A)[keep])
            return self._interior_bound(Ar, c, rl[keep], ru[keep], cl, cu, tolerance)[0]

        def note(value: float) -> None:
            if record is not None and np.isfinite(value):
                record(value)

        bound = -np.inf
        if late.any() and np.isfinite(target):
            # first without the moments' products (rows (X) of the moments: a relaxation, the LP of lifting="rlt"),
            # which closes most walls at a fraction of the cost
            bound = bound_without(late)
            self.root_timing["ipm0"] = time.perf_counter() - t0
            note(bound)
        if not _meets(bound, target):
            full, y = self._interior_bound(A, c, rl, ru, cl, cu, tolerance)
            if y is not None:
                bound = max(bound, full)
                self.root_timing["ipm1"] = time.perf_counter() - t0
                note(bound)
                rows = self.dormant_candidates
                y_lifted = y
                if to_lifted is not None:  # the pair rows are rows of both LPs, one to one
                    y_lifted = np.zeros(self.lifted_matrix.shape[0])
                    y_lifted[to_lifted[to_lifted >= 0]] = y[to_lifted >= 0]
                sleep = rows[np.abs(y_lifted[rows]) <= DORMANT_DUAL_TOL]
                self.dormant[sleep] = True
                _checked(self.h.changeRowsBounds(sleep.size, sleep, np.full(sleep.size, -np.inf),
                                                 np.full(sleep.size, np.inf)))
                # in null-space coordinates a finite bound far below the incumbent is the LP's own (IPX at 1e-10): a
                # relaxation of that LP cannot close the root, so the time goes to branching (6x3 running-bond wall:
                # bound 0.5753 against 0.5789 after the first run, then the second took the rest of 600 s)
                settled = (reduced is not None and np.isfinite(full)
                           and target - full > NULL_SPACE_SETTLED_GAP * max(1.0, abs(target)))
                if not _meets(bound, target) and not settled:
                    # the second run drops every one-sided row with a zero dual (static pair rows and lam rows too)
                    bound = max(bound, bound_without((np.isfinite(rl) ^ np.isfinite(ru))
                                                     & (np.abs(y) <= DORMANT_DUAL_TOL)))
                    note(bound)
        if reduced is not None and self.null_space_nodes:
            # from here on every node LP is solved in null-space coordinates, its dormant rows left out; the
            # interior point solves the whole LP (9-block door wall: 0.5-0.6 s a node LP with every row, 1-3 s
            # without the dormant rows and their separation rounds, with weaker bounds)
            _, row_lower, row_upper, _, _ = self.lp_arrays()
            sleeping = np.flatnonzero(self.dormant)
            if self.node_lp == "interior":  # the dormant rows sleep in the sparse LP only
                self.dormant_free = False
            nodes = NullSpaceNodes.of(reduced, self.lifted_matrix, self.layout, self.form.n_pairs, self._changed_rows(),
                                      row_lower, row_upper, sleeping)
            if nodes is not None:
                nodes.use("full" if self.node_lp == "interior" else "sparse")
                self.h = nodes
                self.nodes_in_null_space = True
                self.iteration_limit = max(NODE_LP_ITERATIONS, sum(reduced.A.shape))
        self.ipm_time = self.root_timing["ipm"] = time.perf_counter() - t0
        self.ipm_bound = bound
        return bound

    def null_space_root_lp(self, c, rl, ru, cl, cu, basis: str = "tree"):
        """The root LP in the null-space coordinates of :mod:`~blockmpec.solvers.linalg.null_space`.

        The static field and every copy are written ``x = x_d + lam x_l + N sigma`` (``N`` a basis of the
        self-stresses, the null space of the equilibrium matrix ``E``) and the mechanism ``u = L z``, so the rows of
        equilibrium and of the tree part of compatibility hold identically and drop out; every point of the lifted
        LP maps to one point of this LP with the same ``lam`` and back, so the two have the same minimum.

        Parameters
        ----------
        c, rl, ru, cl, cu : ndarray
            The lifted LP's cost and bounds (:meth:`lp_arrays`).
        basis : str
            The self-stress basis of :func:`~blockmpec.solvers.linalg.null_space.static_null_space`.

        Returns
        -------
        NullSpaceLP or None
            The reduced LP (its ``arrays`` and the map of its rows to the lifted ones), or None where the lifting
            does not allow it (not every force tied, copies without statics) or the structure has no checked basis.
        """
        from blockmpec.solvers.linalg.null_space import layout_allows, null_space_lp, static_null_space

        lay = self.layout
        if self.static_copies != "all" or not layout_allows(lay, self.form.n_pairs):
            return None
        space = static_null_space(self.form, basis)
        if space is None:
            return None
        try:
            return null_space_lp(self.lifted_matrix, c, rl, ru, cl, cu, lay, space)
        except ValueError:  # a row that should vanish on the null space does not hold: keep the lifted LP
            return None

    def generated_root(self, target: float = np.inf, record=None) -> float:
        """A lower bound on ``lam`` at the root: ``root_lp="ipm-rows"``, the root LP (its bounds already applied by
        :meth:`apply_node`) by row generation, each round one
        interior point (no crossover) on a subset of its rows; returns the largest round's dual bound (``-inf``
        if none).

        Any subset of the rows is a relaxation, so every round's :func:`dual_bound` (on the LP actually solved)
        is a valid lower bound.  Round 0 leaves out the copy friction rows ``G_j x^(i) <= 0`` (``j != i``, ``j``
        a friction pair) and the moments' rows (X) (without the unilateral rows too, the 4x3 wall's first interior
        point had not ended after 200 s); each round adds every left-out row violated by more than
        ``ROOT_ROW_TOL`` at the interior point's primal point.  It stops when the bound meets ``target`` (``INTERIOR_CLOSE_TOL``), when no
        left-out row is violated (the point is feasible for the whole LP: its bound is then the whole LP's within
        the interior point's tolerances), after ``ROOT_ROW_ROUNDS`` rounds, or when an interior point gives no
        duals (time limit).  The copy pair rows still left out are made dormant for the node LPs
        (woken where a node's point violates them, as with ``root_lp="ipm"``).  ``self.root_rounds``: one dict
        per round (rows, columns, nonzeros, rows added after it, bound, seconds since the start);
        ``self.root_lp_rows``: the rows of the last LP solved (a mask of the lifted LP's rows)."""
        t0 = time.perf_counter()
        c, rl, ru, cl, cu = self.lp_arrays()
        lay = self.layout
        A = sp.csr_array(self.lifted_matrix)
        out = np.zeros(A.shape[0], dtype=bool)
        friction_rows = [lay.copy_pair_rows[j] for j in np.flatnonzero(self.form.pair_kind == FRICTION)]
        out[np.concatenate(friction_rows) if friction_rows else np.zeros(0, int)] = True
        out[lay.own_rows] = False
        out |= self._late_rows
        bound = -np.inf
        self.root_rounds = []
        for k in range(ROOT_ROW_ROUNDS):
            keep = ~out
            Ak = sp.csc_array(A[keep])
            y, vk = self.interior_solution(Ak, c, rl[keep], ru[keep], cl, cu)
            if y is None:
                break
            self.root_lp_rows = keep.copy()
            bound = max(bound, dual_bound(Ak, c, rl[keep], ru[keep], cl, cu, y))
            info = {"round": k, "rows": int(keep.sum()), "cols": int(A.shape[1]), "nnz": int(Ak.nnz),
                    "bound": bound, "time_s": time.perf_counter() - t0, "added": 0}
            self.root_rounds.append(info)
            if record is not None:
                record(bound)
            if _meets(bound, target) or vk is None:
                break
            r = A @ vk
            viol = np.maximum(r - ru, rl - r)
            add = out & (viol > ROOT_ROW_TOL)
            info["added"] = int(add.sum())
            if not add.any():
                break
            out &= ~add
        # the copy pair rows still left out sleep in the node LPs
        sleep = self.dormant_candidates[out[self.dormant_candidates]]
        self.dormant[sleep] = True
        _checked(self.h.changeRowsBounds(sleep.size, sleep, np.full(sleep.size, -np.inf),
                                         np.full(sleep.size, np.inf)))
        self.ipm_time = self.root_timing["ipm"] = time.perf_counter() - t0
        self.ipm_bound = bound
        return bound

    def _interior_bound(self, A, c, rl, ru, cl, cu, tolerance: float | None = None) -> tuple:
        """``(dual bound, row duals)`` of the LP from HiGHS's interior point without crossover, and, when that
        gives no finite bound and time is left, from a second run *with* crossover (``(-inf, None)`` if neither
        gives one).

        The second run is the repair for an interior point that stops short: on the lifted LP of the arch on
        buttresses (8 voussoirs, mu = 0.4) IPX without crossover ended "unknown" with reduced costs of 1e4 on free
        columns (no bound) on the LP without the moments' rows and "infeasible" on the whole (feasible) LP, and the
        root then went to the dual simplex (12 s in all); with crossover both ended optimal with the minimum as
        their bound (1.0 s and 2.4 s).  A crossover can take long on the large walls, which is why it is only the
        fallback; its basic duals pick more rows dormant (any choice keeps the bound valid)."""
        y = self.interior_solution(A, c, rl, ru, cl, cu, tolerance=tolerance)[0]
        bound = -np.inf if y is None else dual_bound(A, c, rl, ru, cl, cu, y)
        if bound == -np.inf and not self.deadline.expired():
            self.crossover_runs += 1
            y2 = self.interior_solution(A, c, rl, ru, cl, cu, crossover=True, tolerance=tolerance)[0]
            bound2 = -np.inf if y2 is None else dual_bound(A, c, rl, ru, cl, cu, y2)
            if y is None or bound2 > bound:
                bound, y = bound2, y2
        return bound, y

    def interior_solution(self, A, c, rl, ru, cl, cu, crossover: bool = False,
                          tolerance: float | None = None, basis: bool = False) -> tuple:
        """The LP ``min c^T v`` subject to ``rl <= A v <= ru``, ``cl <= v <= cu`` by HiGHS's interior point (one
        LP counted in ``n_lps``), within :attr:`deadline`.

        Parameters
        ----------
        A : sparse matrix
        c, rl, ru, cl, cu : ndarray
        crossover : bool
            Run HiGHS's crossover after the interior point (a basic solution and a basis).
        tolerance : float, optional
            Primal and dual feasibility tolerance (default: HiGHS's).
        basis : bool
            Also return HiGHS's basis.

        Returns
        -------
        tuple
            ``(row duals, column values)``: ``(None, None)`` if it gave no duals, the values None if it gave none;
            with ``basis``, HiGHS's basis (or None: no crossover or no duals) as a third item.  Any row duals give
            a valid lower bound through :func:`dual_bound`.
        """
        g = new_highs()
        g.passModel(highs_lp(A, c, rl, ru, cl, cu))
        use_interior_point(g, crossover=crossover, solver=INTERIOR_SOLVER)
        if tolerance is not None:
            set_feasibility_tolerances(g, tolerance)
        if not set_deadline(g, self.deadline):
            return (None, None, None) if basis else (None, None)
        g.run()
        self.n_lps += 1
        # kUnknown: the interior point stopped near the optimum without meeting its tolerances (seen on small
        # walls with an opening); its duals still tell the rows apart and give a bound
        sol = g.getSolution()
        out = (None, None)
        if g.getModelStatus().name in ("kOptimal", "kUnknown") and sol.dual_valid:
            out = (np.asarray(sol.row_dual, float), np.asarray(sol.col_value, float) if sol.value_valid else None)
        if basis:
            return (*out, g.getBasis() if out[0] is not None and crossover else None)
        return out

    def _run(self) -> Status:
        """One LP solve: at ``LOOSE_LP_TOL`` first (the lifted LPs are degenerate: the dual simplex at 1e-10
        from scratch was measured 20x slower or stalled), then from that basis at ``LP_TOL`` (a few
        iterations), whose answer alone is used; both within the time left (``self.deadline``) and
        ``NODE_LP_ITERATIONS`` simplex iterations each.  An LP infeasible at the loose tolerance is infeasible at
        the tight one (a smaller set): no second solve.  Returns the status."""
        h = self.h
        h.setOptionValue("simplex_iteration_limit", int(self.iteration_limit))
        st = Status.ERROR
        for tol in (LOOSE_LP_TOL, LP_TOL):
            set_feasibility_tolerances(h, tol)
            if not set_deadline(h, self.deadline):
                # no time left: the model status stays the previous solve's, so mark the run as timed out
                h.setOptionValue("time_limit", 0.0)
            h.run()
            self.n_lps += 1
            st = highs_status(h)[0]
            if st is Status.TIME_LIMIT or st is Status.INFEASIBLE or st is Status.ITERATION_LIMIT:
                break
        return st

    def root_bound(self, a: float | None = None, b: float | None = None) -> float:
        """The lifted LP's minimum of ``lam`` at the root pattern over ``lam in [a, b]`` (``inf``: infeasible,
        ``nan``: the LP failed); a measurement, not used by :meth:`solve`."""
        a = self.lam_lower if a is None else a
        b = self.lam_cap if b is None else b
        st, bound, _ = self.solve_node(self.root, a, b)
        if st is Status.INFEASIBLE:
            return np.inf
        return bound if st is Status.OPTIMAL else np.nan

    def _restrict_to_improvements(self, best_val: float) -> None:
        """Only points with ``lam <= best_val`` can improve the incumbent: ``lam <= best_val`` and
        ``zeta_i <= best_val z_i`` (valid for every such point; the incumbent itself is kept apart)."""
        if np.isfinite(best_val) and best_val < self.lam_cap:
            self.lam_cap = best_val

    def _candidates(self, state: np.ndarray, v: np.ndarray) -> list[int]:
        """Free pairs violated at the LP point, most violated first (complementarity + work defect)."""
        lay, form = self.layout, self.form
        x = v[lay.x]
        z = v[lay.z]
        s = -(form.pair_matrix @ x)
        score = np.maximum(z, 0.0) * np.maximum(s, 0.0)
        defect = np.abs(self.B.data * (v[self._work_copy] - z[self.B.col] * x[self.B.row]))
        np.add.at(score, self.B.col, defect)
        score[state != 0] = -1.0
        order = np.argsort(-score)
        return [int(j) for j in order if score[j] > VIOLATION_TOL]

    def _children(self, branch, state, a, b, nb, v, basis, best_val):
        """The two children of ``branch`` (a pair index, or ``("lam", m)``): (bound, state, a, b, point, basis)
        each; a leaf pattern is polished (its exact value returned as ``(inf, ...)`` with the solution)."""
        kids, found = [], []
        if isinstance(branch, tuple):
            m = branch[1]
            parts = [(state, a, m), (state, m, b)]
        else:
            parts = []
            for val in (1, -1):
                child = state.copy()
                child[branch] = val
                parts.append((child, a, b))
        for child, ca, cb in parts:
            if not (child == 0).any():
                # a leaf is one pattern: its exact minimum (over every lam) is known, the child is closed
                sol = self.polish(child == 1)
                if sol is not None:
                    found.append(sol)
                else:
                    self.unproven_closures += 1
                kids.append((np.inf, child, ca, cb, None, None))
                continue
            if basis is not None:
                self.h.setBasis(basis)  # warm start from the parent's optimal basis
            cst, cbound, cv = self.solve_node(child, ca, cb)
            if cst is Status.INFEASIBLE:
                kids.append((np.inf, child, ca, cb, None, None))
            elif cst is not Status.OPTIMAL:
                kids.append((max(nb, ca), child, ca, cb, v, basis))  # keeps the parent's bound, never prunes
            else:
                kids.append((max(cbound, nb, ca), child, ca, cb, cv, self.last_basis))
        return kids, found

    def solve(self, deadline: Deadline = NEVER, incumbent=None, t0: float | None = None, sign: float = 1.0) -> tuple:
        """Returns (MIPRun in lam units, best Solution or None), within ``deadline``."""
        t0 = time.perf_counter() if t0 is None else t0
        self.deadline = deadline
        tracer = _Tracer(1.0, t0)
        best = incumbent
        best_val = incumbent.multiplier if incumbent is not None else np.inf
        self._restrict_to_improvements(best_val)
        a0, b0 = self.lam_lower, np.inf
        interior = -np.inf
        if self.root_lp != "simplex" and a0 <= self.lam_cap:
            # without the cap lam <= incumbent: with it the LP's optimum sits on the cap and the interior point
            # was seen to stop short (4x2 wall: no bound, where the uncapped LP gave the minimum within 1.4e-8)
            cap, self.lam_cap = self.lam_cap, self.lam_upper
            self.apply_node(self.root, a0, b0)
            root = self.generated_root if self.root_lp == "ipm-rows" else self.interior_root
            interior = root(best_val, lambda bnd: tracer.record(max(a0, min(bnd, best_val)), best_val, force=True))
            self.lam_cap = cap
            if best is not None and _meets(interior, best_val):
                # the interior point's duals meet the incumbent within the accuracy of an interior point (the
                # certificate tolerance of milp): the gap, reported as it is, is closed
                tracer.record(min(interior, best_val), best_val, force=True)
                return MIPRun(Status.OPTIMAL, "optimal", "certified at the root by the interior point's dual bound",
                              None, best_val, min(interior, best_val), 0, time.perf_counter() - t0,
                              tracer.records), best
        st, bound, v = self.solve_node(self.root, a0, b0)
        if st is Status.OPTIMAL:
            bound = max(bound, interior)
        if st is Status.INFEASIBLE:
            if best is not None:  # nothing has lam <= the incumbent's value but the incumbent: optimal
                tracer.record(best_val, best_val, force=True)
                return MIPRun(Status.OPTIMAL, "optimal", "root LP infeasible below the incumbent", None, best_val,
                              best_val, 1, time.perf_counter() - t0, tracer.records), best
            return MIPRun(Status.INFEASIBLE, "infeasible", "root LP infeasible", None, np.inf, np.inf, 1,
                          time.perf_counter() - t0, tracer.records), best
        if st is Status.TIME_LIMIT:  # the bound passed in (lam_lower) or the interior point's stands
            root_bound = max(self.lam_lower, min(interior, best_val))
            tracer.record(root_bound, best_val, force=True)
            return MIPRun(Status.TIME_LIMIT, "time_limit", "time limit in the root LP", None, best_val,
                          root_bound, 0, time.perf_counter() - t0, tracer.records), best
        if st is not Status.OPTIMAL:
            return MIPRun(Status.ERROR, st.value, f"root LP {st.value}", None, best_val, -np.inf, 1,
                          time.perf_counter() - t0, tracer.records), best
        heap = [(bound, 0, self.root.copy(), a0, b0, v, self.last_basis)]
        counter, nodes = 1, 0
        global_bound = bound
        status = Status.OPTIMAL

        def tol():
            # without an incumbent (best_val = inf) nothing is pruned: inf - bound <= inf closed the root at once,
            # and inf - inf = nan kept every child off the heap (a run without incumbent found no point)
            return PRUNE_TOL * max(1.0, abs(best_val)) if np.isfinite(best_val) else 0.0

        while heap:
            global_bound = min(entry[0] for entry in heap)
            tracer.record(global_bound, best_val)
            if best_val - global_bound <= tol():
                global_bound = min(global_bound, best_val)
                break
            if deadline.expired():
                status = Status.TIME_LIMIT
                break
            self._restrict_to_improvements(best_val)
            nb, _, state, a, b, v, basis = heapq.heappop(heap)
            nodes += 1
            if nb >= best_val - tol():
                continue
            # an incumbent from the node's LP pattern
            z, s = v[self.layout.z], -(self.form.pair_matrix @ v[self.layout.x])
            active = np.where(state == 0, z > s, state == 1)
            sol = self.polish(active)
            if sol is not None and sol.multiplier < best_val:
                best, best_val = sol, sol.multiplier
                tracer.record(min(nb, best_val), best_val, force=True)
            # strong branching with fixings: a candidate one of whose children is pruned (infeasible, or bounded
            # at the incumbent) is fixed to the other child in this node, whose LP becomes the node's (a domain
            # reduction, no new node); the node branches on the best candidate evaluated after the last fixing
            chosen, closed = None, False
            for _ in range(FIXING_ROUNDS):
                candidates: list = self._candidates(state, v)
                free = state == 0
                z, s = v[self.layout.z], -(self.form.pair_matrix @ v[self.layout.x])
                active = np.where(state == 0, z > s, state == 1)
                if not candidates:
                    # the LP point satisfies complementarity on the free pairs: its pattern's polish is exact
                    leaf = state.copy()
                    leaf[free] = np.where(active[free], 1, -1)
                    sol = self.polish(leaf == 1)
                    if sol is not None and sol.multiplier < best_val:
                        best, best_val = sol, sol.multiplier
                    # a node without violation is closed by its pattern only if its bound meets it
                    if (sol is not None and sol.multiplier - nb <= PRUNE_TOL * max(1.0, abs(sol.multiplier))) \
                            or not free.any():
                        self.unproven_closures += int(sol is None)
                        closed = True
                        break
                    candidates = [int(np.flatnonzero(free)[0])]
                candidates = candidates[: self.root_strong if nodes == 1 else self.strong]
                top = min(b, best_val)
                if self.lam_branching and top - nb > LAM_SPLIT_TOL * max(1.0, abs(top)):
                    # bisect [nb, top]: the upper child's bound is its lower end, the lower child's copies
                    # must carry live load <= the midpoint
                    candidates.append(("lam", 0.5 * (max(nb, a) + top)))
                chosen, chosen_key, fixed = None, -np.inf, False
                for branch in candidates:
                    if deadline.expired():
                        break
                    kids, found = self._children(branch, state, a, b, nb, v, basis, best_val)
                    for sol in found:
                        if sol.multiplier < best_val:
                            best, best_val = sol, sol.multiplier
                            tracer.record(min(nb, best_val), best_val, force=True)
                    alive = [k for k in kids if k[0] < best_val - tol()]
                    if not alive:  # both children pruned: so is this node
                        closed = True
                        break
                    if len(alive) == 1 and not isinstance(branch, tuple) and alive[0][4] is not None:
                        nb, state, a, b, v, basis = max(nb, alive[0][0]), *alive[0][1:]
                        self.fixings += 1
                        fixed, chosen = True, None
                        continue
                    key = min(k[0] for k in kids) + 1e-3 * max(k[0] if np.isfinite(k[0]) else 0.0 for k in kids)
                    if key > chosen_key:
                        chosen, chosen_key, chosen_branch = kids, key, branch
                if closed or not fixed or deadline.expired():
                    break
            if closed:
                continue
            if chosen is None:  # every candidate was fixed (or the time ran out): the node goes back, reduced
                if nb < best_val - tol():
                    heapq.heappush(heap, (nb, counter, state, a, b, v, basis))
                    counter += 1
                continue
            if isinstance(chosen_branch, tuple):
                self.lam_splits += 1
            for cb, child, ca, cbb, cv, cbasis in chosen:
                if cv is not None and cb < best_val - tol():
                    heapq.heappush(heap, (cb, counter, child, ca, cbb, cv, cbasis))
                    counter += 1
        else:
            global_bound = best_val
        if status is Status.OPTIMAL and heap:
            global_bound = min(min(entry[0] for entry in heap), best_val)
        tracer.record(global_bound, best_val, force=True)
        point = None
        return MIPRun(status, status.value, f"complementarity B&B: {nodes} nodes, {self.n_lps} LPs, "
                      f"{self.lam_splits} lam splits, {self.fixings} fixings, {self.interior_nodes} interior-point node LPs, "
                      f"{int(self.dormant.sum())} dormant rows ({self.woken} woken)", point, best_val, global_bound, nodes,
                      time.perf_counter() - t0, tracer.records), best
