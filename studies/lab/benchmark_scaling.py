r"""Cost growth with structure size: walls and arches from 10 to 100,000 blocks.

Part 1, per family (running-bond walls, arches on buttresses) and size, each size
in a fresh subprocess (so the peak memory is that size's own):

* structure generation with interface detection, and operator assembly;
* Pyomo build of the static LP (1) (``blockmpec.formulations.static_lp``) and its
  compilation to matrices (``blockmpec.formulations.compile_linear``), timed here directly;
* the first LP solve: ``bm.solve(ops, "static-lp")``, its set-up (Pyomo build +
  compile + HiGHS load, as the method does it) and its solve time;
* the fixed point: ``bm.solve(ops, "fixed-point")``, its LP steps and total time
  (set-up + solve);
* peak resident memory of the subprocess.

Then the growth exponent ``k`` of each column, ``cost ~ blocks^k``: the slope of a
least-squares line through ``(log blocks, log cost)`` over every size, and the
slope between the two largest sizes (small sizes are dominated by fixed costs, so
the second is the better guide to large sizes).  Solve columns are fitted only on
sizes whose solve succeeded; memory is fitted on the peak above the subprocess's
peak after its imports (the baseline).

Part 2, for ``milp`` and ``nlp``: the largest running-bond wall solved within 60 s.
Wall sizes double (4, 8, 16, ... blocks, up to ``--largest-max``) until a run
fails, then ``--largest-refine`` bisection steps narrow the gap; each run in a
subprocess with ``time_limit`` = the limit.  "Solved" means
a verified success (for ``milp``: a certified global minimum, status ``optimal``)
with set-up + solve time at most the limit.

Every solve has a time limit (``--time-limit``); a subprocess that overruns its
wall-clock allowance is killed and its row keeps the stages it finished, with the
status ``killed``.  Methods are called only through ``bm.solve``, so the table
follows whatever the registered methods currently do; ``--lp-options`` and
``--fp-options`` pass method options or engine settings (e.g. ``--lp-options algorithm=ipm``,
``--fp-options fold_weight=0``).

Usage (the default takes about 4 minutes on 2 cores)::

    python studies/lab/benchmark_scaling.py [--families wall,arch] [--sizes 10,100,1000]
        [--time-limit 120] [--lp-method static-lp] [--fp-method fixed-point]
        [--lp-options KEY=VALUE,...] [--fp-options KEY=VALUE,...]
        [--largest milp,nlp] [--largest-limit 60] [--largest-max 128] [--largest-refine 0]
        [--child-timeout SECONDS] [--tag NAME]

    # the issue's full range (hours; needs several GB of memory at 100,000 blocks):
    python studies/lab/benchmark_scaling.py --sizes 10,100,1000,10000,100000 --time-limit 3600 --largest-max 4096

Prints markdown tables on stdout (progress on stderr) and writes
``studies/output/benchmark_scaling/{scaling,slopes,largest}[_TAG].csv``.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm

# sibling studies (this script's folder is sys.path[0] when run as a script)
sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _methods import solve  # noqa: E402
from _tables import fmt as _fmt  # noqa: E402
from _tables import markdown, peak_memory_mb, write_csv  # noqa: E402
from _walls import wall_for  # noqa: E402
from milp_scaling import run_case  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "benchmark_scaling"
FAMILIES = ("wall", "arch")

#: columns of the per-size table: (CSV key, header, format)
TABLE = [
    ("family", "family", "{}"),
    ("blocks", "blocks", "{:,}"),
    ("interfaces", "interfaces", "{:,}"),
    ("generate_s", "generate s", "{:.3g}"),
    ("assemble_s", "assemble s", "{:.3g}"),
    ("pyomo_build_s", "Pyomo build s", "{:.3g}"),
    ("compile_s", "compile s", "{:.3g}"),
    ("lp_setup_s", "LP set-up s", "{:.3g}"),
    ("lp_solve_s", "first LP solve s", "{:.3g}"),
    ("lp_status", "LP status", "{}"),
    ("lp_multiplier", "lam LP", "{:.6f}"),
    ("fp_iterations", "FP iterations", "{:d}"),
    ("fp_total_s", "FP total s", "{:.3g}"),
    ("fp_status", "FP status", "{}"),
    ("fp_multiplier", "lam FP", "{:.6f}"),
    ("peak_memory_mb", "peak MB", "{:.0f}"),
]
#: columns whose growth is fitted: (CSV key, label, status key whose success it needs or None)
FITTED = [
    ("generate_s", "generate", None),
    ("assemble_s", "assemble", None),
    ("pyomo_build_s", "Pyomo build", None),
    ("compile_s", "compile", None),
    ("lp_setup_s", "LP set-up", "lp_status"),
    ("lp_solve_s", "first LP solve", "lp_status"),
    ("fp_total_s", "FP total", "fp_status"),
    ("memory_above_baseline_mb", "peak memory above baseline", None),
]
SUCCESS = {s.value for s in bm.Status if s.is_success}


# --------------------------------------------------------------------------- structures


def arch_for(n_blocks: int) -> bm.Structure:
    """An arch on buttresses with about ``n_blocks`` free blocks.

    The default geometry (radius 1, thickness 0.15, 8-course buttresses of 0.5 x
    0.25 blocks) with the ring cut into ``n_blocks - 16`` voussoirs, so the
    structure keeps its shape and only the voussoirs get thinner.  Below 26 blocks
    the buttresses get fewer courses (at least 1) and the ring at least 2 voussoirs.

    The thin voussoirs make interface detection grow about quadratically (each
    voussoir's bounding circle, radius ~0.075, meets ~n/10 others): 2.3 s at 4,000
    blocks; at 100,000 some 5e8 candidate pairs, beyond this machine's memory.
    """
    courses = min(8, max(1, (n_blocks - 4) // 2))
    return bm.cases.arch_on_buttresses(n_voussoirs=max(2, n_blocks - 2 * courses), buttress_courses=courses)


def structure_for(family: str, n_blocks: int) -> bm.Structure:
    """A structure of ``family`` ("wall" or "arch") with about ``n_blocks`` free blocks."""
    if family == "wall":
        return wall_for(n_blocks)
    if family == "arch":
        return arch_for(n_blocks)
    raise ValueError(f"family: must be one of {', '.join(FAMILIES)}; got {family!r}")


# --------------------------------------------------------------------------- subprocess side


def _with_time_limit(method: str, options: dict, time_limit: float) -> dict:
    """``options`` plus ``time_limit`` (every method has it)."""
    return {**options, "time_limit": float(time_limit)}


def _emit(row: dict) -> None:
    """One JSON line with everything measured so far (the parent keeps the last one)."""
    print(json.dumps(row, default=str), flush=True)


def child_scaling(spec: dict) -> None:
    """Measure one size of one family (see the module docstring); prints JSON lines."""
    import gc

    from blockmpec.formulations import compile_linear, pause_gc, static_lp

    row: dict = {"family": spec["family"], "target_blocks": spec["n"], "baseline_memory_mb": peak_memory_mb()}
    t0 = time.perf_counter()
    structure = structure_for(spec["family"], spec["n"])
    t1 = time.perf_counter()
    ops = bm.assemble(structure)
    t2 = time.perf_counter()
    row.update(blocks=structure.n_free, interfaces=len(structure.interfaces), generate_s=t1 - t0, assemble_s=t2 - t1,
               peak_memory_mb=peak_memory_mb())
    _emit(row)

    t0 = time.perf_counter()
    problem = pause_gc(static_lp)(ops)  # as the compiled-formulation cache builds it
    t1 = time.perf_counter()
    lp = compile_linear(problem)
    t2 = time.perf_counter()
    row.update(pyomo_build_s=t1 - t0, compile_s=t2 - t1, lp_rows=lp.A.shape[0], lp_columns=lp.A.shape[1],
               peak_memory_mb=peak_memory_mb())
    del problem, lp
    gc.collect()
    _emit(row)

    res = solve(ops, spec["lp_method"], **_with_time_limit(spec["lp_method"], spec["lp_options"], spec["time_limit"]))
    row.update(lp_setup_s=res.build_time_s, lp_solve_s=res.solve_time_s, lp_status=res.status.value,
               lp_multiplier=res.multiplier, lp_iterations=res.iterations, lp_max_residual=res.max_residual,
               lp_message=res.message[:200], peak_memory_mb=peak_memory_mb())
    del res
    gc.collect()
    _emit(row)

    if row["lp_status"] == bm.Status.TIME_LIMIT.value and spec["lp_method"] == "static-lp":
        # the fixed point starts with the same LP: it would only spend the time limit again
        row.update(fp_status="skipped", fp_message="the static LP hit the time limit")
    else:
        res = solve(ops, spec["fp_method"], **_with_time_limit(spec["fp_method"], spec["fp_options"], spec["time_limit"]))
        row.update(fp_iterations=res.iterations, fp_setup_s=res.build_time_s, fp_solve_s=res.solve_time_s,
                   fp_total_s=res.build_time_s + res.solve_time_s, fp_status=res.status.value,
                   fp_multiplier=res.multiplier, fp_lp_solves=res.extra.get("lp_solves"),
                   fp_max_residual=res.max_residual, fp_message=res.message[:200])
    row.update(peak_memory_mb=peak_memory_mb())
    row["memory_above_baseline_mb"] = row["peak_memory_mb"] - row["baseline_memory_mb"]
    _emit(row)


def child_largest(spec: dict) -> None:
    """Solve one wall with ``milp`` or ``nlp`` within the time limit; prints one JSON line."""
    structure = wall_for(spec["n"])
    limit = spec["time_limit"]
    label = f"wall-{structure.metadata['courses']}x{structure.metadata['blocks_per_course']}"
    row = {"method": spec["method"], "case": label, "blocks": structure.n_free, "time_limit": limit}
    _emit(row)
    if spec["method"] == "milp":
        r = run_case("wall", label, structure, limit)
        row.update(status=r["status"], success=bool(r["certified"]), multiplier=r["multiplier"],
                   setup_s=r["setup_s"], solve_s=r["solve_s"], nodes=r["nodes"], gap_abs=r["gap_abs"],
                   message=r["message"])
    else:
        res = bm.solve(structure, spec["method"], **_with_time_limit(spec["method"], {}, limit))
        row.update(status=res.status.value, success=res.success, multiplier=res.multiplier, setup_s=res.build_time_s,
                   solve_s=res.solve_time_s, iterations=res.iterations, message=res.message[:200])
    row["solved"] = bool(row["success"]) and row["setup_s"] + row["solve_s"] <= limit
    _emit(row)


# --------------------------------------------------------------------------- parent side


def run_child(spec: dict, timeout: float) -> dict:
    """Run this script with ``--child SPEC`` and return its last JSON line.

    A child that is killed (``timeout`` seconds of wall clock) or crashes returns
    what it had measured, with ``status`` "killed" / "crashed: <last error line>".
    """
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(spec)]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        stdout, stderr, failure = p.stdout, p.stderr, None if p.returncode == 0 else f"crashed (exit {p.returncode})"
    except subprocess.TimeoutExpired as exc:
        stdout = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        stderr = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
        failure = f"killed after {timeout:g} s"
    row: dict = {}
    for line in stdout.splitlines():
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
    row["wall_s"] = time.perf_counter() - t0
    if failure:
        last = stderr.strip().splitlines()[-1] if stderr.strip() else ""
        row["failure"] = f"{failure}: {last}"[:200] if last else failure
    return row


def fit_exponent(blocks, costs) -> float:
    """Slope ``k`` of the least-squares line through ``(log blocks, log cost)``; nan with < 2 points."""
    b, c = np.asarray(blocks, float), np.asarray(costs, float)
    if len(b) < 2 or len(set(b)) < 2:
        return math.nan
    return float(np.polyfit(np.log(b), np.log(np.maximum(c, 1e-12)), 1)[0])


def growth(rows: list[dict]) -> list[dict]:
    """Growth exponents per family and fitted column (see the module docstring)."""
    out = []
    for family in dict.fromkeys(r["family"] for r in rows):
        for key, label, status_key in FITTED:
            pts = sorted((r["blocks"], r[key]) for r in rows
                         if r["family"] == family and r.get("blocks") and r.get(key) is not None and r[key] > 0
                         and (status_key is None or r.get(status_key) in SUCCESS))
            b = [p[0] for p in pts]
            c = [p[1] for p in pts]
            out.append({"family": family, "column": label, "sizes": len(pts),
                        "blocks": f"{b[0]}-{b[-1]}" if b else "",
                        "k_all": fit_exponent(b, c), "k_two_largest": fit_exponent(b[-2:], c[-2:])})
    return out


def largest_search(method: str, limit: float, start: int, cap: int, timeout: float,
                   refine: int = 0) -> tuple[list[dict], dict]:
    """Largest wall ``method`` solves within ``limit`` seconds.

    Wall sizes (target free blocks) double from ``start`` until a run fails or
    the target exceeds ``cap``; then ``refine`` bisection steps (geometric mean of
    the largest solved and the smallest unsolved target) narrow the gap.
    """
    runs: list[dict] = []

    def attempt(n: int) -> bool:
        row = run_child({"task": "largest", "method": method, "n": n, "time_limit": limit}, timeout)
        row.setdefault("method", method)
        row.setdefault("solved", False)
        row["target_blocks"] = n
        if "failure" in row:
            row["status"] = row["failure"]
        runs.append(row)
        print(f"  largest {method}: {row.get('case', n)} ({row.get('blocks', '?')} blocks) {row.get('status')} "
              f"set-up {_fmt(row.get('setup_s'), '{:.3g}')} s solve {_fmt(row.get('solve_s'), '{:.3g}')} s",
              file=sys.stderr, flush=True)
        return row["solved"]

    lo, hi, n = None, None, start
    while n <= cap:
        if not attempt(n):
            hi = n
            break
        lo, n = n, 2 * n
    for _ in range(refine):
        if lo is None or hi is None:
            break
        mid = round(math.sqrt(lo * hi))
        if mid in (lo, hi) or wall_for(mid).n_free in {r.get("blocks") for r in runs}:
            break
        lo, hi = (mid, hi) if attempt(mid) else (lo, mid)
    ok = [r for r in runs if r["solved"]]
    best = max(ok, key=lambda r: r["blocks"]) if ok else None
    failed = [r for r in runs if not r["solved"]]
    fail = min(failed, key=lambda r: r.get("blocks", r["target_blocks"])) if failed else None
    if fail is None:
        first = f"none up to {runs[-1].get('blocks', '?')} blocks (raise --largest-max)" if runs else "-"
    else:
        first = f"{fail.get('case', '?')} ({fail.get('blocks', '?')} blocks): {fail.get('status')}"
    summary = {
        "method": method, "time_limit_s": limit,
        "largest_solved": f"{best['case']} ({best['blocks']} blocks)" if best else "none",
        "its_time_s": best["setup_s"] + best["solve_s"] if best else None,
        "first_unsolved": first,
    }
    return runs, summary


def parse_options(text: str) -> dict:
    """``"a=1,b=x,c=true"`` -> ``{"a": 1, "b": "x", "c": True}``."""
    out: dict = {}
    for item in (p for p in text.split(",") if p.strip()):
        key, _, value = item.partition("=")
        if not _:
            raise SystemExit(f"option {item!r}: expected KEY=VALUE")
        low = value.strip().lower()
        if low in ("true", "false"):
            out[key.strip()] = low == "true"
            continue
        for cast in (int, float):
            try:
                out[key.strip()] = cast(value)
                break
            except ValueError:
                pass
        else:
            out[key.strip()] = value.strip()
    return out


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns ``{"scaling": rows, "slopes": rows, "largest": rows, "largest_runs": rows}``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--families", default="wall,arch", help="comma-separated: wall, arch")
    parser.add_argument("--sizes", default="10,100,1000", help="target free blocks, comma-separated")
    parser.add_argument("--time-limit", type=float, default=120.0, help="seconds per solve (LP, fixed point)")
    parser.add_argument("--lp-method", default="static-lp")
    parser.add_argument("--fp-method", default="fixed-point")
    parser.add_argument("--lp-options", default="", help="KEY=VALUE,... for the LP method")
    parser.add_argument("--fp-options", default="", help="KEY=VALUE,... for the fixed-point method")
    parser.add_argument("--largest", default="milp,nlp", help="methods for the largest-size search ('' for none)")
    parser.add_argument("--largest-limit", type=float, default=60.0, help="seconds (set-up + solve) per run")
    parser.add_argument("--largest-start", type=int, default=4, help="blocks of the first wall of the search")
    parser.add_argument("--largest-max", type=int, default=128, help="largest wall (blocks) the search tries")
    parser.add_argument("--largest-refine", type=int, default=0,
                        help="bisection steps between the largest solved and the first unsolved size")
    parser.add_argument("--child-timeout", type=float, default=None,
                        help="wall-clock seconds per subprocess before it is killed "
                             "(default: 3 x time limit + 300 s for sizes; 2 x limit + 120 s for the search)")
    parser.add_argument("--tag", default="", help="suffix of the CSV file names")
    args = parser.parse_args(argv)

    if args.child:
        spec = json.loads(args.child)
        (child_scaling if spec["task"] == "scaling" else child_largest)(spec)
        return {}

    families = [f for f in args.families.split(",") if f]
    for f in families:
        if f not in FAMILIES:
            parser.error(f"--families: {f!r} is not one of {', '.join(FAMILIES)}")
    sizes = [int(v) for v in args.sizes.split(",") if v]
    lp_options, fp_options = parse_options(args.lp_options), parse_options(args.fp_options)
    largest = [m for m in args.largest.split(",") if m]
    try:  # an unknown method or a bad option fails here, not in every subprocess
        for method, options in ((args.lp_method, lp_options), (args.fp_method, fp_options)):
            bm.get_solver(method)(**options)
        for m in largest:
            bm.get_solver(m)
    except bm.BlockmpecError as exc:
        parser.error(str(exc))
    t_start = time.perf_counter()

    rows: list[dict] = []
    for family in families:
        for n in sizes:
            spec = {"task": "scaling", "family": family, "n": n, "time_limit": args.time_limit,
                    "lp_method": args.lp_method, "lp_options": lp_options,
                    "fp_method": args.fp_method, "fp_options": fp_options}
            row = run_child(spec, args.child_timeout or 3 * args.time_limit + 300)
            row.setdefault("family", family)
            row.setdefault("target_blocks", n)
            if "failure" in row:  # a stage that did not finish shows why
                for key in ("lp_status", "fp_status"):
                    row.setdefault(key, row["failure"])
            rows.append(row)
            print(f"{family} {row.get('blocks', n)} blocks: LP {row.get('lp_status')} "
                  f"{_fmt(row.get('lp_solve_s'), '{:.3g}')} s, FP {row.get('fp_status')} "
                  f"{_fmt(row.get('fp_total_s'), '{:.3g}')} s, peak {_fmt(row.get('peak_memory_mb'), '{:.0f}')} MB",
                  file=sys.stderr, flush=True)
    slopes = growth(rows)

    largest_runs: list[dict] = []
    largest_rows: list[dict] = []
    for m in largest:
        runs, summary = largest_search(m, args.largest_limit, args.largest_start, args.largest_max,
                                       args.child_timeout or 2 * args.largest_limit + 120, args.largest_refine)
        largest_runs += runs
        largest_rows.append(summary)

    lp_desc = args.lp_method + (f" ({args.lp_options})" if args.lp_options else "")
    fp_desc = args.fp_method + (f" ({args.fp_options})" if args.fp_options else "")
    print(f"## Cost per size (LP: {lp_desc}; FP: {fp_desc}; time limit {args.time_limit:g} s per solve)\n")
    print(markdown(rows, TABLE))
    print("\ngenerate = structure with interface detection; Pyomo build / compile = formulations.static_lp / "
          "compile_linear;\nLP set-up = the LP method's build + compile + load; FP total = fixed-point set-up + solve; "
          "peak MB = peak RSS of the size's subprocess.")
    print("\n## Growth exponents k (cost ~ blocks^k, log-log least squares)\n")
    print(markdown(slopes, [("family", "family", "{}"), ("column", "column", "{}"), ("sizes", "sizes", "{}"),
                            ("blocks", "blocks", "{}"), ("k_all", "k (all sizes)", "{:.2f}"),
                            ("k_two_largest", "k (two largest)", "{:.2f}")]))
    if largest_rows:
        print(f"\n## Largest running-bond wall solved within {args.largest_limit:g} s (set-up + solve; "
              f"sizes doubling from {args.largest_start} to at most {args.largest_max} blocks)\n")
        print(markdown(largest_rows, [("method", "method", "{}"), ("largest_solved", "largest solved", "{}"),
                                      ("its_time_s", "its time s", "{:.3g}"),
                                      ("first_unsolved", "first unsolved", "{}")]))

    OUT.mkdir(parents=True, exist_ok=True)
    suffix = f"_{args.tag}" if args.tag else ""
    written = []
    for name, data in (("scaling", rows), ("slopes", slopes), ("largest", largest_runs)):
        if data:
            write_csv(OUT / f"{name}{suffix}.csv", data)
            written.append(f"{name}{suffix}.csv")
    print(f"\nwrote {', '.join(written)} in {OUT} ({time.perf_counter() - t_start:.0f} s)")
    return {"scaling": rows, "slopes": slopes, "largest": largest_rows, "largest_runs": largest_runs}


if __name__ == "__main__":
    main()
