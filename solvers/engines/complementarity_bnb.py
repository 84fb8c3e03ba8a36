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

so (W) becomes the *linear* ``lam = -f_d^T u + sum_e B_e x^(i_e)_{r_e}``.  Together with
compatibility, ``f_l^T u = 1``, ``z >= 0`` and the static part ``E x + lam f_l + f_d = 0``,
``G x <= 0``, every solution of (3) gives a feasible point, so the LP minimum of ``lam``
is a lower bound.  (At the root it equals the conditional-OBBT bound
:meth:`~blockmpec.solvers.milp.MILPSolver._dissipation_minimum`.)

Branching on a pair ``j`` splits the solutions of (3) exactly (no big-M):

* ``active``: ``s_j = 0``, so ``G_j x = 0`` and ``G_j x^(i) = -s_j z_i = 0`` in *every* copy
  (this is where the copies couple: a sliding joint forces its friction rows tight in the
  static field of every other sliding pair, and the friction work bound moves);
* ``inactive``: ``z_j = 0`` (so the copy ``j`` vanishes: ``zeta_j = 0``).

A node whose pairs are all fixed (a leaf) is one pattern: its minimum is the exact
polish of the pattern (:meth:`MILPSolver._polish`).  Nodes are explored best-bound first;
the LP is warm-started from the previous node (HiGHS re-solves after bound changes).  An
LP that is not optimal never prunes (its node keeps the parent's bound); an infeasible
LP is confirmed by a cold re-solve before the node is pruned.  Branching picks the
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

from blockmpec.result import Status
from blockmpec.solvers.engines.mip import MIPRun, _Tracer

#: a node is pruned when its bound is within this (times max(1, |incumbent|)) of the incumbent
PRUNE_TOL = 1e-9
#: complementarity violation below which a pair of the LP point counts as satisfied
VIOLATION_TOL = 1e-9


@dataclass
class _Layout:
    n: int
    lam: int
    x: slice
    u: slice
    z: slice
    copies: list  # per copy: (pair i, x-slice, zeta column)
    static_pair_rows: np.ndarray  # row of G_j x in the static block, per pair j
    copy_pair_rows: dict  # pair j -> rows of G_j x^(i) over copies
    zeta_upper_rows: np.ndarray  # rows zeta_i - lam_upper z_i <= 0, per copy


def lifted_lp(form, B: sp.coo_array, lam_lower: float, lam_upper: float, slack_max: np.ndarray | None = None):
    """The lifted relaxation's matrices: (A, row_lower, row_upper, col_lower, col_upper, c, layout)."""
    nx = form.x.stop - form.x.start
    nu = form.u.stop - form.u.start
    npair = form.n_pairs
    E = form.block(form.equilibrium, form.x)
    f_l, f_d = form.f_l, form.f_d
    Gx = form.pair_matrix
    Ecomp = form.block(form.compatibility, form.u)
    F = form.block(form.compatibility, form.z)
    pairs = np.unique(B.col)
    # columns: lam | x | u | z | (x^(i), zeta_i) per copy
    lam, xs = 0, slice(1, 1 + nx)
    us = slice(xs.stop, xs.stop + nu)
    zs = slice(us.stop, us.stop + npair)
    col = zs.stop
    copies = []
    for i in pairs:
        copies.append((int(i), slice(col, col + nx), col + nx))
        col += nx + 1
    n = col
    blocks, lo, hi = [], [], []

    def add(M, lower, upper):
        M = sp.csr_array(M)
        blocks.append(M)
        lo.append(np.broadcast_to(np.asarray(lower, float), (M.shape[0],)))
        hi.append(np.broadcast_to(np.asarray(upper, float), (M.shape[0],)))
        return np.arange(sum(b.shape[0] for b in blocks) - M.shape[0], sum(b.shape[0] for b in blocks))

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
    zeta_upper_rows = []
    identity = column([1.0], lam) - place(-f_d.reshape(1, -1), us.start)  # lam + f_d^T u - sum B p = 0
    for i, xi, zeta in copies:
        add(place(E, xi.start) + column(f_l, zeta) + column(f_d, zs.start + i), 0.0, 0.0)
        rows = add(place(Gx, xi.start), -np.inf, 0.0)
        for j in range(npair):
            copy_pair_rows[j].append(rows[j])
        if slack_max is not None:
            # s_j z_i <= slack_max_j z_i:  -G x^(i) - slack_max z_i <= 0
            add(place(-Gx, xi.start) - column(slack_max, zs.start + i), -np.inf, 0.0)
        # lam_lower z_i <= zeta_i <= lam_upper z_i
        add(column([1.0], zeta) - column([lam_lower], zs.start + i), 0.0, np.inf)
        zeta_upper_rows.append(add(column([1.0], zeta) - column([lam_upper], zs.start + i), -np.inf, 0.0)[0])
    for e in range(B.nnz):
        i, r = int(B.col[e]), int(B.row[e])
        xi = next(c[1] for c in copies if c[0] == i)
        identity = identity - sp.csr_array(([B.data[e]], ([0], [xi.start + r])), shape=(1, n))
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
                     {j: np.array(r, dtype=int) for j, r in copy_pair_rows.items()}, np.array(zeta_upper_rows))
    # the equality rows of the pairs fixed active on S (slack_max = 0) are set by the caller
    return A, np.concatenate(lo), np.concatenate(hi), col_lower, col_upper, c, layout


