"""Command line: ``blockmpec solve | export | import | cases | methods | compare | pushover`` (and ``blockmpec --version``).

``blockmpec methods --json`` prints every method's name, problem, summary, availability and user-facing options
(name, type, default, help) as one JSON list (:func:`method_listing`).

The spellings here are a contract with scripts outside this repo: extend, never rename.
Errors go to stderr as one line, with exit code 2 (bad input) or 3 (internal error),
and no traceback (``--debug`` shows it).

Exit codes
----------
``solve``: 0 = verified success; 1 = ran, but no verified success (the status says why);
2 = bad input or usage; 3 = internal error.  ``compare``: 0 when every run finished,
whatever the statuses; 2 = bad input (every value, including the output folder, is
checked before any solve runs); 130 after Ctrl-C (143 after SIGTERM), once the finished
rows are saved.  ``pushover``: 0 when every curve's undeformed structure was solved, whatever
ended the curve (:mod:`blockmpec.pushover`), 1 otherwise.  ``export``, ``cases``, ``methods``: 0, 2 or 3.
Any command whose output's reader has gone (``blockmpec methods | head``) stops quietly with 141, the shell's code for a SIGPIPE.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

from blockmpec.bench.suite import BENCHMARK_SUITE
from blockmpec.cases import CASES, load_case
from blockmpec.drawings import DrawingWarning
from blockmpec.errors import BlockmpecError, OptionError
from blockmpec.registry import get_solver, list_solvers, solver_source
from blockmpec.result import Result
from blockmpec.solver import option_fields, solve
from blockmpec.structure_file import save_structure


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


def _format_result(label: str, r: Result) -> str:
    lam = "—" if r.multiplier is None else f"{r.multiplier:.6g}"
    return (f"{label}: method={r.method} status={r.status.value} success={r.success} lambda={lam} "
            f"max_residual={r.max_residual:.2e} time={r.solve_time_s:.3g}s iterations={r.iterations}"
            + (f"\n  {r.message}" if r.message and not r.success else ""))


@contextlib.contextmanager
def _stdout_to_stderr():
    """Send everything written to file descriptor 1 meanwhile to stderr.

    ``solve --json`` promises one JSON object on stdout, but compiled solvers write there
    directly (HiGHS 1.16 prints its licence banner when the first instance is created), past
    ``sys.stdout``.  So for the solve, descriptor 1 points at stderr; nothing is lost, and
    stdout carries only the JSON.  Where stdout has no descriptor (an in-process caller's
    buffer) nothing is redirected.
    """
    try:
        stdout_fd = sys.stdout.fileno()
    except (AttributeError, ValueError, io.UnsupportedOperation):
        yield
        return
    sys.stdout.flush()
    saved = os.dup(stdout_fd)
    try:
        os.dup2(sys.stderr.fileno(), stdout_fd)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, stdout_fd)
        os.close(saved)


def _output_file(path: str | None, flag: str, example: str) -> Path | None:
    """The file a ``solve`` table will be written to, checked before the solve (a bad path: OptionError)."""
    if path is None:
        return None
    out = Path(path)
    if out.is_dir():
        raise OptionError(f"{flag} {path}: is a folder; give a file name such as {out / example}")
    if not out.parent.is_dir():
        raise OptionError(f"{flag} {path}: folder {out.parent} does not exist")
    if not os.access(out if out.exists() else out.parent, os.W_OK):
        raise OptionError(f"{flag} {path}: cannot write there (permission denied)")
    return out


def _write_table(frame: Any, path: Path, flag: str) -> None:
    try:
        frame.to_csv(path, index=False)
    except OSError as exc:
        raise OptionError(f"{flag} {path}: cannot write ({exc.strerror or exc})") from None


def cmd_solve(args: argparse.Namespace) -> int:
    from blockmpec.bench.study import check_tolerance

    verify_tol = check_tolerance(args.verify_tol)
    forces_path = _output_file(args.forces, "--forces", "forces.csv")
    mechanism_path = _output_file(args.mechanism, "--mechanism", "mechanism.csv")
    if forces_path is not None and mechanism_path is not None and forces_path.resolve() == mechanism_path.resolve():
        raise OptionError(f"--forces and --mechanism: both name {args.forces}; give two files")
    params = parse_pairs(args.param, "-p")
    options = parse_pairs(args.option, "-O")
    get_solver(args.method)(**options)  # unknown method / bad option: exit 2 before building anything
    if args.export_drawing:
        from blockmpec.drawings.export import check_export_path

        check_export_path(args.export_drawing)
    plot_path = _output_file(args.plot, "--plot", "mechanism.png")
    if plot_path is not None:
        _check_figure_format(plot_path)
    mesh_path = _output_file(args.export_mesh, "--export-mesh", "mechanism.obj")
    structure = _load(args.case, params, sys.stderr if args.json else sys.stdout)
    _check_dimension(structure, args, mesh_path)
    with _stdout_to_stderr() if args.json else contextlib.nullcontext():
        result = solve(structure, args.method, verify_tol=verify_tol, **options)
    if args.json:
        out = result.to_dict()
        out["case"] = args.case
        out["parameters"] = params
        print(json.dumps(out))
    else:
        print(_format_result(args.case, result))
        for name, value in result.residuals.items():
            print(f"  {name:28s} {value:.3e}")
    for path, flag, frame, rows, what in (
            (forces_path, "--forces", lambda: result.forces, "interfaces", "interface forces"),
            (mechanism_path, "--mechanism", lambda: result.mechanism, "free blocks", "mechanism")):
        if path is not None:
            table = frame()
            _write_table(table, path, flag)
            if not args.json:
                print(f"wrote {path} ({len(table)} {rows})" if len(table) else
                      f"wrote {path} (column names only: the result has no {what})")
    if args.export_drawing:
        from blockmpec.drawings import export_drawing, is_drawing

        written = export_drawing(structure, result, args.export_drawing,
                                 source=args.case if is_drawing(args.case) else None)
        print(f"wrote {written}", file=sys.stderr if args.json else sys.stdout)
    if plot_path is not None:
        _plot_mechanism(structure, result, plot_path)
        print(f"wrote {plot_path}", file=sys.stderr if args.json else sys.stdout)
    if mesh_path is not None:
        from blockmpec.three_d.plot import export_mechanism

        export_mechanism(result, structure, mesh_path)
        print(f"wrote {mesh_path}", file=sys.stderr if args.json else sys.stdout)
    return 0 if result.success else 1


def _check_dimension(structure: Any, args: argparse.Namespace, mesh_path: Path | None) -> None:
    """The 2D-only and 3D-only outputs of ``solve``: one line naming the option that does not fit the structure."""
    three_d = getattr(structure, "dim", 2) == 3
    if three_d and args.export_drawing:
        raise OptionError("--export-drawing: a 3D structure has no drawing; write the mechanism as a mesh with "
                          "--export-mesh FILE.obj")
    if not three_d and mesh_path is not None:
        raise OptionError("--export-mesh: only for a 3D structure; for a 2D one use --export-drawing or --plot")
    if three_d and mesh_path is not None and mesh_path.suffix.lower() not in (".obj", ".stl", ".ply"):
        raise OptionError(f"--export-mesh {mesh_path}: give a .obj, .stl or .ply file")


def _check_figure_format(path: Path) -> None:
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix.lstrip(".").lower()
    if suffix not in formats:
        raise OptionError(f"--plot {path}: unknown figure format {path.suffix or '(no suffix)'!r}; "
                          f"use one of {', '.join('.' + f for f in sorted(formats))}")


def _plot_mechanism(structure: Any, result: Any, path: Path) -> None:
    """The figure of ``solve --plot``: the mechanism (hinges, sliding joints) with its legend; a figure outside
    pyplot, so no backend is chosen and nothing is left to close."""
    from matplotlib.figure import Figure

    from blockmpec import plot

    if getattr(structure, "dim", 2) == 3:
        fig = Figure(figsize=(8, 7), layout="constrained")
        plot.mechanism(result, structure, ax=fig.add_subplot(projection="3d"))
        try:
            fig.savefig(path, dpi=150)
        except OSError as exc:
            raise OptionError(f"--plot {path}: cannot write ({exc.strerror or exc})") from None
        return
    x, y = structure.vertices[..., 0], structure.vertices[..., 1]
    aspect = float(y.max() - y.min()) / max(float(x.max() - x.min()), 1e-300)
    fig = Figure(figsize=(9, max(2.5, min(9.0, 6.5 * aspect + 0.8))), layout="constrained")
    plot.mechanism(result, structure, ax=fig.add_subplot())
    try:
        fig.savefig(path, dpi=150, bbox_inches="tight")
    except OSError as exc:
        raise OptionError(f"--plot {path}: cannot write ({exc.strerror or exc})") from None


def cmd_export(args: argparse.Namespace) -> int:
    out = Path(args.output)
    if out.is_dir():
        raise OptionError(f"-o {args.output}: is a folder; give a file name such as {out / 'structure.json'}")
    if not out.parent.is_dir():
        raise OptionError(f"-o {args.output}: folder {out.parent} does not exist")
    structure = _load(args.case, parse_pairs(args.param, "-p"), sys.stdout)
    three_d = getattr(structure, "dim", 2) == 3
    try:
        save_structure(structure, args.output)
    except OSError as exc:
        raise OptionError(f"-o {args.output}: cannot write ({exc.strerror or exc})") from None
    print(f"wrote {args.output} ({structure.n_blocks} blocks, "
          f"{len(structure.contacts if three_d else structure.interfaces)} interfaces)")
    return 0


def cmd_pushover(args: argparse.Namespace) -> int:
    from blockmpec.bench.study import check_tolerance
    from blockmpec.pushover_cli import run_command

    verify_tol = check_tolerance(args.verify_tol)
    pairs = parse_pairs(args.option, "-O")
    return run_command(args, lambda: _load(args.case, parse_pairs(args.param, "-p"), sys.stdout), pairs, verify_tol)


def _load(case: str, params: dict[str, Any], stream) -> Any:
    """``load_case``; for a drawing, its reader's summary line (what it read and skipped) goes to ``stream``."""
    structure = load_case(case, params)
    from blockmpec.drawings import is_drawing

    if is_drawing(case):
        print(f"{case}: {structure.metadata['drawing']['summary']}", file=stream)
    return structure


