"""``milp``'s certificate against a textbook big-M MILP of (4) on HiGHS (issue 41, items 4 and 5).

Issue 41 asks that ``milp``'s automatic engine certify every structure that a textbook big-M MILP of the MPEC (4)
on HiGHS certifies within the same time limit, and names its test structures: the 3-course running-bond wall of
1 x 0.5 blocks, 3 per course, with the bottom course's middle block left out as a door (9 free blocks), at mu 0.65
and 0.8, and Ferris & Tin-Loi's wall 1 (the built-in case ``ferris-tinloi``, 33 blocks) in 10 minutes.

Configurations (``--configs``):

* ``milp``: ``bm.solve(structure, "milp", time_limit=T)``, the defaults (``engine="auto"``);
* ``textbook``: the textbook big-M MILP of (4) with a *valid* big-M, in the normalisation ``milp`` uses
  (``1^T z = 1``, so ``0 <= z_i <= 1`` exactly): ``min lam`` s.t. equilibrium, compatibility, ``1^T z = 1``,
  ``tau = f_l^T u >= 0``, ``G w <= 0``, ``z_i <= y_i``, ``s_i <= M_i (1 - y_i)``, ``y`` binary, with ``M_i`` the
  LP-proven maximum of the slack ``s_i`` over the statically admissible set (``milp``'s bound LPs, widened), HiGHS
  branch and cut on one thread at ``milp``'s gaps (1e-9).  No cut of ``milp``'s (work identity, dead-work,
  sliding direction, multiplier bounds), no incumbent.  ``tau >= 0`` makes it a relaxation, so its dual bound is
  valid; it certifies when its optimum's pattern admits a mechanism with ``tau > 0`` and the exact point of that
  pattern meets the bound within 1e-7 (``milp``'s ``CERTIFICATE_TOL``).  Its time includes the bound LPs;
* ``textbook-guess``: the same in the paper's own normalisation ``f_l^T u = 1`` with one *guessed* ``M`` (``--bigm``,
  default 100) on slacks and multipliers (a model whose big-M is a guess).  Its ``M`` is not proven, so it
  never certifies anything; it is measured only because issue 41 quotes such a model ("certifies both door walls in
  13-161 s"; measured here: neither in 300 s).

Every run reports its lower bound and its best verified point at the stop.  Run one configuration at a time on a
quiet machine and note the load (``uptime``): the times are wall seconds.

    nice python studies/lab/certificate_vs_textbook.py --cases door:0.65,door:0.8 --configs milp,textbook --time-limit 300
    nice python studies/lab/certificate_vs_textbook.py --cases ferris-tinloi --configs milp --time-limit 600
    nice python studies/lab/certificate_vs_textbook.py --cases 2x2,3x2,3x2s,6x2s,arch:8,door:0.65 --time-limit 60

Writes ``studies/output/certificate_vs_textbook.csv`` and prints a markdown table.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.formulations.mpec_milp import MixedIntegerMPEC
from blockmpec.solvers.engines.mip import solve_highs
from blockmpec.solvers.milp import CERTIFICATE_TOL, MILPSettings, MILPSolver
from blockmpec.verify import residuals

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "certificate_vs_textbook.csv"
COLUMNS = ["case", "blocks", "config", "status", "certified", "incumbent", "bound", "gap_rel", "nodes", "time_s",
           "load", "note"]


def door_wall(mu: float) -> bm.Structure:
    """Issue 41's door wall: 3 courses of 1 x 0.5 blocks in running bond, 3 per course (half blocks at the ends of
    the middle course), the bottom course's middle block left out: 9 free blocks."""
    wall = bm.cases.wall(courses=3, blocks_per_course=3, block_length=1.0, block_height=0.5,
                         openings=[(1.0, 0.0, 2.0, 0.5)], mu=mu)
    assert wall.n_free == 9, wall.n_free
    return wall


def case(spec: str) -> bm.Structure:
    """``door:MU`` (issue 41's door wall), ``ferris-tinloi``, ``side`` (the 3x3 stack wall whose middle block hangs on
    side friction: (3) has no solution), ``two:ETA:MU`` (two blocks), ``CxB`` running-bond / ``CxBs`` stack wall
    (mu 0.65), ``arch:N`` round arch of N voussoirs."""
    if spec.startswith("door:"):
        return door_wall(float(spec.split(":")[1]))
    if spec == "side":
        return bm.cases.wall(3, 3, bond="stack", openings=[(1.0, 0.0, 2.0, 0.5)], mu=0.65)
    if spec.startswith("two:"):
        _, eta, mu = spec.split(":")
        return bm.cases.two_blocks(eta=float(eta), mu=float(mu))
    if spec == "ferris-tinloi":
        return bm.cases.build_case("ferris-tinloi")
    if spec.startswith("arch:"):
        return bm.cases.round_arch(n_voussoirs=int(spec.split(":")[1]))
    bond = "stack" if spec.endswith("s") else "running"
    courses, blocks = (int(v) for v in spec.rstrip("s").split("x"))
    return bm.cases.wall(courses, blocks, bond=bond, mu=0.65)


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def run_milp(structure: bm.Structure, time_limit: float) -> dict:
    res = bm.solve(structure, "milp", time_limit=time_limit)
    bound = res.extra.get(bm.facts.BOUND)
    return {"status": res.status.value, "certified": res.status is bm.Status.OPTIMAL and res.verified,
            "incumbent": res.multiplier if res.verified else None, "bound": bound,
            "gap_rel": res.extra.get(bm.facts.GAP_REL), "nodes": res.extra.get("nodes"), "time_s": res.solve_time_s,
            "note": res.message[:160]}


