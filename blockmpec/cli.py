"""Command line: ``blockmpec solve | export | cases | methods | compare``.

The spellings here are a contract with scripts outside this repo: extend, never rename.
Errors go to stderr as one line, with exit code 2 (bad input) or 3 (internal error),
and no traceback (``--debug`` shows it).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from blockmpec.cases import CASES, get_case
from blockmpec.errors import BlockmpecError, OptionError
from blockmpec.geometry import Structure
from blockmpec.registry import get_solver, list_solvers
from blockmpec.result import Result
from blockmpec.solver import option_fields, solve
from blockmpec.structure_file import load_structure, save_structure

#: The built-in benchmark suite of ``blockmpec compare``: label -> (case, parameters).
#: Sizes keep the default run (every method, with the time limits of
#: ``BENCHMARK_METHOD_OPTIONS``) within a few minutes on 2 cores.
BENCHMARK_SUITE: dict[str, tuple[str, dict[str, Any]]] = {
    "two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65}),
    "round-arch": ("round-arch", {}),
    "arch-on-buttresses": ("arch-on-buttresses", {}),
    "wall-4x2-stack": ("wall", {"courses": 4, "blocks_per_course": 2, "bond": "stack"}),
    "wall-5x4": ("wall", {"courses": 5, "blocks_per_course": 4}),
    "wall-10x5": ("wall", {"courses": 10, "blocks_per_course": 5}),
}


def parse_value(text: str) -> Any:
    """A ``-p``/``-O`` value: JSON if it parses (numbers, lists, true/false), else the string."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def parse_pairs(pairs: list[str] | None, flag: str) -> dict[str, Any]:
    """``["k=v", ...]`` -> ``{k: parse_value(v)}``; a pair without ``=`` is an OptionError."""
    out: dict[str, Any] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise OptionError(f"{flag} {pair!r}: expected KEY=VALUE")
        out[key.strip()] = parse_value(value.strip())
    return out


def load_case(case: str, params: dict[str, Any]) -> Structure:
    """A built-in case name or a structure file path, with parameters applied."""
    if case in CASES:
        return get_case(case).build(**params)
    path = Path(case)
    if path.suffix.lower() == ".json" or path.exists():
        structure = load_structure(path)
        unknown = sorted(set(params) - {"mu", "dilatancy"})
        if unknown:
            raise OptionError(f"structure file {case}: only mu and dilatancy can be set with -p; got {unknown[0]!r}")
        return structure.with_material(params.get("mu"), params.get("dilatancy"))
    raise OptionError(f"unknown case {case!r}: not a built-in case ({', '.join(CASES)}) nor a structure file")


def _format_result(label: str, r: Result) -> str:
    lam = "—" if r.multiplier is None else f"{r.multiplier:.6g}"
    return (f"{label}: method={r.method} status={r.status.value} success={r.success} lambda={lam} "
            f"max_residual={r.max_residual:.2e} time={r.solve_time_s:.3g}s iterations={r.iterations}"
            + (f"\n  {r.message}" if r.message and not r.success else ""))


