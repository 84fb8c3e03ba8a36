"""The certified minimum at medium scale (issue 12): engines side by side, targets, largest certified.

Three parts, each a table (markdown on stdout, CSV in ``studies/output/certificate/``):

``compare``  every configuration on the same walls, one after the other in one
             process (ratios are what to read: the machine is shared);
``targets``  the issue's targets: running-bond walls 2x4, 4x3, 5x2 at mu = 0.65
             within 60 s, and running-bond walls of 30-50 blocks (half blocks at
             the course ends, as ``bm.cases.wall`` builds them: 2x15, 31 blocks, and
             8x4, 36 blocks) within 600 s;
``largest``  the largest running-bond wall, stack wall and arch certified within a
             time limit, growing each family until the first size that fails;
``suite``    every configuration on the structures the heuristic suite certifies by ``milp``
             (``studies/lab/heuristic_suite.py``: walls with openings, arches on buttresses,
             psi > 0, ...): certified or not, time, and whether the certified values agree.

Usage::

    python studies/lab/certificate_study.py compare --configs highs,bnb-rltfull-ipm --cases 3x2,6x2s,2x4 --time-limit 60
    python studies/lab/certificate_study.py targets --configs bnb-rltfull-ipm
    python studies/lab/certificate_study.py largest --configs bnb-rltfull-ipm --time-limit 60 --families running,stack,arch
    python studies/lab/certificate_study.py suite --configs highs,bnb-rltfull-ipm --time-limit 60
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _tables import write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "certificate"

#: configuration name -> (method, options and engine settings (``_methods.solve`` sends each where it belongs))
CONFIGS = {
    "auto": ("milp", {}),  # the default: engine="auto"
    "highs": ("milp", {"engine": "highs"}),
    "highs+env": ("milp", {"engine": "highs", "envelope": True}),
    # the bnb engine as first measured (its defaults are now lifting="rlt-full", root_lp="ipm": "bnb-rltfull-ipm")
    "bnb": ("milp", {"engine": "bnb", "lifting": "friction", "root_lp": "simplex"}),
    "bnb-friction-ipm": ("milp", {"engine": "bnb", "lifting": "friction", "root_lp": "ipm"}),
    "bnb+lam": ("milp", {"engine": "bnb", "lifting": "friction", "root_lp": "simplex", "lam_branching": True}),
    "bnb-mechanism": ("milp", {"engine": "bnb", "lifting": "mechanism", "root_lp": "simplex"}),
    "bnb-rlt": ("milp", {"engine": "bnb", "lifting": "rlt", "root_lp": "simplex"}),
    "bnb-rlt+lam": ("milp", {"engine": "bnb", "lifting": "rlt", "root_lp": "simplex", "lam_branching": True}),
    "bnb-rlt-ipm": ("milp", {"engine": "bnb", "lifting": "rlt", "root_lp": "ipm"}),
    "bnb-rltfull-ipm": ("milp", {"engine": "bnb", "lifting": "rlt-full", "root_lp": "ipm"}),
    "highs-nodiss": ("milp", {"engine": "highs", "dissipation_bound": False, "heuristic": ""}),
}

COLUMNS = ["case", "blocks", "config", "status", "certified", "multiplier", "root_bound", "bound", "gap_abs", "nodes",
           "crossover_runs", "bound_s", "solve_s", "message"]


def case(spec: str) -> bm.Structure:
    """``CxB`` running-bond wall, ``CxBs`` stack wall, ``arch:N`` round arch of N voussoirs,
    ``buttress:N:K`` arch on buttresses, ``ft:N`` MPECLib's Ferris & Tin-Loi wall N; mu = 0.65, psi = 0."""
    if spec.startswith("ft:"):
        return bm.cases.build_case("ferris-tinloi", wall=int(spec.split(":")[1]))
    if spec.startswith("arch:"):
        return bm.cases.round_arch(n_voussoirs=int(spec.split(":")[1]))
    if spec.startswith("buttress:"):
        _, n, k = spec.split(":")
        return bm.cases.arch_on_buttresses(n_voussoirs=int(n), buttress_courses=int(k))
    bond = "stack" if spec.endswith("s") else "running"
    c, b = (int(v) for v in spec.rstrip("s").split("x"))
    return bm.cases.wall(c, b, bond=bond, mu=0.65)


def run(spec: str, config: str, time_limit: float, traces: list | None = None) -> dict:
    """One certificate run of the case ``spec`` (see :func:`case`) by ``config``: one row of the tables."""
    return run_structure(spec, case(spec), config, time_limit, traces)