def cmd_import(args: argparse.Namespace) -> int:
    """``blockmpec import DRAWING -o FILE.json``: a drawing or image as a structure file."""
    from blockmpec.drawings import is_drawing

    if not is_drawing(args.drawing):
        from blockmpec.drawings import SUFFIXES

        raise OptionError(f"{args.drawing}: not a drawing or image (suffixes: {', '.join(SUFFIXES)})")
    out = Path(args.output)
    if out.is_dir() or not out.parent.is_dir():
        raise OptionError(f"-o {args.output}: " + ("is a folder" if out.is_dir() else f"folder {out.parent} does not exist"))
    structure = _load(args.drawing, parse_pairs(args.param, "-p"), sys.stdout)
    try:
        save_structure(structure, args.output)
    except OSError as exc:
        raise OptionError(f"-o {args.output}: cannot write ({exc.strerror or exc})") from None
    snapping = structure.metadata.get("snapping", {})
    moved = len(snapping.get("vertices", []))
    print(f"wrote {args.output} ({structure.n_blocks} blocks, {int(structure.fixed.sum())} fixed, "
          f"{len(structure.interfaces)} interfaces; snapped {moved} vertices"
          + (f", largest move {snapping['largest']:.3g}" if moved else "") + ")")
    return 0


def _import_epilog() -> str:
    from blockmpec.drawings import READERS, reader_options

    lines = ["options (-p KEY=VALUE) of each kind of file:"]
    for suffix in (".dxf", ".svg", ".png"):
        kinds = ", ".join(s for s, r in READERS.items() if r == READERS[suffix])
        lines.append(f"  {kinds}: " + ", ".join(f"{k}={v!r}" for k, v in reader_options(suffix).items()))
    return "\n".join(lines)


