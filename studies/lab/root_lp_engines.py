"""Engines and liftings for the root LP of ``milp``'s branch and bound (issue 12's 30-50-block target): a recorded
negative result.

The 30-block running-bond walls are not certified because the root's lifted LP (``lifting="rlt-full"``, 166,078 rows
on the 2x15 wall) is not solved in 10 minutes by HiGHS's IPX, the interior point ``root_lp="ipm"`` runs.  This study
asks whether another interior point, an IPX setting or a smaller lifting would do it.

Part 1 (``--engines``): the same root LP (the root's bounds applied, every row) by each engine, one after the other in
one process: CPU seconds and the dual bound of :func:`~blockmpec.solvers.engines.complementarity_bnb.dual_bound` from
its row duals (the bound ``milp`` would use; ``-inf``: none), and ``open_reduced_cost``, the largest reduced cost
those duals leave towards an open column bound (:func:`~blockmpec.solvers.engines.complementarity_bnb.open_reduced_cost`:
above ``LP_TOL`` = 1e-9 the bound is ``-inf`` unless its least-squares correction repairs it).  Engines:

* ``ipx``: HiGHS's IPX without crossover on the lifted LP, what ``root_lp="ipm"`` ran before the null-space
  coordinates (``root_lp="ipm-lifted"`` now);
* ``ipx-null-space``: the same LP in null-space coordinates (:mod:`blockmpec.solvers.linalg.null_space`:
  equilibrium and compatibility solved once, ``W = x u^T`` and every copy's equilibrium rows gone), by IPX
  without crossover at feasibility tolerances ``NULL_SPACE_IPM_TOL``: what ``root_lp="ipm"`` runs now;
  ``ipx-null-space-cycles``: the same with the short-cycle basis of self-stresses (``basis="cycles"``);
  ``ipx-null-space-crossover``: the null-space LP by IPX *with* crossover, the optimal basis a search by warm dual
  simplex node LPs would start from (its cost is the question; 6x3 wall: see the README's taller walls).  Measured
  (``--engines 2x4,5x2,4x3,2x8 --only ipx,ipx-null-space``, one run, CPU s, lifted against null-space):
  see the README's root-LP section;
* ``ipx-presolve-off``, ``ipx-tol-1e-4``: IPX with HiGHS's presolve off / ``ipm_optimality_tolerance=1e-4``;
* ``ipx-primal``, ``ipx-filippo``: IPX on the primal LP (``ipx_dualize_strategy=-1``; by default IPX solves this LP's
  dual, whose starting basis costs most of the 2x15 run) / with IPX's other dualisation test (3), which here also picks
  the primal.  Measured (one run, CPU s): 5x2 8.1 against 11.7, 4x3 25.4 against 35.2, 2x8 33.9 against 56.2, same
  bounds: the primal LP is slower.  On 2x13 (124,564 rows), where the dual's starting basis is costliest, the primal
  LP also hits a 600 s limit without a bound (588 s CPU; ``--engines 2x13 --only ipx-primal --time-limit 600``);
* ``hipo``: HiGHS's newer interior point (needs the wheel ``highspy-extras``; without it HiGHS silently runs
  another solver, so the study refuses to run it);
* ``hipo-augmented``, ``hipo-normaleq``: HiPO with its Newton system forced (``hipo_system``).  On 2x8 (one run,
  CPU s of the process, ``--engines 2x8 --only ipx,hipo-augmented,hipo-normaleq,clarabel-faer --time-limit 300``):
  IPX 35.1 s, bound 0.6499999953; HiPO augmented 76.5 s, "unknown", 0.64986; normal equations 84.2 s, "unknown",
  0.64784; Clarabel with faer 110 s, 0.6499999999994 (112 s with its default solver in an earlier run);
* ``clarabel``: Clarabel (pip ``clarabel``, Apache-2.0; not a dependency of blockmpec) on the LP as a conic
  problem (equality rows a zero cone, the rest a nonnegative cone) at tolerances 1e-10 and static regularisation
  1e-7 (with its defaults it ends "NumericalError" within 3 iterations on the 3x2 wall's LP); ``clarabel-faer``:
  the same with ``direct_solve_method="faer"`` (a supernodal LDL^T) instead of its default.

Part 2 (``--liftings``): the root LP of each ``lifting`` by IPX: rows, CPU seconds, dual bound; which products the
bound needs.

Part 3 (``--profile``): where IPX spends its time on one root LP (``--lifting``, default ``rlt``: the LP the root
solves first, which certifies the two-course walls): IPX's own log (written to ``studies/output/root_lp_engines/``),
summarised as the seconds spent constructing IPX's starting basis (from the last iteration before it to the first after
it, so one iteration included), the iterations and seconds after it, and the last iteration's gap.

    python studies/lab/root_lp_engines.py --engines 5x2,4x3 --time-limit 300
    python studies/lab/root_lp_engines.py --liftings 2x8
    python studies/lab/root_lp_engines.py --profile 2x8,2x15 --time-limit 650
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _clarabel import ClarabelProblem  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "root_lp_engines"
ENGINES = ("ipx", "ipx-null-space", "ipx-null-space-cycles", "ipx-null-space-crossover", "ipx-presolve-off", "ipx-tol-1e-4", "ipx-primal", "ipx-filippo", "hipo",
           "hipo-augmented", "hipo-normaleq", "clarabel", "clarabel-faer")
#: HiGHS options of each HiGHS engine (the interior point without crossover in every case)
HIGHS_ENGINES = {"ipx": ("ipx", {}), "ipx-presolve-off": ("ipx", {"presolve": "off"}),
                 "ipx-tol-1e-4": ("ipx", {"ipm_optimality_tolerance": 1e-4}),
                 # HiGHS's ipx_dualize_strategy: -1 never dualise, 2 (default) dualise when rows > 2 columns,
                 # 3 IPX's other test ("Filippo")
                 "ipx-primal": ("ipx", {"ipx_dualize_strategy": -1}),
                 "ipx-filippo": ("ipx", {"ipx_dualize_strategy": 3}), "hipo": ("hipo", {}),
                 # HiPO's Newton system forced: the augmented system (free columns need no regularised
                 # normal equations) or the normal equations
                 "hipo-augmented": ("hipo", {"hipo_system": "augmented"}),
                 "hipo-normaleq": ("hipo", {"hipo_system": "normaleq"})}
#: Clarabel's direct solver of each Clarabel engine
CLARABEL_ENGINES = {"clarabel": "auto", "clarabel-faer": "faer"}


def _emit(rows: list[dict], row: dict) -> None:
    """Print one result row as it arrives (a long run shows its progress) and keep it."""
    print(json.dumps(row), flush=True)
    rows.append(row)


def root_lp(spec: str, lifting: str = "rlt-full", null_space: str | None = None):
    """``(A, c, row_lower, row_upper, col_lower, col_upper)`` of the root's lifted LP of the wall ``spec``; with
    ``null_space`` (a basis of :data:`~blockmpec.solvers.linalg.null_space.BASES`) the same LP in the null-space
    coordinates that ``root_lp="ipm"`` solves (:mod:`blockmpec.solvers.linalg.null_space`, basis ``"tree"``)."""
    from blockmpec.deadline import Deadline
    from blockmpec.solvers.milp import MILPSettings, MILPSolver

    # the root of milp's branch and bound: its set-up, bounds and root LP (the milp module's own steps)
    solver = MILPSolver(engine="bnb", settings=MILPSettings(lifting=lifting, root_lp="ipm"))
    solver.setup(bm.operators.assemble(named_wall(spec)))
    bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(600)))
    bnb.apply_node(bnb.root, bnb.lam_lower, bnb.lam_cap)
    c, rl, ru, cl, cu = bnb.lp_arrays()
    if null_space:
        reduced = bnb.null_space_root_lp(c, rl, ru, cl, cu, basis=null_space)
        if reduced is None:
            raise SystemExit(f"{spec}: no null-space coordinates for lifting {lifting!r} (needs rlt-full)")
        return reduced.arrays
    return sp.csc_array(bnb.lifted_matrix), c, rl, ru, cl, cu


def highs_duals(lp, solver: str, options: dict, time_limit: float, crossover: bool = False):
    """Row duals of the LP by one of HiGHS's interior points, without crossover unless ``crossover`` (None if it
    gave none)."""
    from blockmpec.solvers.engines.highs import highs_lp, new_highs, use_interior_point

    A, c, rl, ru, cl, cu = lp
    h = new_highs()
    h.passModel(highs_lp(A, c, rl, ru, cl, cu))
    if solver == "hipo":
        try:
            import highspy_extras  # noqa: F401
        except ImportError:
            raise SystemExit("hipo needs the wheel highspy-extras (without it HiGHS silently runs another solver)")
    use_interior_point(h, crossover=crossover, solver=solver)
    h.setOptionValue("time_limit", time_limit)
    for name, value in options.items():
        h.setOptionValue(name, value)
    h.run()
    sol = h.getSolution()
    return (np.asarray(sol.row_dual, float) if sol.dual_valid else None), h.modelStatusToString(h.getModelStatus())


def clarabel_duals(lp, time_limit: float, direct_solve_method: str = "auto"):
    """Row duals of the LP by Clarabel (:class:`_clarabel.ClarabelProblem`, HiGHS's signs) at tolerances 1e-10 with
    static regularisation 1e-7, and its status name."""
    _, y, status, _ = ClarabelProblem(*lp).solve(
        time_limit=time_limit, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10,
        static_regularization_constant=1e-7,
        direct_solve_method=direct_solve_method)  # "faer": a supernodal LDL^T (Rust), on max_threads threads
    return y, status


def engines(walls: list[str], names: list[str], time_limit: float) -> list[dict]:
    from blockmpec.solvers.engines.complementarity_bnb import NULL_SPACE_IPM_TOL, dual_bound, open_reduced_cost

    rows = []
    for spec in walls:
        lifted = root_lp(spec)
        for name in names:
            lp = lifted
            if name.startswith("ipx-null-space"):  # not timed: its construction is part of milp's root (< 1 s)
                lp = root_lp(spec, null_space="cycles" if name.endswith("cycles") else "tree")
            cpu = time.process_time()
            if name in CLARABEL_ENGINES:
                y, status = clarabel_duals(lp, time_limit, CLARABEL_ENGINES[name])
            elif name.startswith("ipx-null-space"):
                tolerances = {"primal_feasibility_tolerance": NULL_SPACE_IPM_TOL,
                              "dual_feasibility_tolerance": NULL_SPACE_IPM_TOL}
                y, status = highs_duals(lp, "ipx", tolerances, time_limit, crossover=name.endswith("crossover"))
            else:
                solver, options = HIGHS_ENGINES[name]
                y, status = highs_duals(lp, solver, options, time_limit)
            cpu = time.process_time() - cpu
            bound = -np.inf if y is None else dual_bound(*lp, y)
            row = {"wall": spec, "rows": int(lp[0].shape[0]), "engine": name, "status": status, "cpu_s": cpu,
                   "bound": bound, "open_reduced_cost": None if y is None else open_reduced_cost(*lp, y)}
            _emit(rows, row)
    return rows


def liftings(walls: list[str], time_limit: float) -> list[dict]:
    from blockmpec.solvers.engines.complementarity_bnb import dual_bound
    from blockmpec.solvers.milp import LIFTINGS

    rows = []
    for spec in walls:
        for lifting in LIFTINGS:
            lp = root_lp(spec, lifting)
            cpu = time.process_time()
            y, status = highs_duals(lp, "ipx", {}, time_limit)
            cpu = time.process_time() - cpu
            row = {"wall": spec, "lifting": lifting, "rows": int(lp[0].shape[0]), "status": status, "cpu_s": cpu,
                   "bound": -np.inf if y is None else dual_bound(*lp, y)}
            _emit(rows, row)
    return rows


def profile(walls: list[str], lifting: str, time_limit: float) -> list[dict]:
    """IPX's log on the root LP of each wall, and its summary (see the module docstring)."""
    import re

    from blockmpec.solvers.engines.highs import highs_lp, new_highs, use_interior_point

    # IPX's iteration line in HiGHS's log file: iter, primal obj, dual obj, pinf, dinf, gap, time
    sci = r"([-+]?\d\.\d+e[-+]\d+)"
    iteration = re.compile(rf"^\s*(\d+)\*?\s+{sci}\s+{sci}\s+{sci}\s+{sci}\s+{sci}\s+(\d+\.\d+)")
    rows = []
    for spec in walls:
        A, c, rl, ru, cl, cu = root_lp(spec, lifting)
        log = OUT / f"ipx-{spec}-{lifting}.log"
        log.unlink(missing_ok=True)
        h = new_highs()
        h.setOptionValue("output_flag", True)
        h.setOptionValue("log_to_console", False)
        h.setOptionValue("log_file", str(log))
        h.passModel(highs_lp(A, c, rl, ru, cl, cu))
        use_interior_point(h, crossover=False, solver="ipx")
        h.setOptionValue("time_limit", time_limit)
        cpu = time.process_time()
        h.run()
        cpu = time.process_time() - cpu
        h.setOptionValue("log_file", "")
        its, crash_before, crash_after, seen_crash = [], None, None, False
        for line in log.read_text().splitlines():
            if "Constructing starting basis" in line:
                seen_crash, crash_before = True, its[-1]["time_s"] if its else 0.0
                continue
            m = iteration.match(line)
            if m:
                its.append({"iter": int(m[1]), "gap": float(m[6]), "time_s": float(m[7])})
                if seen_crash and crash_after is None:
                    crash_after = its[-1]["time_s"]
        row = {"wall": spec, "lifting": lifting, "rows": int(A.shape[0]), "cols": int(A.shape[1]),
               "status": h.modelStatusToString(h.getModelStatus()), "cpu_s": cpu, "iterations": len(its),
               "starting_basis_s": None if crash_after is None else crash_after - crash_before,
               "after_basis_s": None if crash_after is None else its[-1]["time_s"] - crash_after,
               "last_gap": its[-1]["gap"] if its else None, "log": str(log)}
        _emit(rows, row)
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="", help="walls CxB, comma-separated: the root LP by every engine")
    ap.add_argument("--only", default=",".join(ENGINES), help=f"engines of --engines, from {', '.join(ENGINES)}")
    ap.add_argument("--liftings", default="", help="walls CxB: the root LP of every lifting by IPX")
    ap.add_argument("--profile", default="", help="walls CxB: IPX's log on the root LP of --lifting, summarised")
    ap.add_argument("--lifting", default="rlt", help="lifting of --profile")
    ap.add_argument("--time-limit", type=float, default=300.0, help="seconds per LP solve")
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    unknown = sorted(set(names) - set(ENGINES))
    if unknown:
        raise SystemExit(f"unknown engine(s) {', '.join(unknown)}; known: {', '.join(ENGINES)}")
    OUT.mkdir(parents=True, exist_ok=True)
    if args.engines:
        out = engines(args.engines.split(","), names, args.time_limit)
        (OUT / "engines.json").write_text(json.dumps(out, indent=1))
    if args.liftings:
        out = liftings(args.liftings.split(","), args.time_limit)
        (OUT / "liftings.json").write_text(json.dumps(out, indent=1))
    if args.profile:
        out = profile(args.profile.split(","), args.lifting, args.time_limit)
        (OUT / "profile.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
