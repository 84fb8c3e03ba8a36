"""Row generation at the root of ``milp``'s lifted LP (``root_lp="ipm-rows"``) against the interior point on the
whole LP (``root_lp="ipm-lifted"``; ``root_lp="ipm"`` now solves it in null-space coordinates), issue 12's
30-50-block target.  The measurements quoted in the README with ``--modes ipm`` were made before the null-space
coordinates; ``--modes ipm-lifted`` repeats them.

Part 1 (``--compare``): both root LPs side by side on the same walls, one run at a time, ``lifting="rlt-full"``,
``engine="bnb"``, mu = 0.65: status, multiplier, bound, CPU seconds, and the bound after every interior-point round.
Part 2 (``--sizes``): the 30-36-block walls' lifted LP (rows, columns, nonzeros, copy pair rows) and how many pairs
the bound tightening fixes (``slack_max = 0``: active, ``z_max = 0``: idle), which row generation and the
copy removal of idle pairs could drop.
Part 3 (``--copies``): the root LP's interior-point bound with full static copies for every pair
(``static_copies="all"``, what ``rlt-full`` builds) against copies with statics for the friction pairs only.

    python studies/lab/root_rows.py --compare 2x4,5x2,4x3,3x4 --time-limit 300
    python studies/lab/root_rows.py --sizes 2x15,4x7,8x4
    python studies/lab/root_rows.py --copies 5x2
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "root_rows"


def compare(walls: list[str], modes: list[str], time_limit: float) -> list[dict]:
    rows = []
    for spec in walls:
        for mode in modes:
            cpu = time.process_time()
            res = solve(named_wall(spec), "milp", engine="bnb", lifting="rlt-full", root_lp=mode,
                        time_limit=time_limit)
            row = {"wall": spec, "root_lp": mode, "status": res.status.value, "lam": res.multiplier,
                   "bound": res.extra.get(bm.facts.BOUND), "cpu_s": time.process_time() - cpu,
                   "rounds": [(round(t["time_s"], 1), t["bound"]) for t in res.trace if t.get("stage") == "search"]}
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def sizes(walls: list[str]) -> list[dict]:
    from blockmpec.deadline import Deadline
    from blockmpec.formulations.mpec_milp import work_matrix
    from blockmpec.solvers.engines.complementarity_bnb import lifted_lp
    from blockmpec.solvers.milp import MILPSettings, MILPSolver, lifting_options

    rows = []
    for spec in walls:
        solver = MILPSolver(engine="bnb", settings=MILPSettings(lifting="rlt-full", root_lp="ipm-rows"))
        solver.setup(bm.operators.assemble(named_wall(spec)))
        cpu = time.process_time()
        bd = solver.lp_bounds(Deadline(600))  # milp's own LP bounds (its module's step)
        bound_s = time.process_time() - cpu
        form = solver.form
        A, *_, layout = lifted_lp(form, work_matrix(form), bd.lam_lower, bd.lam_upper,
                                  **lifting_options(form, "rlt-full", bd.slack_max))
        pair_rows = sum(r.size for r in layout.copy_pair_rows.values())
        late = 0 if layout.tied is None else int(layout.tied_rows[~np.isin(layout.tied, np.r_[form.n, form.t])].size)
        row = {"wall": spec, "blocks": int(named_wall(spec).n_free), "pairs": int(form.n_pairs),
               "fixed_active": int((bd.slack_max == 0).sum()), "fixed_idle": int((bd.z_max == 0).sum()),
               "rows": int(A.shape[0]), "cols": int(A.shape[1]), "nnz": int(A.nnz), "copy_pair_rows": int(pair_rows),
               "moment_rows": late, "bounds_cpu_s": bound_s, "lam_lower": bd.lam_lower}
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


def copies(walls: list[str], time_limit: float) -> list[dict]:
    from blockmpec.deadline import Deadline
    from blockmpec.solvers.milp import MILPSettings, MILPSolver

    rows = []
    for spec in walls:
        for static_copies in ("all", "friction"):
            solver = MILPSolver(engine="bnb", settings=MILPSettings(lifting="rlt-full", root_lp="ipm"))
            solver.setup(bm.operators.assemble(named_wall(spec)))
            # the root of milp's branch and bound (the milp module's own steps)
            bnb = solver.branch_and_bound(solver.lp_bounds(Deadline(time_limit)), static_copies=static_copies)
            bnb.deadline = Deadline(time_limit)
            bnb.apply_node(bnb.root, bnb.lam_lower, np.inf)
            cpu = time.process_time()
            bound = bnb.interior_root()  # no target: the whole LP (per-block units)
            row = {"wall": spec, "static_copies": static_copies, "rows": int(bnb.lifted_matrix.shape[0]),
                   "nnz": int(bnb.lifted_matrix.nnz), "root_bound": bound, "cpu_s": time.process_time() - cpu}
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", default="", help="walls CxB, comma-separated, for the side-by-side runs")
    ap.add_argument("--modes", default="ipm-lifted,ipm-rows")
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--sizes", default="", help="walls CxB whose lifted LP sizes and fixed pairs are counted")
    ap.add_argument("--copies", default="", help="walls CxB whose root bound is measured with fewer full copies")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    if args.compare:
        out = compare(args.compare.split(","), args.modes.split(","), args.time_limit)
        (OUT / "compare.json").write_text(json.dumps(out, indent=1))
    if args.sizes:
        out = sizes(args.sizes.split(","))
        (OUT / "sizes.json").write_text(json.dumps(out, indent=1))
    if args.copies:
        out = copies(args.copies.split(","), args.time_limit)
        (OUT / "copies.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
