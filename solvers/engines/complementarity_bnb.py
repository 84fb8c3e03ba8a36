r"""A branch and bound over the complementarity pairs of (3) with a lifted LP bound (no big-M).

Each node is a pattern ``state`` (``1``: pair active, ``s_i = 0``; ``-1``: idle, ``z_i = 0``; ``0``: free) and an
interval ``a <= lam <= b``; its bound is the minimum of ``lam`` over the lifted LP of
:mod:`~blockmpec.solvers.engines.lifted_lp` with the pattern applied, a relaxation of every solution of (3) with that
pattern in that interval.  Branching on a pair ``j`` splits the solutions of (3) exactly:

* ``active``: ``s_j = 0``, so ``G_j x = 0`` and ``G_j x^(i) = -s_j z_i = 0`` in *every* copy (this is where the
  copies couple: a sliding joint forces its friction rows tight in every other copy, and the friction work moves);
* ``idle``: ``z_j = 0`` (copy ``j`` vanishes: ``zeta_j = 0``).

Branching on ``lam`` (``lam_branching``): a node carries ``[a, b]`` with ``a z_i <= zeta_i <= b z_i`` in every copy,
valid since ``z_i >= 0``; the incumbent caps ``b`` (only points with ``lam`` below it can improve it).

The root LP is solved by the interior point (:mod:`~blockmpec.solvers.engines.bnb_root`); the node LPs by the dual
simplex from the parent's basis or, in null-space coordinates (``node_lp="interior"``), by the interior point, whose
duals give the node's bound whatever its point (:mod:`~blockmpec.solvers.engines.node_lp`).  A node LP that is not
optimal never prunes (its node keeps the parent's bound); an infeasible one is pruned only on a checked Farkas
certificate.  A leaf (every pair fixed) is one pattern: its exact minimum is the polish of the pattern.

Nodes are explored best-bound first.  Strong branching with fixings: both children of up to ``strong`` candidates
(``ROOT_STRONG`` at the root) are solved; a candidate one of whose children is pruned is *fixed* to the other child
in the node itself (a domain reduction, no new node), and the candidates are evaluated again (``FIXING_ROUNDS``);
a node whose every candidate closes both children is closed.  Candidates: the free pairs with the largest
complementarity violation ``z_j s_j`` of the LP point plus their friction-work defect ``|B_e (x^(i)_r - z_i x_r)|``
(the copy and the static field disagree on the normal force that dissipates).
"""

from __future__ import annotations

import heapq
import time

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.result import Status
from blockmpec.solvers.engines.bnb_root import NULL_SPACE_IPM_TOL, RootLP, meets
from blockmpec.solvers.engines.lifted_lp import dual_bound, lifted_lp, open_reduced_cost, proves_infeasible
from blockmpec.solvers.engines.mip import MIPRun, _Tracer
from blockmpec.solvers.engines.node_lp import LiftedNodes, simplex

__all__ = ["ROOT_LPS", "ComplementarityBnB", "dual_bound", "lifted_lp", "open_reduced_cost", "proves_infeasible"]

#: a node is pruned when its bound is within this (times max(1, |incumbent|)) of the incumbent
PRUNE_TOL = 1e-9
#: complementarity violation below which a pair of the LP point counts as satisfied
VIOLATION_TOL = 1e-9
#: lam_branching: a node's interval [bound, min(b, incumbent)] is bisected only while wider than this (relative)
LAM_SPLIT_TOL = 1e-6
#: a dormant row violated by more than this at a node's LP point is woken; re-solves of one node LP at most
SEPARATION_TOL = 1e-9
SEPARATION_ROUNDS = 3
#: strong branching: rounds of candidates per node at most (each after a fixing), candidates at the root
FIXING_ROUNDS = 5
ROOT_STRONG = 16
#: the root LP: ``"ipm"`` by the interior point (in null-space coordinates where the lifting allows),
#: ``"ipm-lifted"`` the same on the lifted LP, ``"simplex"`` by the dual simplex
ROOT_LPS = ("simplex", "ipm", "ipm-lifted")