def run_structure(spec: str, structure: bm.Structure, config: str, time_limit: float,
                  traces: list | None = None) -> dict:
    """One certificate run of ``structure`` (labelled ``spec``) by ``config``."""
    method, options = CONFIGS[config]
    res = solve(structure, method, time_limit=time_limit, **options)
    ex = res.extra
    bound = ex.get("bound", ex.get("dual_bound"))
    if traces is not None:
        traces += [dict(r, case=spec, config=config) for r in (res.trace or [])]
    search = [r for r in (res.trace or []) if r.get("stage") == "search" and r.get("bound") is not None]
    root_bound = search[0]["bound"] if search else (bound if ex.get("nodes") == 0 else None)
    return {"case": spec, "blocks": structure.n_free, "config": config, "status": res.status.value,
            "certified": res.status is bm.Status.OPTIMAL and res.verified, "multiplier": res.multiplier,
            "root_bound": root_bound,
            "bound": bound, "gap_abs": ex.get("gap_abs"), "nodes": ex.get("nodes"),
            "crossover_runs": ex.get("root_crossover_runs"),
            "bound_s": ex.get("bound_time_s"), "solve_s": res.solve_time_s, "message": res.message[:100]}


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def table(rows: list[dict], columns: list[str]) -> str:
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(_fmt(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def write(rows: list[dict], name: str, columns: list[str]) -> Path:
    return write_csv(OUT / f"{name}.csv", rows, columns)


#: two certified values of one structure agree when they differ by at most this (times max(1, |value|))
AGREE_TOL = 1e-6


def suite_summary(rows: list[dict], configs: list[str]) -> str:
    """Per configuration: structures certified, total and median solve time, and the structures where its
    certified value differs from another configuration's certified value (a bug in one of them)."""
    import statistics

    by_case: dict = {}
    for r in rows:
        by_case.setdefault(r["case"], {})[r["config"]] = r
    out = []
    for config in configs:
        mine = [r for r in rows if r["config"] == config]
        times = [r["solve_s"] for r in mine if r["solve_s"] is not None]
        disagree = 0
        for runs in by_case.values():
            r = runs.get(config)
            if r is None or not r["certified"]:
                continue
            others = [o for c, o in runs.items() if c != config and o["certified"]]
            disagree += any(abs(o["multiplier"] - r["multiplier"]) > AGREE_TOL * max(1.0, abs(r["multiplier"]))
                            for o in others)
        only = sum(1 for runs in by_case.values() if runs.get(config, {}).get("certified")
                   and not any(o["certified"] for c, o in runs.items() if c != config))
        out.append({"config": config, "structures": len(mine), "certified": sum(bool(r["certified"]) for r in mine),
                    "only_it_certified": only, "disagreements": disagree,
                    "total_solve_s": sum(times), "median_solve_s": statistics.median(times) if times else None})
    return table(out, ["config", "structures", "certified", "only_it_certified", "disagreements", "total_solve_s",
                       "median_solve_s"])


#: growing sizes of each family for ``largest``
#: the issue's targets: three walls within 60 s, and running-bond walls of 30-50 blocks (half blocks at the course
#: ends) within 600 s: the 31-block two-course 2x15 and the 36-block 8x4
TARGETS = (("2x4", 60.0), ("4x3", 60.0), ("5x2", 60.0), ("2x15", 600.0), ("8x4", 600.0))

FAMILIES = {
    "running": ["2x2", "3x2", "2x3", "4x2", "2x4", "5x2", "4x3", "3x4", "6x3", "5x4", "6x4", "6x5", "8x4", "6x6"],
    # two-course running-bond walls, whose root LP alone certifies them: how far the root LP reaches
    "two-course": ["2x4", "2x6", "2x8", "2x10", "2x12", "2x15", "2x18", "2x21", "2x25"],
    "stack": ["3x2s", "4x2s", "6x2s", "4x3s", "8x2s", "6x3s", "5x4s", "6x4s", "8x4s", "6x6s", "8x6s"],
    "arch": ["arch:10", "arch:20", "arch:40", "arch:80", "arch:160", "arch:320", "arch:640"],
}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", choices=["compare", "targets", "largest", "suite"])
    ap.add_argument("--configs", default="highs,bnb-rltfull-ipm")
    ap.add_argument("--cases", default="3x2,6x2s,2x4,4x3,5x2")
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--families", default="running,stack,arch")
    ap.add_argument("--tag", default="")
    args = ap.parse_args(argv)
    configs = args.configs.split(",")
    rows: list[dict] = []
    traces: list[dict] = []
    tag = f"_{args.tag}" if args.tag else ""
    if args.part == "compare":
        for spec in args.cases.split(","):
            for config in configs:
                rows.append(run(spec, config, args.time_limit, traces))
                print(table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    elif args.part == "suite":
        from heuristic_suite import suite

        for entry in suite(include_large=False):
            if entry.source != "milp":
                continue
            for config in configs:
                rows.append(run_structure(entry.label, entry.build(), config, args.time_limit, traces))
                print(table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
        print()
        print(suite_summary(rows, configs))
    elif args.part == "targets":
        for spec, limit in TARGETS:
            for config in configs:
                rows.append(run(spec, config, limit, traces))
                print(table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    else:
        for family in args.families.split(","):
            for config in configs:
                best = None
                for spec in FAMILIES[family]:
                    t0 = time.perf_counter()
                    r = run(spec, config, args.time_limit, traces)
                    r["family"], r["wall_s"] = family, time.perf_counter() - t0
                    print(table([r], COLUMNS).splitlines()[-1], flush=True)
                    if not r["certified"]:
                        break
                    best = r
                rows.append({"family": family, "config": config, "largest": best and best["case"],
                             "blocks": best and best["blocks"], "solve_s": best and best["solve_s"]})
        print(table(rows, ["family", "config", "largest", "blocks", "solve_s"]))
        write(rows, f"largest{tag}", ["family", "config", "largest", "blocks", "solve_s"])
        write(traces, f"largest_trace{tag}", ["case", "config", "stage", "time_s", "bound", "incumbent", "gap_abs"])
        return
    print()
    print(table(rows, COLUMNS))
    write(rows, f"{args.part}{tag}", COLUMNS)
    write(traces, f"{args.part}_trace{tag}", ["case", "config", "stage", "time_s", "bound", "incumbent", "gap_abs"])


if __name__ == "__main__":
    main()
