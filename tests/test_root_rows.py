"""``milp``'s root LP by row generation (``root_lp="ipm-rows"``, issue 12): every round's LP is a relaxation of
the lifted LP (a certified minimiser, lifted, satisfies each of its rows), no round's dual bound exceeds the
certified minimum, and the certified values are those of ``root_lp="ipm"``."""


import numpy as np
import pytest
import scipy.sparse as sp
from milp_runs import milp_solver, solve_milp

import blockmpec as bm
from blockmpec.deadline import Deadline
from helpers import CERTIFIED_TOL, margin

WALLS = {"2x2": (2, 2), "3x2": (3, 2)}


def _wall(spec):
    return bm.cases.wall(*WALLS.get(spec, tuple(int(k) for k in spec.split("x"))), mu=0.65)


def _certified(spec, root_lp):
    res = solve_milp(_wall(spec), engine="bnb", lifting="rlt-full", root_lp=root_lp, time_limit=60)
    assert res.status is bm.Status.OPTIMAL, res.message
    assert abs(res.multiplier - res.extra[bm.facts.BOUND]) <= margin(CERTIFIED_TOL, res.multiplier)
    return res


def _rows_bnb(spec):
    """(solver in per-block units, ComplementarityBnB with root_lp="ipm-rows" at the root pattern)."""
    solver = milp_solver(engine="bnb", lifting="rlt-full", root_lp="ipm-rows")
    solver.setup(bm.operators.assemble(_wall(spec)))
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(60)))
    bnb.deadline = Deadline(60)
    bnb.apply_node(bnb.root, bnb.lam_lower, np.inf)
    return solver, bnb


def _within(M, v, lower, upper, tol):
    r = M @ v
    return bool(np.all(r >= lower - tol) and np.all(r <= upper + tol))


@pytest.mark.slow
@pytest.mark.parametrize("spec", list(WALLS))
def test_every_generated_lp_holds_at_the_lifted_minimiser_and_bounds_below_it(spec):
    """Without an incumbent the rounds run until no left-out row is violated: the last LP solved (a subset of
    the lifted LP's rows) and the node LP left behind (its left-out copy pair rows free) hold at the lifted
    certified minimiser, each round's bound lies below the minimum, and the last one is the minimum (the lifted
    LP's root bound on these walls)."""
    res = _certified(spec, "ipm")
    solver, bnb = _rows_bnb(spec)
    form = solver.form
    w = form.pack(solver.scaled(res.solution))
    v = bnb.layout.lift(w[form.lam], w[form.x], w[form.u], w[form.z])
    lam = float(w[form.lam])
    lp = bnb.h.getLp()
    rl, ru = np.asarray(lp.row_lower_), np.asarray(lp.row_upper_)
    bound = bnb.generated_root()
    tol = 1e-7 * max(1.0, float(np.abs(v).max()))
    A = sp.csr_array(bnb.lifted_matrix)
    kept = bnb.root_lp_rows
    assert 0 < kept.sum() < A.shape[0]  # a strict subset: some rows were never needed
    assert _within(A[kept], v, rl[kept], ru[kept], tol)
    after = bnb.h.getLp()
    assert bnb.dormant.any()
    assert np.all(np.asarray(after.row_upper_)[bnb.dormant] == np.inf)
    assert _within(A, v, np.asarray(after.row_lower_), np.asarray(after.row_upper_), tol)
    assert np.all(v >= np.asarray(after.col_lower_) - tol) and np.all(v <= np.asarray(after.col_upper_) + tol)
    rounds = bnb.root_rounds
    assert len(rounds) >= 2 and rounds[0]["rows"] < rounds[-1]["rows"] and rounds[-1]["added"] == 0
    bounds = [r["bound"] for r in rounds]
    assert all(b <= lam + margin(CERTIFIED_TOL, lam) for b in bounds)
    assert bounds == sorted(bounds) and bounds[-1] == bound
    assert abs(bound - lam) <= margin(1e-6, lam)


@pytest.mark.slow
@pytest.mark.parametrize("spec", ["2x2", "3x2", "2x4"])
def test_row_generation_certifies_the_same_minimum(spec):
    """Side by side with the interior point on the whole root LP: the same certified multiplier, and the trace's
    bounds (one per round) never above it."""
    whole, rows = _certified(spec, "ipm"), _certified(spec, "ipm-rows")
    assert abs(rows.multiplier - whole.multiplier) <= margin(CERTIFIED_TOL, whole.multiplier)
    search = [t["bound"] for t in rows.trace if t.get("stage") == "search" and t["bound"] is not None]
    assert search and all(b <= rows.multiplier + margin(CERTIFIED_TOL, rows.multiplier) for b in search)