class ComplementarityBnB(RootLP):
    """Best-bound branch and bound over the pairs (and, ``lam_branching``, over ``lam``); see the module docstring.

    Parameters
    ----------
    form : CompiledMCP
        Problem (3) (in the units of the search).
    B : sparse matrix
        The friction work (:func:`~blockmpec.formulations.mpec_milp.work_matrix`).
    lam_lower, lam_upper : float
        Bounds on ``lam`` at every solution of (3).
    polish : callable
        ``polish(active) -> Solution | None``: the exact point of a pattern (its value closes a leaf).
    fixed_active, fixed_idle : ndarray of bool, optional
        Pairs fixed at the root.
    strong : int
        Strong-branching candidates per node.
    slack_max, all_copies, lam_mechanism, force_mechanism, static_copies
        The lifting (:func:`~blockmpec.solvers.engines.lifted_lp.lifted_lp`).
    lam_branching, own_pair_active : bool
        Branch on ``lam`` too; hold every copy's own pair row at equality.
    root_lp : str
        One of :data:`ROOT_LPS`.
    null_space_nodes : bool
        With the root in null-space coordinates, solve the node LPs there too.
    node_lp : {"interior", "simplex"}
        Node LPs in null-space coordinates: the interior point first, or the dual simplex from the parent's basis.
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
        self.deadline: Deadline = NEVER
        self.lifted = LiftedNodes(A, c, rl, ru, cl, cu)
        #: the node LPs as HiGHS holds them (:class:`~.node_lp.LiftedNodes`, then maybe :class:`~.node_lp.NullSpaceNodes`)
        self.nodes = self.lifted
        self.root_lp, self.static_copies, self.node_lp = root_lp, static_copies, node_lp
        self.null_space_root = False  # the root LP was solved in null-space coordinates
        self.null_space_nodes = bool(null_space_nodes)
        self.nodes_in_null_space = False
        #: the lifted LP's constraint matrix ``A`` (CSC; its rows and columns as in :func:`lifted_lp`)
        self.lifted_matrix = sp.csc_array(A)
        self._init_dormant(A)
        self.root = np.zeros(form.n_pairs, dtype=np.int8)  # 0 free, 1 active, -1 inactive
        if fixed_active is not None:
            self.root[fixed_active] = 1
        if fixed_idle is not None:
            self.root[fixed_idle & (self.root == 0)] = -1
        self.n_lps = self.interior_nodes = self.crossover_runs = self.fixings = self.lam_splits = 0
        self.farkas_proofs = 0  # node LPs pruned as infeasible on a checked Farkas certificate
        self.unproven_closures = 0  # leaves closed because their pattern LP had no point (HiGHS's word)
        self.ipm_time, self.ipm_bound, self.root_timing = 0.0, None, {}
        self.last_basis = None
        self.strong = max(1, int(strong))
        self.root_strong = max(self.strong, ROOT_STRONG)
        self.lam_lower, self.lam_cap, self.lam_upper = float(lam_lower), float(lam_upper), float(lam_upper)
        self.lam_branching, self.own_pair_active = bool(lam_branching), bool(own_pair_active)
        self._interval = (float(lam_lower), float(lam_upper))  # the (a, b) now in the LP's zeta rows
        # the x-slices of the copies, by pair (for the work defect of _candidates)
        self._work_copy = np.array([layout.copy_x[int(i)].start + int(r) for i, r in zip(B.col, B.row)], dtype=int)

    def _init_dormant(self, A) -> None:
        """The rows that may sleep (the copy pair rows ``G_j x^(i) <= 0`` with ``j != i``) and the rows (X) of the
        moments (left out of the root's first interior point)."""
        lay, npair = self.layout, self.form.n_pairs
        own = np.zeros(A.shape[0], dtype=bool)
        own[lay.own_rows] = True
        rows = np.concatenate([lay.copy_pair_rows[j] for j in range(npair)]) if npair else np.zeros(0, int)
        self.dormant_candidates = np.sort(rows[~own[rows]]).astype(np.int64)
        self._sleep_matrix = sp.csr_array(A)[self.dormant_candidates]
        self.dormant = np.zeros(A.shape[0], dtype=bool)
        #: the dormant rows are free in the node LPs (False: node_lp="interior" in null-space coordinates, where
        #: they sleep only in the dual simplex's sparse model)
        self.dormant_free = True
        self.woken = 0
        late = np.zeros(A.shape[0], dtype=bool)
        if lay.tied is not None:
            nt_forces = np.isin(lay.tied, np.r_[self.form.n, self.form.t])
            late[lay.tied_rows[~nt_forces].ravel()] = True
        self._late_rows = late

    def _changed_rows(self) -> np.ndarray:
        """The lifted rows whose bounds or coefficients the search changes (pair rows, ``zeta`` rows)."""
        lay = self.layout
        parts = [lay.static_pair_rows, lay.zeta_lower_rows, lay.zeta_upper_rows, lay.own_rows, self.dormant_candidates]
        parts += [lay.copy_pair_rows[j] for j in range(self.form.n_pairs)]
        return np.concatenate([np.asarray(p, dtype=np.int64).ravel() for p in parts])

    def lp_arrays(self) -> tuple:
        """The lifted LP's cost and bounds as HiGHS holds it now: ``(c, row_lower, row_upper, col_lower,
        col_upper)`` (``A`` is :attr:`lifted_matrix`); only while the node LPs are on the lifted LP."""
        if self.nodes_in_null_space:
            raise RuntimeError("the node LPs are in null-space coordinates: the lifted LP is not held any more")
        _, c, rl, ru, cl, cu = self.lifted.model.arrays()
        return c, rl, ru, cl, cu

    # ------------------------------------------------------------------ one node
    def _set_interval(self, a: float, b: float) -> None:
        """``a <= lam <= b`` and ``a z_i <= zeta_i <= b z_i`` in every copy (coefficients changed in place)."""
        lay = self.layout
        self.nodes.set_column_bounds([lay.lam], [a], [b])
        if (a, b) == self._interval:
            return
        pa, pb = self._interval
        z = np.array([lay.z.start + i for i, _, _ in lay.copies])
        if a != pa:
            self.nodes.set_coefficients(lay.zeta_lower_rows, z, np.full(z.size, -a))
        if b != pb:
            self.nodes.set_coefficients(lay.zeta_upper_rows, z, np.full(z.size, -b))
        self._interval = (a, b)

    def apply_node(self, state: np.ndarray, a: float, b: float) -> None:
        """Set the node LP of the pattern ``state`` over ``a <= lam <= b``: every pair row ``<= 0`` (free while
        dormant, when dormant rows are free), the rows of the active pairs and every copy's own pair row (with
        ``own_pair_active``) ``= 0``, ``z_i = 0`` for the idle pairs, and :meth:`_set_interval` with ``b`` capped."""
        lay = self.layout
        rows = np.concatenate([lay.static_pair_rows] + [lay.copy_pair_rows[j] for j in range(state.size)])
        active = [lay.static_pair_rows[state == 1]] + [lay.copy_pair_rows[j] for j in np.flatnonzero(state == 1)]
        if self.own_pair_active:
            active.append(lay.own_rows)
        active = np.unique(np.concatenate(active))
        upper = np.where(self.dormant[rows] & self.dormant_free, np.inf, 0.0)
        self.nodes.set_row_bounds(rows, np.full(rows.size, -np.inf), upper)
        if active.size:
            self.nodes.set_row_bounds(active, np.zeros(active.size), np.zeros(active.size))
        zc = np.arange(lay.z.start, lay.z.stop)
        self.nodes.set_column_bounds(zc, np.zeros(zc.size), np.where(state == -1, 0.0, np.inf))
        self._set_interval(a, min(b, self.lam_cap))

    def solve_node(self, state: np.ndarray, a: float, b: float):
        """``(status, bound, point)`` of the node LP of ``state`` over ``a <= lam <= b``: ``bound`` a lower bound on
        ``lam`` over every solution of (3) with that pattern in that interval, ``point`` the lifted point (None
        unless ``OPTIMAL``).  An infeasible LP is pruned only on a proof; one that ends otherwise is repaired by the
        interior point with crossover, then by a cold re-solve; failing both its status is returned."""
        if a > min(b, self.lam_cap):
            return Status.INFEASIBLE, None, None
        self.apply_node(state, a, b)
        if self.node_lp == "interior" and self.nodes_in_null_space:
            return self._interior_node_lp(a, b)
        out = self._simplex()
        # a checked Farkas certificate proves infeasibility whatever HiGHS's status (after its presolve an
        # infeasible node LP can end kUnknown with a valid dual ray)
        if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT) and self._infeasibility_proven():
            return Status.INFEASIBLE, None, None
        if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT, Status.INFEASIBLE):
            ist, ibound, iv = self._interior_node(crossover=True)
            if ist is Status.OPTIMAL:
                return ist, ibound, iv
        if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT):
            # a cold re-solve: warm re-solves after coefficient changes were seen to end without an optimal status
            self.nodes.active().hl.clear_basis()
            out = self._simplex()
            if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT):
                if self._infeasibility_proven():
                    return Status.INFEASIBLE, None, None
                return Status.ERROR, None, None  # not pruned: the node keeps its parent's bound
        if out.status is not Status.OPTIMAL:
            return out.status, None, None
        return self._separated(out)

    def _simplex(self):
        out, solves = simplex(self.nodes.active(), self.nodes.iteration_limit, self.deadline)
        self.n_lps += solves
        return out

    def _separated(self, out):
        """The optimal node LP ``out`` after waking the dormant rows its point violates (re-solved at most
        ``SEPARATION_ROUNDS`` times; the last optimal LP, a relaxation of the next, gives the bound)."""
        model = self.nodes.active()
        v, value, basis = self.nodes.lift(out.v), float(out.objective), model.hl.basis_status()
        for _ in range(SEPARATION_ROUNDS if self.dormant_free and self.dormant.any() else 0):
            if not self._wake(v):
                break
            out = self._simplex()
            if out.status is not Status.OPTIMAL:
                break
            v, value, basis = self.nodes.lift(out.v), float(out.objective), model.hl.basis_status()
        self.last_basis = basis
        return Status.OPTIMAL, value, v

    def _interior_node_lp(self, a: float, b: float):
        """``node_lp="interior"``: the node LP by the interior point.  An infeasible LP gives it no bound; then the
        LP without the cap ``lam <= incumbent`` (a relaxation) prunes the node if its bound reaches the cap, and
        failing that the dual simplex on the sparse model prunes it on a Farkas proof; otherwise ``ERROR``."""
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
        self.nodes.use("sparse")
        try:
            out = self._simplex()
            if out.status not in (Status.OPTIMAL, Status.TIME_LIMIT):  # a checked Farkas proof, whatever the status
                return (Status.INFEASIBLE, None, None) if self._infeasibility_proven() else (Status.ERROR, None, None)
            if out.status is Status.OPTIMAL:  # the sparse LP is a relaxation: its minimum bounds the node's
                return out.status, float(out.objective), self.nodes.lift(out.v)
            return out.status, None, None
        finally:
            self.nodes.use("full")

    def _infeasibility_proven(self) -> bool:
        """HiGHS's dual ray of the infeasible node LP is a Farkas certificate (:func:`proves_infeasible`)."""
        model = self.nodes.active()
        ray = model.hl.dual_ray()
        if ray is None or ray.size != model.n_rows:
            return False
        A, _, rl, ru, cl, cu = model.arrays()
        proven = proves_infeasible(A, rl, ru, cl, cu, ray)
        self.farkas_proofs += int(proven)
        return proven

    def _interior_node(self, crossover: bool = False):
        """The node LP by the interior point (with its crossover if ``crossover``; without, and with no finite
        bound, once more with it): ``(OPTIMAL, dual bound, lifted point)`` or ``(ERROR, None, None)``.  A
        crossover's basis becomes the node LP's (the children start from it)."""
        if self.deadline.expired():
            return Status.TIME_LIMIT, None, None
        model = self.nodes.active()
        A, c, rl, ru, cl, cu = model.arrays()
        self.interior_nodes += 1
        tolerance = NULL_SPACE_IPM_TOL if self.nodes_in_null_space else None
        point = self.interior_solution(A, c, rl, ru, cl, cu, crossover=crossover, tolerance=tolerance)
        bound = -np.inf if point.y is None or point.v is None else dual_bound(A, c, rl, ru, cl, cu, point.y)
        if not np.isfinite(bound) and not crossover and point.y is not None and not self.deadline.expired():
            self.crossover_runs += 1
            point = self.interior_solution(A, c, rl, ru, cl, cu, crossover=True, tolerance=tolerance)
            bound = -np.inf if point.y is None or point.v is None else dual_bound(A, c, rl, ru, cl, cu, point.y)
        if not np.isfinite(bound):
            return Status.ERROR, None, None
        if point.basis is not None:
            model.hl.set_basis(*point.basis)
            self.last_basis = point.basis
        return Status.OPTIMAL, float(bound), self.nodes.lift(point.v)

    def _wake(self, v: np.ndarray) -> bool:
        """Wake the dormant rows violated at ``v`` (bound ``<= 0`` again); True if any."""
        rows = self.dormant_candidates
        bad = self.dormant[rows] & (self._sleep_matrix @ v > SEPARATION_TOL)
        if not bad.any():
            return False
        wake = rows[bad]
        self.dormant[wake] = False
        self.woken += int(wake.size)
        self.nodes.set_row_bounds(wake, np.full(wake.size, -np.inf), np.zeros(wake.size))
        return True

    def root_bound(self, a: float | None = None, b: float | None = None) -> float:
        """The lifted LP's minimum of ``lam`` at the root pattern over ``lam in [a, b]`` (``inf``: infeasible,
        ``nan``: the LP failed); a measurement, not used by :meth:`solve`."""
        st, bound, _ = self.solve_node(self.root, self.lam_lower if a is None else a, self.lam_cap if b is None else b)
        if st is Status.INFEASIBLE:
            return np.inf
        return bound if st is Status.OPTIMAL else np.nan

    # ------------------------------------------------------------------ branching
    def _candidates(self, state: np.ndarray, v: np.ndarray) -> list[int]:
        """Free pairs violated at the LP point, most violated first (complementarity + work defect)."""
        lay, form = self.layout, self.form
        x, z = v[lay.x], v[lay.z]
        score = np.maximum(z, 0.0) * np.maximum(-(form.pair_matrix @ x), 0.0)
        np.add.at(score, self.B.col, np.abs(self.B.data * (v[self._work_copy] - z[self.B.col] * x[self.B.row])))
        score[state != 0] = -1.0
        return [int(j) for j in np.argsort(-score) if score[j] > VIOLATION_TOL]

    def _children(self, branch, state, a, b, nb, v, basis):
        """The two children of ``branch`` (a pair index, or ``("lam", m)``): ``(bound, state, a, b, point, basis)``
        each, and the exact points of the leaf children (a leaf is closed with ``inf``)."""
        kids, found = [], []
        if isinstance(branch, tuple):
            parts = [(state, a, branch[1]), (state, branch[1], b)]
        else:
            parts = []
            for val in (1, -1):
                child = state.copy()
                child[branch] = val
                parts.append((child, a, b))
        for child, ca, cb in parts:
            if not (child == 0).any():  # a leaf is one pattern: its exact minimum is known, the child is closed
                sol = self.polish(child == 1)
                found += [sol] if sol is not None else []
                self.unproven_closures += int(sol is None)
                kids.append((np.inf, child, ca, cb, None, None))
                continue
            if basis is not None:
                self.nodes.active().hl.set_basis(*basis)  # warm start from the parent's optimal basis
            cst, cbound, cv = self.solve_node(child, ca, cb)
            if cst is Status.INFEASIBLE:
                kids.append((np.inf, child, ca, cb, None, None))
            elif cst is not Status.OPTIMAL:
                kids.append((max(nb, ca), child, ca, cb, v, basis))  # keeps the parent's bound, never prunes
            else:
                kids.append((max(cbound, nb, ca), child, ca, cb, cv, self.last_basis))
        return kids, found

    # ------------------------------------------------------------------ the search
    def solve(self, deadline: Deadline = NEVER, incumbent=None, t0: float | None = None) -> tuple:
        """The search within ``deadline`` from ``incumbent`` (a Solution or None); returns ``(MIPRun in lam units,
        best Solution or None)``."""
        self.deadline = deadline
        run = _Search(self, incumbent, time.perf_counter() if t0 is None else t0)
        early = run.root()
        if early is not None:
            return early, run.best
        while run.heap:
            if run.converged() or deadline.expired():
                break
            run.expand()
        return run.finish(), run.best