def textbook_model(form, bigm: np.ndarray | float, normalisation: str) -> MixedIntegerMPEC:
    """The textbook big-M MILP of (4) on the compiled (3) ``form`` (module docstring): ``normalisation="sum"``:
    ``1^T z = 1``, ``f_l^T u >= 0``, ``z_i <= y_i``; ``"live"``: ``f_l^T u = 1``, ``z_i <= M y_i``."""
    nw, npair = form.n_columns, form.n_pairs
    n = nw + npair
    y = np.arange(nw, n)
    zc = form.pair_column
    M = np.broadcast_to(np.asarray(bigm, float), (npair,))
    pad = sp.csr_array((form.A.shape[0], npair))
    A = sp.hstack([form.A, pad]).tocsr()
    rl, ru = form.rhs.copy(), form.rhs.copy()
    if normalisation == "sum":  # the normalisation row f_l^T u = 1 becomes tau = f_l^T u >= 0, and 1^T z = 1 is added
        rl[form.normalisation], ru[form.normalisation] = 0.0, np.inf
        total = sp.csr_array((np.ones(npair), (np.zeros(npair, int), zc)), shape=(1, n))
        A = sp.vstack([A, total]).tocsr()
        rl, ru = np.r_[rl, 1.0], np.r_[ru, 1.0]
        zmax = np.ones(npair)
    else:
        zmax = M
    G = sp.hstack([form.G, sp.csr_array((npair, npair))]).tocsr()
    ey = sp.hstack([sp.csr_array((npair, nw)), sp.eye_array(npair)]).tocsr()
    Z = sp.csr_array((np.ones(npair), (np.arange(npair), zc)), shape=(npair, n)) - sp.diags_array(zmax) @ ey
    S = -G + sp.diags_array(M) @ ey
    col_lower, col_upper = np.full(n, -np.inf), np.full(n, np.inf)
    col_lower[zc] = 0.0
    col_lower[y], col_upper[y] = 0.0, 1.0
    c = np.zeros(n)
    c[form.lam] = 1.0
    integer = np.zeros(n, dtype=bool)
    integer[y] = True
    return MixedIntegerMPEC(c=c, A=sp.vstack([A, G, Z, S]).tocsr(), col_lower=col_lower, col_upper=col_upper,
                            row_lower=np.concatenate([rl, np.full(3 * npair, -np.inf)]),
                            row_upper=np.concatenate([ru, np.zeros(2 * npair), M]), columns={"y": y}, rows={},
                            objective_sign=1.0, integer=integer, bigm=M)


def run_textbook(structure: bm.Structure, time_limit: float, guess: float | None = None) -> dict:
    """The textbook model (``guess``: the unproven live-normalisation variant with ``M = guess``) on HiGHS; its
    pattern polished by ``milp``'s exact piece LPs."""
    solver = MILPSolver(settings=MILPSettings(heuristic="", incumbent=False))
    solver.setup(bm.operators.assemble(structure))
    t0 = time.perf_counter()
    deadline = Deadline(time_limit)
    form, unit = solver.form, solver.lam_unit
    if guess is None:
        bd = solver.model_bounds(solver.root_bounds(deadline), deadline)  # LP-proven slack bounds
        mip = textbook_model(form, bd.slack_max, "sum")
    else:
        mip = textbook_model(form, guess, "live")
    run = solve_highs(mip, deadline, rel_gap=1e-9, abs_gap=1e-9, feasibility_tol=1e-9, threads=1)
    elapsed = time.perf_counter() - t0
    bound = float(run.dual_bound) * unit
    row = {"status": run.status.value, "certified": False, "incumbent": None, "bound": bound, "nodes": run.nodes,
           "time_s": elapsed, "gap_rel": None, "note": ""}
    if run.point is None:
        return row
    sol, message = solver.polish(run.point[mip.columns["y"]] >= 0.5)
    if sol is None:
        row["note"] = f"the optimum's pattern has no point of (3) ({message})"
        return row
    lam = sol.multiplier * unit
    res = residuals(solver.ops, solver.unscaled(sol), associative=False)
    verified = max(res.values()) <= 1e-6
    row["incumbent"] = lam if verified else None
    row["gap_rel"] = max(0.0, lam - bound) / max(abs(lam), 1e-12)
    tol = CERTIFICATE_TOL * max(1.0, abs(lam))
    if guess is not None:
        row["note"] = f"M = {guess:g} guessed: no certificate"
    elif run.status is bm.Status.OPTIMAL and verified and -tol <= lam - bound <= tol + 1e-9 * abs(lam):
        row["certified"] = True
    return row


def fmt(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.7g}"
    return str(value)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", default="door:0.65,door:0.8")
    p.add_argument("--configs", default="milp,textbook")
    p.add_argument("--time-limit", type=float, default=300.0)
    p.add_argument("--bigm", type=float, default=100.0, help="M of textbook-guess")
    args = p.parse_args(argv)
    rows = []
    for spec in args.cases.split(","):
        structure = case(spec)
        for config in args.configs.split(","):
            load = _load()
            if config == "milp":
                row = run_milp(structure, args.time_limit)
            elif config == "textbook":
                row = run_textbook(structure, args.time_limit)
            elif config == "textbook-guess":
                row = run_textbook(structure, args.time_limit, guess=args.bigm)
            else:
                raise SystemExit(f"unknown config {config!r}: milp | textbook | textbook-guess")
            row.update(case=spec, blocks=structure.n_free, config=config, load=load)
            rows.append(row)
            print(" | ".join(fmt(row.get(c)) for c in COLUMNS), flush=True)
    path = write_csv(OUT, rows, COLUMNS)
    print("| " + " | ".join(COLUMNS) + " |\n|" + "---|" * len(COLUMNS))
    for row in rows:
        print("| " + " | ".join(fmt(row.get(c)) for c in COLUMNS) + " |")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