def cmd_solve(args: argparse.Namespace) -> int:
    params = parse_pairs(args.param, "-p")
    options = parse_pairs(args.option, "-O")
    structure = load_case(args.case, params)
    result = solve(structure, args.method, verify_tol=args.verify_tol, **options)
    if args.json:
        out = result.to_dict()
        out["case"] = args.case
        out["parameters"] = params
        print(json.dumps(out))
    else:
        print(_format_result(args.case, result))
        for name, value in result.residuals.items():
            print(f"  {name:28s} {value:.3e}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    structure = load_case(args.case, parse_pairs(args.param, "-p"))
    save_structure(structure, args.output)
    print(f"wrote {args.output} ({structure.n_blocks} blocks, {len(structure.interfaces)} interfaces)")
    return 0


def cmd_cases(args: argparse.Namespace) -> int:
    for spec in CASES.values():
        print(f"{spec.name}: {spec.summary}")
        for key, default in spec.parameters.items():
            print(f"    {key} = {default!r}")
    return 0


def cmd_methods(args: argparse.Namespace) -> int:
    from blockmpec.solvers import FAILED_PLUGINS

    for module, error in FAILED_PLUGINS.items():
        print(f"solvers/{module}.py failed to import: {error}", file=sys.stderr)
    for name in list_solvers():
        cls = get_solver(name)
        reason = cls.unavailable_reason()
        state = "available" if reason is None else f"unavailable: {reason}"
        print(f"{name} [{cls.problem}] {cls.summary} ({state})")
        for key, typ, default, help_text in option_fields(cls):
            typ_name = getattr(typ, "__name__", str(typ))
            print(f"    {key}: {typ_name} = {default!r}" + (f"  -- {help_text}" if help_text else ""))
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from blockmpec.compare import BENCHMARK_METHOD_OPTIONS, ProgressBar, compare, write_tables

    labels = list(BENCHMARK_SUITE) if not args.cases else [c.strip() for c in args.cases.split(",") if c.strip()]
    for label in labels:
        if label not in BENCHMARK_SUITE:
            raise OptionError(f"--cases: unknown suite case {label!r}; choose from {', '.join(BENCHMARK_SUITE)}")
    methods = list_solvers() if not args.methods else [m.strip() for m in args.methods.split(",") if m.strip()]
    for m in methods:
        get_solver(m)
    if args.repeat < 1:
        raise OptionError(f"--repeat: must be >= 1; got {args.repeat}")
    options: dict[str, dict[str, Any]] = {m: dict(BENCHMARK_METHOD_OPTIONS.get(m, {})) for m in methods}
    for key, value in parse_pairs(args.option, "-O").items():
        method, dot, name = key.partition(".")
        if not dot or method not in options:
            raise OptionError(f"-O {key}={value}: expected METHOD.OPTION=VALUE "
                              f"with METHOD one of {', '.join(methods)}")
        options[method][name] = value
    out_dir = Path(args.out)
    t0 = time.perf_counter()
    results: dict = {}
    df = compare({lbl: BENCHMARK_SUITE[lbl] for lbl in labels}, [(m, m, options[m]) for m in methods],
                 repeat=args.repeat, progress=None if args.quiet else ProgressBar(), results=results)
    wall_time = time.perf_counter() - t0
    paths = write_tables(df, out_dir)
    print(_table(df, "multiplier", "{:.5f}", "Collapse multiplier lambda (cf. the paper's Table 1)", reference=True))
    print()
    print(_table(df, "friction_admissibility", "{:.1e}",
                 "Friction admissibility error ||(N_f^T x)+|| / ||N_f^T x|| (cf. the paper's Table 2)"))
    print()
    print(_table(df, "solve_time_s", "{:.3g}", "Solve time [s] (set-up excluded"
                 + (f"; median of {args.repeat} runs)" if args.repeat > 1 else ")"), median=True))
    anomalies = df[df["anomaly"].astype(str) != ""]
    for _, r in anomalies.iterrows():
        print(f"ANOMALY {r['case']} · {r['method_label']}: {r['anomaly']} (lam {r['multiplier']:.8g}, "
              f"reference {r['reference']:.8g})")
    if not args.no_figures:
        from blockmpec.plot import comparison_figures

        try:
            paths += comparison_figures(df, results, out_dir)
        except Exception as exc:  # figures are a convenience: tables are already written
            print(f"figures failed: {type(exc).__name__}: {exc}", file=sys.stderr)
    print(f"\nran {len(df)} solves in {wall_time:.1f} s; wrote {len(paths)} file(s) into {out_dir.resolve()}")
    for p in paths[:2]:
        print(f"  {p}")
    return 0


def _table(df, key: str, fmt: str, title: str, reference: bool = False, median: bool = False) -> str:
    """A ``case x method`` text table of column ``key`` of the comparison table ``df``."""
    from blockmpec.compare import text_table

    note = ("NA reference: c = certified minimum (MILP), b = best verified value of the run, f = closed form"
            if reference else "")
    return text_table(df, key, fmt, title, reference=reference, note=note, median=median)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="blockmpec", description=__doc__.splitlines()[0])
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("solve", help="solve one case with one method")
    p.add_argument("case", help="built-in case name or structure file (.json)")
    p.add_argument("--method", "-m", required=True, help="method name (see `blockmpec methods`)")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE", help="case parameter")
    p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE", help="method option")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--verify-tol", type=float, default=1e-6, help="largest residual accepted as success")
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser("export", help="write a built-in case as a structure file")
    p.add_argument("case")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE")
    p.add_argument("-o", "--output", required=True, metavar="FILE.json")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("cases", help="list built-in cases and their parameters")
    p.set_defaults(func=cmd_cases)
    p = sub.add_parser("methods", help="list methods and their options")
    p.set_defaults(func=cmd_methods)

    p = sub.add_parser("compare", help="run methods over the benchmark suite and print tables (the main job)")
    p.add_argument("--cases", default="", help=f"comma-separated subset of: {', '.join(BENCHMARK_SUITE)}")
    p.add_argument("--methods", default="", help="comma-separated method names (default: all)")
    p.add_argument("--repeat", type=int, default=1, help="repetitions per case and method")
    p.add_argument("--out", default="blockmpec-output", help="output folder (default: ./blockmpec-output)")
    p.add_argument("-O", "--option", action="append", metavar="METHOD.KEY=VALUE",
                   help="method option, e.g. -O milp.time_limit=120 (overrides the suite's defaults)")
    p.add_argument("--no-figures", action="store_true", help="write the tables only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except BlockmpecError as exc:
        print(f"blockmpec: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # pragma: no cover - last resort, still no traceback by default
        if args.debug:
            raise
        print(f"blockmpec: internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)",
              file=sys.stderr)
        return 3


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