class _Search:
    """One run of :meth:`ComplementarityBnB.solve`: the incumbent, the heap of open nodes and the trace."""

    def __init__(self, bnb: ComplementarityBnB, incumbent, t0: float) -> None:
        self.bnb, self.t0 = bnb, t0
        self.tracer = _Tracer(1.0, t0)
        self.best = incumbent
        self.best_val = incumbent.multiplier if incumbent is not None else np.inf
        self.cap()
        self.heap: list = []
        self.counter = self.nodes = 0
        #: the bound when the best open node met the incumbent (None: not yet)
        self.met = None

    def cap(self) -> None:
        """Only points with ``lam <= best_val`` can improve the incumbent (the incumbent itself is kept apart)."""
        if np.isfinite(self.best_val) and self.best_val < self.bnb.lam_cap:
            self.bnb.lam_cap = self.best_val

    def tol(self) -> float:
        """The prune tolerance (0 without an incumbent: nothing is pruned then)."""
        return PRUNE_TOL * max(1.0, abs(self.best_val)) if np.isfinite(self.best_val) else 0.0

    def offer(self, sol, bound: float) -> None:
        if sol is not None and sol.multiplier < self.best_val:
            self.best, self.best_val = sol, sol.multiplier
            self.tracer.record(min(bound, self.best_val), self.best_val, force=True)

    def run(self, status: Status, message: str, bound: float, nodes: int) -> MIPRun:
        self.tracer.record(bound, self.best_val, force=True)
        return MIPRun(status, status.value, message, None, self.best_val, bound, nodes, time.perf_counter() - self.t0,
                      self.tracer.records)

    def push(self, bound: float, state, a, b, v, basis) -> None:
        heapq.heappush(self.heap, (bound, self.counter, state, a, b, v, basis))
        self.counter += 1

    def root(self) -> MIPRun | None:
        """The root: its interior-point bound (which may close it) and its node LP; a MIPRun when the search ends
        there, else None with the root on the heap."""
        bnb, a0 = self.bnb, self.bnb.lam_lower
        interior = -np.inf
        if bnb.root_lp != "simplex" and a0 <= bnb.lam_cap:
            # without the cap lam <= incumbent: with it the LP's optimum sits on the cap and the interior point
            # was seen to stop short
            cap, bnb.lam_cap = bnb.lam_cap, bnb.lam_upper
            bnb.apply_node(bnb.root, a0, np.inf)
            interior = bnb.interior_root(self.best_val, lambda bnd: self.tracer.record(
                max(a0, min(bnd, self.best_val)), self.best_val, force=True))
            bnb.lam_cap = cap
            if self.best is not None and meets(interior, self.best_val):
                return self.run(Status.OPTIMAL, "certified at the root by the interior point's dual bound",
                                min(interior, self.best_val), 0)
        st, bound, v = bnb.solve_node(bnb.root, a0, np.inf)
        if st is Status.INFEASIBLE:
            if self.best is not None:  # nothing has lam <= the incumbent's value but the incumbent: optimal
                return self.run(Status.OPTIMAL, "root LP infeasible below the incumbent", self.best_val, 1)
            return self.run(Status.INFEASIBLE, "root LP infeasible", np.inf, 1)
        if st is Status.TIME_LIMIT:  # the bound passed in (lam_lower) or the interior point's stands
            return self.run(Status.TIME_LIMIT, "time limit in the root LP", max(a0, min(interior, self.best_val)), 0)
        if st is not Status.OPTIMAL:
            return self.run(Status.ERROR, f"root LP {st.value}", max(a0, min(interior, self.best_val)), 1)
        self.push(max(bound, interior), bnb.root.copy(), a0, np.inf, v, bnb.last_basis)
        return None

    def converged(self) -> bool:
        """The best open node's bound meets the incumbent (recorded in the trace)."""
        bound = min(entry[0] for entry in self.heap)
        self.tracer.record(bound, self.best_val)
        if self.best_val - bound <= self.tol():
            self.met, self.heap = min(bound, self.best_val), []
            return True
        return False

    def expand(self) -> None:
        """Pop the best node, try its LP point's pattern as an incumbent, and branch (strong branching with
        fixings); its children go on the heap."""
        self.cap()
        nb, _, state, a, b, v, basis = heapq.heappop(self.heap)
        self.nodes += 1
        if nb >= self.best_val - self.tol():
            return
        bnb = self.bnb
        z, s = v[bnb.layout.z], -(bnb.form.pair_matrix @ v[bnb.layout.x])
        self.offer(bnb.polish(np.where(state == 0, z > s, state == 1)), nb)
        node = [nb, state, a, b, v, basis]
        chosen = None
        for _ in range(FIXING_ROUNDS):
            outcome, chosen = self.strong_branch(node)
            if outcome == "closed":
                return
            if outcome != "fixed" or bnb.deadline.expired():
                break
        nb, state, a, b, v, basis = node
        if chosen is None:  # every candidate was fixed (or the time ran out): the node goes back, reduced
            if nb < self.best_val - self.tol():
                self.push(nb, state, a, b, v, basis)
            return
        kids, branch = chosen
        self.bnb.lam_splits += int(isinstance(branch, tuple))
        for cb, child, ca, cbb, cv, cbasis in kids:
            if cv is not None and cb < self.best_val - self.tol():
                self.push(cb, child, ca, cbb, cv, cbasis)

    def strong_branch(self, node: list) -> tuple:
        """One round of strong branching on ``node`` (``[bound, state, a, b, point, basis]``, reduced in place by
        each fixing; the later candidates of the round are evaluated on the reduced node): ``("closed", None)``,
        ``("fixed", chosen)`` (a candidate was fixed: another round may follow) or ``("chosen", chosen)``, with
        ``chosen = (children, branch)`` of the best candidate evaluated after the last fixing (None if none)."""
        bnb = self.bnb
        nb, state, a, b, v, basis = node
        candidates: list = bnb._candidates(state, v)
        if not candidates:
            if self.close_by_pattern(node):
                return "closed", None
            candidates = [int(np.flatnonzero(state == 0)[0])]
        candidates = candidates[: bnb.root_strong if self.nodes == 1 else bnb.strong]
        top = min(b, self.best_val)
        if bnb.lam_branching and top - nb > LAM_SPLIT_TOL * max(1.0, abs(top)):
            candidates.append(("lam", 0.5 * (max(nb, a) + top)))  # bisect [nb, top]
        chosen, chosen_key, fixed = None, -np.inf, False
        for branch in candidates:
            if bnb.deadline.expired():
                break
            kids, found = bnb._children(branch, state, a, b, nb, v, basis)
            for sol in found:
                self.offer(sol, nb)
            alive = [k for k in kids if k[0] < self.best_val - self.tol()]
            if not alive:  # both children pruned: so is this node
                return "closed", None
            if len(alive) == 1 and not isinstance(branch, tuple) and alive[0][4] is not None:
                node[:] = [max(nb, alive[0][0]), *alive[0][1:]]  # a domain reduction: the node is the alive child
                nb, state, a, b, v, basis = node
                bnb.fixings += 1
                fixed, chosen = True, None
                continue
            key = min(k[0] for k in kids) + 1e-3 * max(k[0] if np.isfinite(k[0]) else 0.0 for k in kids)
            if key > chosen_key:
                chosen, chosen_key = (kids, branch), key
        return ("fixed" if fixed else "chosen"), chosen

    def close_by_pattern(self, node: list) -> bool:
        """A node whose LP point satisfies complementarity on its free pairs: its pattern's polish is exact; the
        node is closed when its bound meets that point (or no pair is free)."""
        bnb = self.bnb
        nb, state, _, _, v, _ = node
        free = state == 0
        z, s = v[bnb.layout.z], -(bnb.form.pair_matrix @ v[bnb.layout.x])
        leaf = state.copy()
        leaf[free] = np.where((z > s)[free], 1, -1)
        sol = bnb.polish(leaf == 1)
        self.offer(sol, nb)
        if (sol is not None and sol.multiplier - nb <= PRUNE_TOL * max(1.0, abs(sol.multiplier))) or not free.any():
            bnb.unproven_closures += int(sol is None)
            return True
        return False

    def finish(self) -> MIPRun:
        """The run's record: ``OPTIMAL`` when the heap is exhausted or its bound met the incumbent."""
        bnb = self.bnb
        status = Status.TIME_LIMIT if self.heap and bnb.deadline.expired() else Status.OPTIMAL
        if not self.heap:  # every node closed (the bound is the incumbent's) or the best one met it
            bound = self.best_val if self.met is None else self.met
        else:
            bound = min(min(entry[0] for entry in self.heap), self.best_val)
        return self.run(status, f"complementarity B&B: {self.nodes} nodes, {bnb.n_lps} LPs, {bnb.lam_splits} lam "
                        f"splits, {bnb.fixings} fixings, {bnb.interior_nodes} interior-point node LPs, "
                        f"{int(bnb.dormant.sum())} dormant rows ({bnb.woken} woken)", bound, self.nodes)
