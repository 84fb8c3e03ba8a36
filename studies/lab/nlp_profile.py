"""Where one ``nlp`` solve spends its time: Ipopt's own timing statistics, per option set.

Each option set (``--configs``, as in ``nlp_scaling.py``) solves one running-bond wall
(``--wall courses x blocks_per_course``) with ``nlp`` under ``--time-limit``; Ipopt writes its
log to ``studies/output/nlp/profile_<config>_<solve>.log`` with ``print_timing_statistics
yes``, and the script prints, per set: status, lam, CPU and wall seconds of the solve,
Ipopt iterations, the start's seconds, and from Ipopt's statistics the CPU seconds of
function and derivative evaluations (our Python callbacks) against the linear solver
(MUMPS: symbolic analysis, factorisation, back-solves).  Every solve of the run is
profiled: the log's tables are summed over the stages.  Usage::

    python studies/lab/nlp_profile.py --wall 20x25 --time-limit 60 \
        --configs "ipopt={'route': 'ipopt'};penalty-fp={'route': 'ipopt', 'start': 'fixed-point', 'complementarity': 'penalty'}"

(``route='ipopt'``: from 100 free blocks on ``nlp``'s default route has no Ipopt stage to profile.)

Writes ``studies/output/nlp/nlp_profile[_TAG].csv``.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.solvers.nlp import RelaxedMPEC, RelaxedNLP

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _tables import csv_rows  # noqa: E402
from _walls import wall_shape  # noqa: E402
from nlp_scaling import parse_configs  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "nlp"
#: Ipopt timing-statistics lines summed over the log ("name ...: cpu  (sys)  wall")
TIMERS = {
    "ipopt_total": "OverallAlgorithm",
    "function_evaluations": "Function Evaluations",
    "linear_solver": "StdAugSystemSolverMultiSolve",  # MUMPS: analysis, factorisations, back-solves
    "back_solves": "LinearSystemBackSolve",
    "symbolic": "LinearSystemSymbolicFactorization",
    "structure_check": "LinearSystemStructureConverter",
    "update_barrier": "UpdateBarrierParameter",
    "hessian_evals": "Hessian of the Lagrangian",
    "jacobian_evals": "Equality constraint Jacobian",
}
COLUMNS = ["config", "wall", "blocks", "status", "verified", "multiplier", "cpu_s", "wall_s", "solve_s",
           "start_time_s", "ipopt_iterations", "stages", *TIMERS, "first_iteration_s",
           "longest_iteration_s", "after_last_iteration_s", "restoration_iterations", "message"]


def ipopt_timers(log_text: str) -> dict[str, float]:
    """Sum the CPU seconds of :data:`TIMERS` over every timing table of an Ipopt log."""
    out = dict.fromkeys(TIMERS, 0.0)
    for key, label in TIMERS.items():
        for m in re.finditer(rf"^\s*{re.escape(label)}[^:\n]*:\s*([0-9.eE+-]+)", log_text, re.M):
            out[key] += float(m.group(1))
    return out


def profile(config: str, courses: int, per_course: int, time_limit: float, options: dict) -> dict:
    """Solve the wall with ``options`` and Ipopt logging; one row."""
    structure = bm.cases.wall(courses=courses, blocks_per_course=per_course)
    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob(f"profile_{config}_*.log"):
        old.unlink()
    ipopt = {"file_print_level": 5, "print_timing_statistics": "yes", **options.pop("ipopt_options", {})}
    logs = []
    solve_stage = RelaxedNLP.solve_stage

    def logged_stage(self, *args, **kwargs):  # one Ipopt log per stage (Ipopt has no append option)
        logs.append(OUT / f"profile_{config}_{len(logs) + 1}.log")
        self.settings.ipopt_options["output_file"] = str(logs[-1])
        return solve_stage(self, *args, **kwargs)

    stamps = []  # (perf_counter, Ipopt iteration): the wall-clock gaps between iterations
    intermediate = RelaxedMPEC.intermediate

    def stamped(self, alg_mod, iter_count, *args):
        stamps.append((time.perf_counter(), int(alg_mod), int(iter_count)))
        return intermediate(self, alg_mod, iter_count, *args)

    RelaxedNLP.solve_stage = logged_stage
    RelaxedMPEC.intermediate = stamped
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        res = solve(structure, "nlp", time_limit=time_limit, ipopt_options=ipopt, **options)
        wall_s, cpu_s = time.perf_counter() - t0, time.process_time() - c0
    finally:
        RelaxedNLP.solve_stage = solve_stage
        RelaxedMPEC.intermediate = intermediate
    gaps = np.diff([t for t, _, _ in stamps]) if len(stamps) > 1 else np.zeros(1)
    end_gap = t0 + wall_s - stamps[-1][0] if stamps else wall_s
    timers = ipopt_timers("\n".join(p.read_text() for p in logs if p.exists()))
    stages = " ".join(f"{rec['stage']}:{rec.get('ipopt_iterations', 0)}" for rec in res.trace if "stage" in rec)
    return {"config": config, "wall": f"{courses}x{per_course}", "blocks": structure.n_free,
            "status": res.status.value, "verified": res.success, "multiplier": res.multiplier, "cpu_s": cpu_s,
            "wall_s": wall_s, "solve_s": res.solve_time_s, "start_time_s": res.extra.get("start_time_s"),
            "ipopt_iterations": res.iterations, "stages": stages, **timers,
            "first_iteration_s": stamps[0][0] - t0 if stamps else None, "longest_iteration_s": float(np.max(gaps)),
            "after_last_iteration_s": end_gap, "restoration_iterations": sum(a for _, a, _ in stamps),
            "message": res.message[:120]}


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wall", default="20x25")
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--configs", default="ipopt={'route': 'ipopt'}")
    ap.add_argument("--tag", default="")
    args = ap.parse_args(argv)
    courses, per_course = wall_shape(args.wall)
    rows = []
    with csv_rows(OUT / f"nlp_profile{'_' + args.tag if args.tag else ''}.csv", COLUMNS) as append:
        for config, options in parse_configs(args.configs).items():
            row = profile(config, courses, per_course, args.time_limit, options)
            rows.append(row)
            append(row)
            it = max(row["ipopt_iterations"], 1)
            print(f"{config}: {row['status']} verified={row['verified']} lam={row['multiplier']} "
                  f"cpu={row['cpu_s']:.1f}s wall={row['wall_s']:.1f}s solve={row['solve_s']:.1f}s "
                  f"start={row['start_time_s'] or 0:.1f}s it={row['ipopt_iterations']} [{row['stages']}]\n"
                  f"   ipopt cpu {row['ipopt_total']:.1f}s: evals {row['function_evaluations']:.2f}s, "
                  f"linear solver {row['linear_solver']:.2f}s, back-solves {row['back_solves']:.2f}s, "
                  f"symbolic {row['symbolic']:.2f}s; per iteration {row['ipopt_total'] / it:.3f}s "
                  f"(evals {row['function_evaluations'] / it:.3f}, linear solver {row['linear_solver'] / it:.3f})\n"
                  f"   wall s: first iteration at {row['first_iteration_s'] or 0:.1f}, longest gap {row['longest_iteration_s']:.1f}, "
                  f"after the last {row['after_last_iteration_s']:.1f}; restoration iterations "
                  f"{row['restoration_iterations']}\n   {row['message']}", flush=True)
    return rows


if __name__ == "__main__":
    main()