def cmd_cases(args: argparse.Namespace) -> int:
    for spec in CASES.values():
        print(f"{spec.name}: {spec.summary}")
        for key, default in spec.parameters.items():
            print(f"    {key} = {default!r}")
    return 0


def _json_value(value: Any) -> Any:
    """A default as strict JSON: non-finite floats as the strings "inf", "-inf", "nan" (what ``-O`` also reads)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)):
        return [_json_value(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _json_value(v) for k, v in value.items()}
    return str(value)


def method_listing() -> list[dict[str, Any]]:
    """What ``blockmpec methods --json`` prints: one object per method, with its user-facing options.

    Keys: ``name``, ``problem``, ``summary``, ``available`` (bool), ``unavailable_reason`` (None when
    available), ``certifies_minimum`` (bool), ``source`` (``"built-in"``, or where a plug-in came from:
    :func:`blockmpec.registry.solver_source`) and ``options``: a list of ``{name, type, default, help}``
    (``type`` the Python type's name, ``default`` as JSON, non-finite numbers as "inf"/"-inf"/"nan").
    """
    out = []
    for name in list_solvers():
        cls = get_solver(name)
        reason = cls.unavailable_reason()
        options = [{"name": key, "type": getattr(typ, "__name__", str(typ)), "default": _json_value(default),
                    "help": help_text} for key, typ, default, help_text in option_fields(cls)]
        out.append({"name": name, "problem": cls.problem, "summary": cls.summary, "available": reason is None,
                    "unavailable_reason": reason, "certifies_minimum": bool(getattr(cls, "certifies_minimum", False)),
                    "source": solver_source(name), "options": options})
    return out


def cmd_methods(args: argparse.Namespace) -> int:
    from blockmpec.solvers import FAILED_PLUGINS

    for module, error in FAILED_PLUGINS.items():
        print(f"solvers/{module}.py failed to import: {error}", file=sys.stderr)
    if args.json:
        print(json.dumps(method_listing(), allow_nan=False))
        return 0
    for name in list_solvers():
        cls = get_solver(name)
        reason = cls.unavailable_reason()
        state = "available" if reason is None else f"unavailable: {reason}"
        source = solver_source(name)
        print(f"{name} [{cls.problem}] {cls.summary} ({state})" + ("" if source == "built-in" else f"; {source}"))
        for key, typ, default, help_text in option_fields(cls):
            typ_name = getattr(typ, "__name__", str(typ))
            print(f"    {key}: {typ_name} = {default!r}" + (f"  -- {help_text}" if help_text else ""))
    return 0


def compare_cases(items: list[str]) -> list[Any]:
    """``--cases`` items as :class:`~blockmpec.bench.compare.CaseRun`: suite labels, built-in case names
    (default parameters) and structure files; each is built now, so a bad one is an error before
    any solve."""
    from blockmpec.bench.compare import CaseRun
    from blockmpec.operators import assemble

    out = []
    for item in items:
        if item in BENCHMARK_SUITE:
            name, params = BENCHMARK_SUITE[item]
            run = CaseRun(item, name, dict(params))
        elif item in CASES:
            run = CaseRun(item, item, {})
        elif item.lower().endswith(".json") or Path(item).exists():
            run = CaseRun(Path(item).stem, None, {}, _load(item, {}, sys.stderr))
        else:
            raise OptionError(f"--cases: {item!r} is not a suite case ({', '.join(BENCHMARK_SUITE)}), a built-in "
                              f"case ({', '.join(CASES)}) nor a structure file")
        out.append(_built(run, assemble))
    return out


def _built(run, assemble):
    """The case run with its structure built and assembled (errors name the case)."""
    import dataclasses

    try:
        structure = run.structure if run.structure is not None else load_case(run.name, run.params)
        assemble(structure)
    except BlockmpecError as exc:
        raise OptionError(f"case {run.label!r}: {exc}") from None
    return dataclasses.replace(run, structure=structure)


def _seconds_arg(values: list[str] | None, flag: str, what: str, allow_inf: bool) -> dict[str, float] | None:
    """``FLAG SECONDS`` (key ``"*"``: every one) or ``FLAG NAME=SECONDS`` (repeatable)."""
    out: dict[str, float] = {}
    for text in values or []:
        key, sep, value = text.rpartition("=")
        try:
            seconds = float(value)
        except ValueError:
            seconds = float("nan")
        if not (seconds > 0 and (allow_inf or seconds < float("inf"))):
            number = "a number > 0 (inf: none)" if allow_inf else "a finite number > 0"
            raise OptionError(f"{flag} {text}: expected SECONDS or {what}=SECONDS with {number}")
        out[key if sep else "*"] = seconds
    return out or None


def _wall_limit_arg(values: list[str] | None) -> dict[str, float] | None:
    """``--wall-limit 90`` (every method) or ``--wall-limit milp=90`` (repeatable); ``inf``: no limit."""
    return _seconds_arg(values, "--wall-limit", "METHOD", allow_inf=True)


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C (the finished rows are saved), exit code 143."""

    signal_name = "SIGTERM"


def _on_sigterm(signum, frame):  # pragma: no cover - exercised through a subprocess
    raise Terminated()


def cmd_compare(args: argparse.Namespace) -> int:
    import signal

    from blockmpec.bench.compare import (
        BENCHMARK_METHOD_OPTIONS,
        ComparisonInterrupted,
        MethodRun,
        compare,
        normalise_cases,
        normalise_methods,
    )
    from blockmpec.bench.runner import check_backend
    from blockmpec.bench.study import ResultsFolder, check_tolerance, load_study, run_metadata

    # ---- every input is checked before anything runs
    study = load_study(args.config) if args.config else None
    if study is not None and args.cases:
        raise OptionError("--cases and --config: give the cases in one place")
    if study is not None and args.methods:
        raise OptionError("--methods and --config: give the methods in one place")
    verify_tol = check_tolerance(args.verify_tol if args.verify_tol is not None
                                 else (study.verify_tol if study else 1e-6))
    repeat = args.repeat if args.repeat is not None else (study.repeat if study else 1)
    if repeat < 1:
        raise OptionError(f"--repeat: must be >= 1; got {repeat}")
    jobs = args.jobs if args.jobs is not None else (study.jobs if study and study.jobs else 1)
    backend = args.backend or (study.backend if study else None)
    scheduler = args.scheduler or (study.scheduler if study else None)
    check_backend(jobs, backend, scheduler)
    if study is not None:
        case_runs = [_built(c, __import__("blockmpec.operators", fromlist=["assemble"]).assemble) for c in study.cases]
        method_runs = list(study.methods)
    else:
        items = list(BENCHMARK_SUITE) if not args.cases else [c.strip() for c in args.cases.split(",") if c.strip()]
        case_runs = compare_cases(items)
        names = list_solvers() if not args.methods else [m.strip() for m in args.methods.split(",") if m.strip()]
        for m in names:
            get_solver(m)
        method_runs = [MethodRun(m, m, dict(BENCHMARK_METHOD_OPTIONS.get(m, {}))) for m in names]
    for key, value in parse_pairs(args.option, "-O").items():
        method, dot, name = key.partition(".")
        hits = [m for m in method_runs if m.name == method]
        if not dot or not hits:
            raise OptionError(f"-O {key}={value}: expected METHOD.OPTION=VALUE "
                              f"with METHOD one of {', '.join(dict.fromkeys(m.name for m in method_runs))}")
        for m in hits:
            m.options[name] = value
    try:
        case_runs = normalise_cases(case_runs)
        method_runs = normalise_methods(method_runs)
    except (ValueError, TypeError) as exc:
        if isinstance(exc, BlockmpecError):
            raise
        raise OptionError(str(exc)) from None
    limits = dict(study.wall_limits) if study else {}
    given = _wall_limit_arg(args.wall_limit)
    if given:
        every = given.pop("*", None)
        if every is not None:
            limits = {m.label: every for m in method_runs}
        for key in given:
            if not any(key in (m.label, m.name) for m in method_runs):
                raise OptionError(f"--wall-limit {key}=...: no method or label {key!r} in this run")
        limits.update(given)
    budget = _budget_arg(args.budget, study, [c.label for c in case_runs])
    folder = ResultsFolder(args.out, overwrite=args.overwrite, resume=args.resume)
    try:
        return _run_compare(args, folder, case_runs, method_runs, repeat, verify_tol, jobs, backend, scheduler,
                            limits or None, compare, ComparisonInterrupted, run_metadata, signal, budget)
    finally:
        folder.close()


def _budget_arg(values: list[str] | None, study: Any, cases: list[str]) -> float | dict[str, float] | None:
    """``--budget SECONDS`` (every case) or ``--budget CASE=SECONDS`` (repeatable), over the study file's
    ``budget``; None: each case's default (the largest wall-clock limit of its runs)."""
    from blockmpec.bench.profiles import check_budget

    given = _seconds_arg(values, "--budget", "CASE", allow_inf=False)
    if not given:
        return study.budget if study is not None else None
    every = given.pop("*", None)
    for key in given:
        if key not in cases:
            raise OptionError(f"--budget {key}=...: no case {key!r} in this run; cases: {', '.join(cases)}")
    if not given:
        return every
    base = {c: every for c in cases} if every is not None else (
        dict(study.budget) if study is not None and isinstance(study.budget, dict) else
        {c: study.budget for c in cases} if study is not None and study.budget is not None else {})
    return check_budget({**base, **given}, cases)


def _run_compare(args, folder, case_runs, method_runs, repeat, verify_tol, jobs, backend, scheduler, limits,
                 compare, ComparisonInterrupted, run_metadata, signal, budget) -> int:
    from datetime import datetime, timezone

    from blockmpec.bench.runner import shared_cpus

    out_dir = folder.path
    settings = {"cases": [c.label for c in case_runs], "methods": {m.label: [m.name, m.options] for m in method_runs},
                "repeat": repeat, "verify_tol": verify_tol, "jobs": jobs, "backend": backend or "serial",
                "scheduler": scheduler, "wall_limits": limits, "budget": budget, "resume": args.resume,
                "config": args.config,
                # what each solve's automatic settings may use (BLOCKMPEC_CPUS); a cluster's machines are its own
                "cpus_per_solve": None if scheduler else shared_cpus(jobs or 1)}
    meta = run_metadata(["blockmpec", *sys.argv[1:]] if sys.argv and "blockmpec" in sys.argv[0] else sys.argv,
                        settings)
    folder.write_metadata(meta)
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    t0 = time.perf_counter()
    results: dict = {}
    try:
        df = compare(case_runs, method_runs, repeat=repeat, progress=False if args.quiet else None,
                     verify_tol=verify_tol, results=results, n_jobs=jobs, backend=backend, scheduler=scheduler,
                     wall_limit=limits, out=folder, resume=args.resume, budget=budget)
    except ComparisonInterrupted as exc:
        kept, ran = _kept_and_ran(exc.table)
        meta.update(finished=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                    interrupted=exc.signal_name, rows=len(exc.table), rows_kept=kept, rows_run=ran,
                    wall_time_s=time.perf_counter() - t0)
        folder.write_metadata(meta)
        how = f" ({ran} run now, {kept} kept from the earlier run)" if kept else ""
        print(f"blockmpec: interrupted ({exc.signal_name}): {len(exc.table)} finished row(s) saved{how} in "
              f"{out_dir / 'results.csv'}; rerun with --resume to continue", file=sys.stderr)
        return 143 if exc.signal_name == "SIGTERM" else 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    wall_time = time.perf_counter() - t0
    from blockmpec.bench.profiles import summary_table, summary_text

    summary = summary_table(df, budget=budget)
    paths = [out_dir / "results.csv", out_dir / "results.parquet"]
    paths += folder.write_tables(summary, stem="summary")[:1]
    print(_table(df, "multiplier", "{:.5f}", "Collapse multiplier lambda (cf. the paper's Table 1)", reference=True))
    print()
    print(_table(df, "friction_admissibility", "{:.1e}",
                 "Friction admissibility error ||(N_f^T x)+|| / ||N_f^T x|| (cf. the paper's Table 2)"))
    print()
    print(_table(df, "solve_time_s", "{:.3g}", "Solve time [s] (set-up excluded"
                 + (f"; median of {repeat} runs)" if repeat > 1 else ")"), median=True))
    print()
    print(summary_text(summary))
    anomalies = df[~df["anomaly"].astype(str).isin(["", "nan", "None"])]
    for _, r in anomalies.iterrows():
        print(f"ANOMALY {r['case']} · {r['method_label']}: {r['anomaly']} (lam {r['multiplier']:.8g}, "
              f"reference {r['reference']:.8g} from {r['reference_source']}"
              f"{' ' + r['reference_method'] if r['reference_method'] else ''}): a verified value that cannot be "
              "right; check the certificate and the point")
    if len(anomalies):
        print(f"blockmpec: warning: {len(anomalies)} ANOMALY line(s) after the tables (column anomaly of "
              "results.csv): a verified value below a certified or closed-form minimum, or above the associative "
              "multiplier, is a bug", file=sys.stderr)
    for stale in out_dir.glob("*.png"):  # figures of an earlier state of a resumed run
        stale.unlink()
    if not args.no_figures:
        from blockmpec.bench.plots import comparison_figures

        try:
            paths += comparison_figures(df, results, out_dir, budget=budget)
        except Exception as exc:  # figures are a convenience: tables are already written
            print(f"figures failed: {type(exc).__name__}: {exc}", file=sys.stderr)
    kept, ran = _kept_and_ran(df)
    meta.update(finished=datetime.now(timezone.utc).isoformat(timespec="seconds"), rows=len(df), rows_kept=kept,
                rows_run=ran, wall_time_s=wall_time)
    paths.append(folder.write_metadata(meta))
    kept_text = f" and kept {kept} finished row(s) of the earlier run" if args.resume else ""
    print(f"\nran {ran} solve(s) in {wall_time:.1f} s{kept_text}; {len(df)} row(s); wrote {len(paths)} file(s) "
          f"into {out_dir.resolve()}")
    for p in paths[:3]:
        print(f"  {p}")
    return 0


def _kept_and_ran(df) -> tuple[int, int]:
    """Rows kept from an earlier run (``--resume``) and rows finished by this one."""
    kept = int(df["resumed"].astype(bool).sum()) if "resumed" in df.columns and len(df) else 0
    return kept, len(df) - kept


def _table(df, key: str, fmt: str, title: str, reference: bool = False, median: bool = False) -> str:
    """A ``case x method`` text table of column ``key`` of the comparison table ``df``."""
    from blockmpec.bench.compare import text_table

    note = ("NA reference (for a method that produced nothing): f = closed form, c = certified minimum, "
            "b = best verified value; after the colon the method that produced it.\n"
            "No method is graded against a value only it produced (results.csv: reference_method, reference_note)."
            if reference else "")
    return text_table(df, key, fmt, title, reference=reference, note=note, median=median)


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser whose usage errors are one line, ``blockmpec: error: ...`` (exit 2), not the whole
    usage; ``--help`` prints the usage in full as before."""

    def error(self, message: str):
        command = self.prog.partition(" ")[2]
        where = f"{command}: " if command else ""
        self.exit(2, f"blockmpec: error: {where}{message} (blockmpec {command + ' ' if command else ''}--help for "
                     "the usage)\n")


def build_parser() -> argparse.ArgumentParser:
    from blockmpec import __version__

    parser = OneLineParser(prog="blockmpec", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"blockmpec {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("solve", help="solve one case with one method")
    p.add_argument("case", help="built-in case name, structure file (.json), drawing (.dxf, .svg, an image) or 3D "
                   "mesh (.obj, .stl, .ply)")
    p.add_argument("--method", "-m", required=True, help="method name (see `blockmpec methods`), or MODULE:CLASS "
                   "for a SolverBase subclass not installed as a plug-in (the current folder is searched too)")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE", help="case parameter")
    p.add_argument("-O", "--option", action="append", metavar="KEY=VALUE", help="method option")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--verify-tol", default=1e-6, help="largest residual accepted as success (finite, > 0)")
    p.add_argument("--forces", metavar="FILE.csv", help="write the interface forces (one row per interface, the "
                   "structure's ids, frame and units; see docs/results.md)")
    p.add_argument("--mechanism", metavar="FILE.csv", help="write the collapse mechanism (one row per free block, "
                   "velocities normalised to a live-load power of 1)")
    p.add_argument("--export-drawing", metavar="FILE.dxf|FILE.svg", help="draw the mechanism and the interface "
                   "forces into a DXF or SVG file (a copy of the drawing solved, if it is one)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the collapse mechanism (hinges and sliding joints "
                   "marked) into a figure file; its suffix chooses the format (.png, .pdf, .svg, ...)")
    p.add_argument("--export-mesh", metavar="FILE.obj", help="3D: write the blocks moved along the mechanism as a "
                   "mesh (.obj, one object per block; .stl or .ply)")
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser("import", help="read a drawing (DXF, SVG) or an image of stones into a structure file",
                       epilog=_import_epilog(), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("drawing", help="a .dxf, .svg, .png, .tif, .bmp or .npy file")
    p.add_argument("-o", "--output", required=True, metavar="FILE.json")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE", help="reader option (see below)")
    p.set_defaults(func=cmd_import)

    p = sub.add_parser("export", help="write a built-in case as a structure file")
    p.add_argument("case")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE")
    p.add_argument("-o", "--output", required=True, metavar="FILE.json")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("cases", help="list built-in cases and their parameters")
    p.set_defaults(func=cmd_cases)
    p = sub.add_parser("methods", help="list methods and their options")
    p.add_argument("--json", action="store_true", help="print one JSON list: name, problem, summary, availability "
                   "and the options (name, type, default, help) of every method")
    p.set_defaults(func=cmd_methods)

    _add_compare_parser(sub)

    from blockmpec.pushover_cli import add_parser as add_pushover_parser

    add_pushover_parser(sub, cmd_pushover)
    return parser


def _add_compare_parser(sub) -> None:
    """The ``compare`` subcommand's arguments."""
    p = sub.add_parser("compare", help="run methods over cases and print tables and figures (the main job)")
    p.add_argument("--cases", default="", help="comma-separated suite labels "
                   f"({', '.join(BENCHMARK_SUITE)}), built-in case names or structure files (default: the suite)")
    p.add_argument("--methods", default="", help="comma-separated method names, plug-ins included, or "
                   "MODULE:CLASS (default: all registered methods)")
    p.add_argument("--config", metavar="STUDY.toml", help="a study file: cases with parameters, methods with "
                   "options, repeats, wall-clock limits (see studies/example_study.toml)")
    p.add_argument("--repeat", type=int, default=None, help="repetitions per case and method (default 1)")
    p.add_argument("--out", default="blockmpec-output", help="output folder (default: ./blockmpec-output); "
                   "refused if it holds files, unless --overwrite or --resume")
    p.add_argument("--overwrite", action="store_true", help="delete the earlier run's outputs in --out first")
    p.add_argument("--resume", action="store_true", help="keep the finished rows in --out and run only the others")
    p.add_argument("-O", "--option", action="append", metavar="METHOD.KEY=VALUE",
                   help="method option, e.g. -O milp.time_limit=120 (overrides the suite's defaults)")
    p.add_argument("--jobs", "-j", type=int, default=None, help="worker processes (default 1)")
    p.add_argument("--backend", choices=["loky", "dask"], default=None,
                   help="loky: worker processes on this machine (joblib); dask: a Dask cluster")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="Dask scheduler address (with --backend dask); without it a local cluster of --jobs workers")
    p.add_argument("--wall-limit", action="append", metavar="[METHOD=]SECONDS",
                   help="wall-clock limit per solve, enforced from outside (default: max(1.5 x the method's "
                        "time_limit, time_limit + 30 s): 900 s for the default 600 s; inf: none)")
    p.add_argument("--budget", action="append", metavar="[CASE=]SECONDS",
                   help="time budget of a case: what the summary and the performance profiles charge an unsolved "
                        "run, the same for every method of the case, and the longest solve that counts as solved "
                        "(default: the largest wall-clock limit of the case's runs)")
    p.add_argument("--verify-tol", default=None, help="largest residual accepted as success (finite, > 0; default 1e-6)")
    p.add_argument("--no-figures", action="store_true", help="write the tables only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare)


def _detach_stdout() -> None:
    """Point stdout at /dev/null, so that the interpreter's last flush at exit does not fail once more."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):  # stdout is not a file (replaced, closed)
        pass


def _one_line_warnings(default):
    """``warnings.showwarning`` that prints a drawing's warnings as ``blockmpec: warning: ...``, one line each."""
    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, DrawingWarning):
            print(f"blockmpec: warning: {message}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    return show
@contextlib.contextmanager
def _command_context():
    """What every command runs in: the current folder on ``sys.path`` (last, so it shadows no installed package),
    where ``--method module:Class`` finds a module that is not installed, as under ``python -m``; and a plug-in that
    failed to load (:class:`~blockmpec.errors.PluginWarning`) shown as one line ``blockmpec: warning: ...``."""
    import warnings

    from blockmpec.errors import PluginWarning

    try:
        cwd = os.getcwd()
    except OSError:  # the current folder was deleted: nothing to find there
        cwd = None
    added = cwd is not None and not any(os.path.abspath(p or ".") == cwd for p in sys.path)
    if added:
        sys.path.append(cwd)
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, PluginWarning):
                print(f"blockmpec: warning: {message}", file=sys.stderr)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        try:
            yield
        finally:
            if added and cwd in sys.path:
                sys.path.remove(cwd)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    with _command_context():
        return _dispatch(args)


def _dispatch(args: argparse.Namespace) -> int:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", DrawingWarning)
            warnings.showwarning = _one_line_warnings(warnings.showwarning)
            code = int(args.func(args))
        sys.stdout.flush()  # here, so that a reader gone by now is the BrokenPipeError below, not one at exit
        return code
    except BlockmpecError as exc:
        print(f"blockmpec: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of stdout has gone: nothing is wrong with the run, so no message
        _detach_stdout()
        return 141
    except Exception as exc:  # pragma: no cover - last resort, still no traceback by default
        if args.debug:
            raise
        print(f"blockmpec: internal error: {type(exc).__name__}: {exc} (rerun with --debug for a traceback)",
              file=sys.stderr)
        return 3


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