class ComplementarityBnB:
    """Best-bound branch and bound over the pairs; see the module docstring.

    ``polish(active) -> Solution | None`` gives the exact point (and leaf value) of a pattern.
    """

    def __init__(self, form, B, lam_lower, lam_upper, polish, fixed_active=None, fixed_idle=None, strong=4,
                 slack_max=None):
        import highspy

        A, rl, ru, cl, cu, c, layout = lifted_lp(form, B, lam_lower, lam_upper, slack_max)
        self.form, self.B, self.layout, self.polish = form, B, layout, polish
        self.rl0, self.ru0, self.cl0, self.cu0 = rl, ru, cl, cu
        h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("primal_feasibility_tolerance", 1e-10)
        h.setOptionValue("dual_feasibility_tolerance", 1e-10)
        lp = highspy.HighsLp()
        Ac = A.tocsc()
        lp.num_col_, lp.num_row_ = Ac.shape[1], Ac.shape[0]
        lp.col_cost_, lp.col_lower_, lp.col_upper_ = c, cl, cu
        lp.row_lower_, lp.row_upper_ = rl, ru
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = Ac.indptr, Ac.indices, Ac.data
        h.passModel(lp)
        self.h = h
        npair = form.n_pairs
        self.root = np.zeros(npair, dtype=np.int8)  # 0 free, 1 active, -1 inactive
        if fixed_active is not None:
            self.root[fixed_active] = 1
        if fixed_idle is not None:
            self.root[fixed_idle & (self.root == 0)] = -1
        self.n_lps = 0
        self.last_basis = None
        self.strong = max(1, int(strong))
        self.lam_cap = float(lam_upper)

    def _apply(self, state: np.ndarray) -> None:
        lay, h = self.layout, self.h
        rows = np.concatenate([lay.static_pair_rows] + [lay.copy_pair_rows[j] for j in range(state.size)])
        active_rows = np.concatenate([lay.static_pair_rows[state == 1]]
                                     + [lay.copy_pair_rows[j] for j in np.flatnonzero(state == 1)])
        lower = np.full(rows.size, -np.inf)
        h.changeRowsBounds(rows.size, rows.astype(np.int32), lower, np.zeros(rows.size))
        if active_rows.size:
            h.changeRowsBounds(active_rows.size, active_rows.astype(np.int32), np.zeros(active_rows.size),
                               np.zeros(active_rows.size))
        zc = np.arange(lay.z.start, lay.z.stop, dtype=np.int32)
        h.changeColsBounds(zc.size, zc, np.zeros(zc.size), np.where(state == -1, 0.0, np.inf))

    def _node_lp(self, state: np.ndarray):
        """(status, bound, point) of the node LP; infeasibility confirmed by a cold re-solve."""
        from blockmpec.solvers.engines.highs import highs_status

        self._apply(state)
        self.h.run()
        self.n_lps += 1
        st, _ = highs_status(self.h)
        if st is Status.INFEASIBLE:
            self.h.clearSolver()
            self.h.run()
            self.n_lps += 1
            st, _ = highs_status(self.h)
        if st is not Status.OPTIMAL:
            return st, None, None
        v = np.asarray(self.h.getSolution().col_value, float)
        self.last_basis = self.h.getBasis()
        return st, float(self.h.getInfo().objective_function_value), v

    def _restrict_to_improvements(self, best_val: float) -> None:
        """Only points with ``lam <= best_val`` can improve the incumbent: ``lam <= best_val`` and
        ``zeta_i <= best_val z_i`` (valid for every such point; the incumbent itself is kept apart)."""
        if not np.isfinite(best_val) or best_val >= self.lam_cap:
            return
        self.lam_cap = best_val
        lay = self.layout
        self.h.changeColBounds(lay.lam, self.cl0[lay.lam], best_val)
        for (i, _, _), row in zip(lay.copies, lay.zeta_upper_rows):
            self.h.changeCoeff(int(row), int(lay.z.start + i), -best_val)

    def _candidates(self, state: np.ndarray, v: np.ndarray) -> list[int]:
        """Free pairs violated at the LP point, most violated first (complementarity + work defect)."""
        lay, form = self.layout, self.form
        x = v[lay.x]
        z = v[lay.z]
        s = -(form.pair_matrix @ x)
        score = np.maximum(z, 0.0) * np.maximum(s, 0.0)
        for e in range(self.B.nnz):
            i, r = int(self.B.col[e]), int(self.B.row[e])
            xi = next(c[1] for c in lay.copies if c[0] == i)
            score[i] += abs(self.B.data[e] * (v[xi.start + r] - z[i] * x[r]))
        score[state != 0] = -1.0
        order = np.argsort(-score)
        return [int(j) for j in order if score[j] > VIOLATION_TOL]

    def solve(self, time_limit: float, incumbent=None, t0: float | None = None, sign: float = 1.0) -> tuple:
        """Returns (MIPRun in lam units, best Solution or None)."""
        t0 = time.perf_counter() if t0 is None else t0
        deadline = time.perf_counter() + time_limit
        tracer = _Tracer(1.0, t0)
        best = incumbent
        best_val = incumbent.multiplier if incumbent is not None else np.inf
        self._restrict_to_improvements(best_val)
        st, bound, v = self._node_lp(self.root)
        if st is Status.INFEASIBLE:
            if best is not None:  # nothing has lam <= the incumbent's value but the incumbent: optimal
                tracer.record(best_val, best_val, force=True)
                return MIPRun(Status.OPTIMAL, "optimal", "root LP infeasible below the incumbent", None, best_val,
                              best_val, 1, time.perf_counter() - t0, tracer.records), best
            return MIPRun(Status.INFEASIBLE, "infeasible", "root LP infeasible", None, np.inf, np.inf, 1,
                          time.perf_counter() - t0, tracer.records), best
        if st is not Status.OPTIMAL:
            return MIPRun(Status.ERROR, st.value, f"root LP {st.value}", None, best_val, -np.inf, 1,
                          time.perf_counter() - t0, tracer.records), best
        heap = [(bound, 0, self.root.copy(), v, self.last_basis)]
        counter, nodes = 1, 0
        global_bound = bound
        status = Status.OPTIMAL
        while heap:
            global_bound = min(entry[0] for entry in heap)
            tracer.record(global_bound, best_val)
            if best_val - global_bound <= PRUNE_TOL * max(1.0, abs(best_val)):
                global_bound = min(global_bound, best_val)
                break
            if time.perf_counter() > deadline:
                status = Status.TIME_LIMIT
                break
            self._restrict_to_improvements(best_val)
            nb, _, state, v, basis = heapq.heappop(heap)
            nodes += 1
            if nb >= best_val - PRUNE_TOL * max(1.0, abs(best_val)):
                continue
            # an incumbent from the node's LP pattern
            z, s = v[self.layout.z], -(self.form.pair_matrix @ v[self.layout.x])
            active = np.where(state == 0, z > s, state == 1)
            sol = self.polish(active)
            if sol is not None and sol.multiplier < best_val:
                best, best_val = sol, sol.multiplier
                tracer.record(min(nb, best_val), best_val, force=True)
            candidates = self._candidates(state, v)
            if not candidates:
                # the LP point satisfies complementarity on the free pairs: its pattern's polish is exact
                free = state == 0
                leaf = state.copy()
                leaf[free] = np.where(active[free], 1, -1)
                sol = self.polish(leaf == 1)
                if sol is not None and sol.multiplier < best_val:
                    best, best_val = sol, sol.multiplier
                # a node without violation is closed by its pattern only if its bound meets it
                if sol is not None and sol.multiplier - nb <= PRUNE_TOL * max(1.0, abs(sol.multiplier)):
                    continue
                if not free.any():
                    continue
                candidates = [int(np.flatnonzero(free)[0])]
            # strong branching: both children of each candidate, keep the pair whose weaker child is best
            chosen, chosen_key = None, -np.inf
            for j in candidates[: self.strong]:
                kids = []
                for val in (1, -1):
                    child = state.copy()
                    child[j] = val
                    if not (child == 0).any():
                        sol = self.polish(child == 1)
                        if sol is not None and sol.multiplier < best_val:
                            best, best_val = sol, sol.multiplier
                        kids.append((np.inf, child, None, None))
                        continue
                    if basis is not None:
                        self.h.setBasis(basis)  # warm start from the parent's optimal basis
                    cst, cb, cv = self._node_lp(child)
                    if cst is Status.INFEASIBLE:
                        kids.append((np.inf, child, None, None))
                    elif cst is not Status.OPTIMAL:
                        kids.append((nb, child, v, basis))  # keeps the parent's bound, never prunes
                    else:
                        kids.append((max(cb, nb), child, cv, self.last_basis))
                key = min(k[0] for k in kids) + 1e-3 * max(k[0] if np.isfinite(k[0]) else 0.0 for k in kids)
                if key > chosen_key:
                    chosen, chosen_key = kids, key
            for cb, child, cv, cbasis in chosen:
                if cv is not None and cb < best_val - PRUNE_TOL * max(1.0, abs(best_val)):
                    heapq.heappush(heap, (cb, counter, child, cv, cbasis))
                    counter += 1
        else:
            global_bound = best_val
        if status is Status.OPTIMAL and heap:
            global_bound = min(min(entry[0] for entry in heap), best_val)
        tracer.record(global_bound, best_val, force=True)
        point = None
        return MIPRun(status, status.value, f"complementarity B&B: {nodes} nodes, {self.n_lps} LPs", point,
                      best_val, global_bound, nodes, time.perf_counter() - t0, tracer.records), best
