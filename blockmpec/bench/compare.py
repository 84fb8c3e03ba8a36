r"""Run several methods over several cases and tabulate the answers in one long table.

>>> from blockmpec.bench.compare import compare
>>> df = compare({"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})},
...              ["static-lp", "fixed-point", ("fixed-point", {"relaxation": 0.5})],
...              n_jobs=2, out="my-study")  # doctest: +SKIP
>>> df[["case", "method_label", "multiplier", "reference", "reference_source", "rel_error"]]  # doctest: +SKIP

One row per (case, method with options, repetition).  Only the solve is timed
(:func:`blockmpec.solve` times set-up and solve apart; structure generation,
operator assembly and the residual evaluation are not timed).  Every solve runs in
a worker process under a wall-clock limit enforced from outside
(:mod:`blockmpec.bench.runner`): a crash or hang becomes a row with status ``error`` or
``time_limit``.  With ``out=`` every finished row is saved at once
(:class:`blockmpec.bench.study.ResultsFolder`), so an interrupt keeps it and ``resume=True``
skips it next time.

Columns: :data:`COLUMNS` and the docs' comparator page (``docs/comparator.md``) list and explain them.

Reference multiplier
--------------------
Each row is compared with one reference value ``lam_ref``, chosen per (case,
problem) by rank:

1. ``"closed-form"``: :func:`blockmpec.cases.closed_form` for the row's problem
   (for the non-associative problem: the minimum over solutions of (3));
2. ``"certified"`` (non-associative rows only): the smallest multiplier of a
   successful run of a *certifying* method -- one whose class sets
   ``certifies_minimum = True``, as ``milp`` does -- with status ``optimal`` (a
   closed branch-and-bound gap: a proven global minimum of (4)); a run asked to
   maximise (``extra["sense"] == "max"``) is never taken as the minimum;
3. ``"best"``: the smallest *verified* multiplier of the problem (every verified
   non-associative point solves (3), so this is an upper bound on the minimum of (4);
   verified associative values all equal the LP optimum);
4. ``"none"``.

**A row is never graded against a value that only its own method produced**: ranks 2
and 3 take only values of *other* methods (``method`` differs), so a method that alone
certified or alone found a value falls to the next rank, and ``reference_note`` says
so.  ``reference_method`` names the method label that produced the reference.

Errors
------
With ``lam`` the row's multiplier,

* ``signed_error = lam - lam_ref`` and ``abs_error = |lam - lam_ref|``;
* ``rel_error = (lam - lam_ref) / |lam_ref|`` -- **signed** (its magnitude is ``abs_rel_error``).  For the minimum
  of (4) a negative
  error is a lower verified multiplier than the reference: a better answer when the reference
  is only the best value of another method, a bug when the reference is exact (below);
* ``lam_ref = 0``: ``rel_error`` is 0 when ``lam = 0``, else ``+-inf``.

New best (column ``new_best``, mark ``↓`` in the text tables): a *verified* non-associative
multiplier below a reference of source ``"best"`` by more than :data:`MATCH_TOL` (relative):
``rel_error < -MATCH_TOL``.  It beats every verified value of the other methods, so it is the
reference of those other methods of the case (rank 3 takes the smallest verified value of
another method), and its own error, negative, is measured against the best of the others.

Anomalies (column ``anomaly``, ``;``-separated, empty when none; mark ``!`` in the text tables
and an ``ANOMALY`` line from ``blockmpec compare``), with ``tol = 1e-7 max(1, |lam_ref|)``
(:data:`ANOMALY_TOL`):

* ``below-certified-minimum``: a verified non-associative multiplier below a
  certified minimum (of any method) by more than ``tol`` (the certificate or the
  point is wrong);
* ``below-closed-form-minimum``: the same against the non-associative closed form;
* ``above-associative``: a verified non-associative multiplier above the
  associative reference by more than ``tol`` (impossible: the forces of every
  solution of (3) are statically admissible for the associative LP (1));
* ``associative-mismatch``: a verified associative multiplier differs from the
  associative reference by more than ``tol`` (the LP optimum is unique).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from blockmpec import OptionError, Result, Status, Structure, assemble, get_solver
from blockmpec.bench.runs import (  # noqa: F401 - the records and helpers, re-exported for the comparator's users
    ANOMALY_TOL,
    MATCH_TOL,
    CaseRun,
    MethodRun,
    _finite,
    _true,
    parametrised_label,
    relative_error,
)
from blockmpec.cases import CASES, closed_form, get_case
from blockmpec.verify import RESIDUAL_NAMES

#: per-method options of the built-in benchmark run (``blockmpec compare``): time limits for the
#: methods whose cost grows fast with the size of the structure
BENCHMARK_METHOD_OPTIONS: dict[str, dict[str, Any]] = {
    "milp": {"time_limit": 60.0},
    "nlp": {"time_limit": 60.0},
    "mcp-newton": {"time_limit": 60.0},
}

#: reference sources, in order of rank
REFERENCE_SOURCES = ("closed-form", "certified", "best", "none")


# --------------------------------------------------------------------------- inputs


def normalise_cases(cases: Any) -> list[CaseRun]:
    """Accepted forms of ``cases``.

    * a mapping ``label -> (case name, params)`` (like ``blockmpec.bench.suite.BENCHMARK_SUITE``) or ``label -> Structure``;
    * an iterable of: a case name, ``(name, params)``, ``(label, name, params)``, a
      :class:`~blockmpec.geometry.Structure` (label = its ``name``) or a :class:`CaseRun`.
    """
    out: list[CaseRun] = []
    items: Iterable[Any]
    if isinstance(cases, Mapping):
        items = [((label, *v) if isinstance(v, tuple) else (label, v)) for label, v in cases.items()]
    elif isinstance(cases, (str, Structure)):
        items = [cases]
    else:
        items = cases
    for item in items:
        if isinstance(item, CaseRun):
            out.append(item)
        elif isinstance(item, str):
            get_case(item)
            out.append(CaseRun(item, item, {}))
        elif isinstance(item, Structure):
            out.append(_structure_run(item.name, item))
        elif isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], Structure):
            out.append(_structure_run(item[0], item[1]))
        elif isinstance(item, tuple) and len(item) == 2:
            name, params = item[0], dict(item[1] or {})
            get_case(name)
            out.append(CaseRun(parametrised_label(name, params), name, params))
        elif isinstance(item, tuple) and len(item) == 3:
            label, name, params = item[0], item[1], dict(item[2] or {})
            get_case(name)
            out.append(CaseRun(str(label), name, params))
        else:
            raise TypeError(f"cannot read a case from {item!r}: expected a name, (name, params), "
                            "(label, name, params) or a Structure")
    labels = [c.label for c in out]
    dupes = sorted({lbl for lbl in labels if labels.count(lbl) > 1})
    if dupes:
        raise ValueError(f"case labels must be unique; repeated: {', '.join(dupes)}")
    return out


def _structure_run(label: str, structure: Structure) -> CaseRun:
    """A bare structure: its closed form is looked up only for an unmodified built-in case."""
    import numpy as np

    meta = dict(structure.metadata or {})
    name = meta.pop("case", None)
    uniform = bool(np.all(np.asarray(structure.interface_friction()) == structure.friction))
    if name in CASES and uniform:
        known = get_case(name).parameters
        params = {k: v for k, v in meta.items() if k in known}
        params.update(mu=float(structure.friction), dilatancy=float(structure.dilatancy))
        return CaseRun(label, name, params, structure)
    return CaseRun(label, None, {}, structure)


def normalise_methods(methods: Any) -> list[MethodRun]:
    """Accepted forms of ``methods``.

    * a mapping ``label -> (method name, options)`` or ``label -> (method name, options, settings)``;
    * an iterable of: a method name, ``(name, options)`` (label ``name[k=v,...]``),
      ``(label, name, options)``, ``(label, name, options, settings)`` or a :class:`MethodRun`.

    Unknown methods, bad options and settings of the wrong type raise here, before anything runs.
    """
    items: Iterable[Any]
    if isinstance(methods, Mapping):
        items = [(label, *v) for label, v in methods.items()]
    elif isinstance(methods, str):
        items = [methods]
    else:
        items = methods
    out: list[MethodRun] = []
    for item in items:
        if isinstance(item, MethodRun):
            run = item
        elif isinstance(item, str):
            run = MethodRun(item, item, {})
        elif isinstance(item, tuple) and len(item) == 2:
            run = MethodRun(parametrised_label(item[0], item[1] or {}), item[0], dict(item[1] or {}))
        elif isinstance(item, tuple) and len(item) in (3, 4):
            run = MethodRun(str(item[0]), item[1], dict(item[2] or {}), item[3] if len(item) == 4 else None)
        else:
            raise TypeError(f"cannot read a method from {item!r}: expected a name, (name, options), "
                            "(label, name, options) or (label, name, options, settings)")
        get_solver(run.name)(settings=run.settings, **run.options)  # unknown name / bad option -> error now
        out.append(run)
    labels = [m.label for m in out]
    dupes = sorted({lbl for lbl in labels if labels.count(lbl) > 1})
    if dupes:
        raise ValueError(f"method labels must be unique; repeated: {', '.join(dupes)}")
    return out


def certifies_minimum(method: str) -> bool:
    """True for a method whose ``optimal`` status certifies the global minimum of (4).

    A solver class declares it with ``certifies_minimum = True`` (``milp`` does);
    a run of it with ``extra["sense"] == "max"`` certifies a maximum instead and is
    never taken as the minimum.
    """
    return bool(getattr(get_solver(method), "certifies_minimum", False))


# --------------------------------------------------------------------------- progress


class Progress:
    """A tqdm progress bar on stderr: completed/total, the solve in progress with its elapsed
    time (refreshed twice a second, also during a long solve) and the failures so far.

    The running solves are read from start markers that the supervisors write into
    ``marker_dir`` (:class:`blockmpec.bench.runner.Task`), so the elapsed time is the real one for
    every backend on this machine.
    """

    def __init__(self, total: int, labels: dict[int, str], marker_dir: str, *, enabled: bool | None = None,
                 initial: int = 0) -> None:
        import threading

        from tqdm.auto import tqdm

        self.labels, self.marker_dir, self.failed = labels, Path(marker_dir), 0
        self.bar = tqdm(total=total, initial=initial, desc="compare", unit="solve", file=sys.stderr,
                        disable=(not enabled) if enabled is not None else None, dynamic_ncols=True, leave=True,
                        bar_format="{desc}: {percentage:3.0f}%|{bar:20}| {n_fmt}/{total_fmt} [{elapsed}] {postfix}")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._tick, daemon=True)
        if not self.bar.disable:
            self._thread.start()

    def running(self) -> list[tuple[float, str]]:
        """``(elapsed seconds, "case · method")`` of the solves in progress, longest first."""
        now, out = time.time(), []
        try:
            for marker in self.marker_dir.glob("*.start"):
                try:
                    started = float(marker.read_text())
                except (OSError, ValueError):
                    continue
                out.append((now - started, self.labels.get(int(marker.stem), marker.stem)))
        except OSError:
            pass
        return sorted(out, reverse=True)

    def postfix(self) -> str:
        """The text after the bar: the longest-running solve and its seconds (``running <label> 12s``, with ``(+k)``
        for the k others running), then ``failed <count>``."""
        run = self.running()
        text = "" if not run else f"running {run[0][1]} {run[0][0]:.0f}s" + (f" (+{len(run) - 1})" if len(run) > 1 else "")
        return f"{text}{', ' if text else ''}failed {self.failed}"

    def _tick(self) -> None:
        while not self._stop.wait(0.5):
            self.bar.set_postfix_str(self.postfix(), refresh=True)

    def finished(self, row: dict[str, Any]) -> None:
        if row.get("status") in (Status.ERROR.value, Status.TIME_LIMIT.value):
            self.failed += 1
        self.bar.update(1)
        self.bar.set_postfix_str(self.postfix(), refresh=False)

    def close(self) -> None:
        self._stop.set()
        self.bar.set_postfix_str(f"failed {self.failed}", refresh=False)
        self.bar.close()


# --------------------------------------------------------------------------- the run


class ComparisonInterrupted(KeyboardInterrupt):
    """Raised by :func:`compare` after an interrupt, once the finished rows are saved.

    ``table`` holds the finished rows (with references), ``saved`` the folder or None.
    """

    def __init__(self, table, saved: Path | None, signal_name: str = "SIGINT") -> None:
        super().__init__(f"interrupted by {signal_name}; {len(table)} finished row(s) saved")
        self.table, self.saved, self.signal_name = table, saved, signal_name


def run_key(case: CaseRun, method: MethodRun, rep: int) -> str:
    """What ``resume`` matches: case label and parameters, method name and options, repetition."""
    import json

    key = [case.label, case.params, method.name, method.options, rep]
    if method.settings is not None:  # keys of runs without settings stay as they were (resume of older folders)
        key.append(repr(method.settings))
    return json.dumps(key, sort_keys=True, default=str)


def compare(
    cases: Any,
    methods: Any,
    *,
    repeat: int = 1,
    progress: Callable[[int, int, str, str], None] | bool | None = None,
    verify_tol: float = 1e-6,
    results: dict | None = None,
    n_jobs: int = 1,
    backend: str | None = None,
    scheduler: str | None = None,
    wall_limit: float | Mapping[str, float] | None = None,
    isolate: bool = True,
    out: Any = None,
    resume: bool = False,
    overwrite: bool = False,
    budget: float | Mapping[str, float] | None = None,
):
    """Run every method on every case and return one long-format table.

    Parameters
    ----------
    cases
        See :func:`normalise_cases` (e.g. ``{"arch": ("round-arch", {"mu": 0.6})}``).
    methods
        See :func:`normalise_methods` (e.g. ``["static-lp", ("fixed-point", {"relaxation": 0.5})]``).
    repeat : int
        Repetitions of every (case, method) pair (timings vary; answers should not).
    progress : bool, callable or None
        ``True``: a tqdm bar on stderr (see :class:`Progress`); ``None``: the same when stderr is
        a terminal; ``False``: none; a callable is called as ``progress(done, total, case, method)``
        after each finished run.
    verify_tol : float
        Passed to :func:`blockmpec.solve`.
    results : dict, optional
        If given, filled with ``(case_label, method_label, repetition) -> (Result, Structure)``
        (for figures of mechanisms and traces), also for rows taken over by ``resume``.
    n_jobs : int
        Worker processes (each supervising one solve at a time).
    backend : {None, "loky", "dask"}
        ``None``: serial for ``n_jobs=1``, else ``"loky"`` (joblib); ``"dask"``: a Dask cluster
        (see :func:`blockmpec.bench.runner.execute`).
    scheduler : str, optional
        Address of a running Dask scheduler; without it ``backend="dask"`` starts a local
        cluster of ``n_jobs`` workers.
    wall_limit : float or mapping, optional
        Outside wall-clock limit per solve [s] (``inf``: none): one number for all, or a mapping from method
        label or method name to seconds; the default is :func:`blockmpec.bench.runner.default_wall_limit`.
    budget : float or mapping, optional
        The time budget of each case [s] (column ``budget_s``): what the summary and the performance
        profiles charge an unsolved run, the same for every method of the case, and the longest solve
        that still counts as solved.  One number for all cases or a mapping from case label to seconds;
        the default is the largest finite wall-clock limit of the case's runs
        (:func:`blockmpec.bench.profiles.case_budgets`).
    isolate : bool
        ``False`` runs the solves in the supervising process (no protection; for debugging).
    out : path or :class:`~blockmpec.bench.study.ResultsFolder`, optional
        Save every finished row there at once (``rows.jsonl``, ``solutions/``) and the tables
        at the end (``results.csv``, ``results.parquet``).  A path is opened with ``resume``
        and ``overwrite``; a folder with files is refused without one of them.
    resume : bool
        Skip the runs whose ``run_key`` is already in ``out`` and keep their rows.

    Returns
    -------
    pandas.DataFrame
        One row per (case, method, repetition); columns in the module docstring and
        :data:`COLUMNS`.

    Raises
    ------
    ComparisonInterrupted
        On Ctrl-C (or SIGTERM, where the caller turns it into KeyboardInterrupt), after the
        finished rows are saved; its ``table`` holds them.
    """
    import tempfile

    from blockmpec.bench.runner import Task, check_backend, default_wall_limit, execute
    from blockmpec.bench.study import ResultsFolder, check_tolerance

    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat must be an integer >= 1; got {repeat!r}")
    verify_tol = check_tolerance(verify_tol, "verify_tol")
    check_backend(n_jobs, backend, scheduler)
    case_runs = normalise_cases(cases)
    method_runs = normalise_methods(methods)
    if isolate:
        _check_importable(method_runs)
    limits = _wall_limits(wall_limit, method_runs, default_wall_limit)
    from blockmpec.bench.profiles import check_budget

    budget = check_budget(budget, [c.label for c in case_runs])
    folder = None
    if out is not None:
        folder = out if isinstance(out, ResultsFolder) else ResultsFolder(out, overwrite=overwrite, resume=resume,
                                                                          flag="out")
    try:
        previous = {r["run_key"]: r for r in folder.finished_rows()} if (folder is not None and resume) else {}
        return _run(case_runs, method_runs, repeat, progress, verify_tol, results, n_jobs, backend, scheduler,
                    limits, isolate, folder, previous, Task, execute, tempfile, budget)
    finally:
        if folder is not None and not isinstance(out, ResultsFolder):
            folder.close()


def _check_importable(method_runs: list[MethodRun]) -> None:
    """Worker processes find a method by its name (built-in, plug-in or ``module:Class``) or by importing the module
    that registered it: a class defined in the script being run (``__main__``) cannot be found there."""
    for run in method_runs:
        cls = get_solver(run.name)
        if cls.__module__ == "__main__":
            raise OptionError(f"method {run.label!r}: its class {cls.__qualname__} is defined in the script being run, "
                              "which the worker processes cannot import; move it into a module (my_method.py) and "
                              "give 'my_method:" + cls.__qualname__ + "', or pass isolate=False")


def _wall_limits(wall_limit, method_runs, default) -> dict[str, float]:
    out = {}
    for m in method_runs:
        if wall_limit is None:
            value = default(m.options, m.name)
        elif isinstance(wall_limit, Mapping):
            value = wall_limit.get(m.label, wall_limit.get(m.name, default(m.options, m.name)))
        else:
            value = wall_limit
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise OptionError(f"wall limit of {m.label}: must be a number of seconds > 0 (inf: none); got {value!r}")
        out[m.label] = float(value)
    return out


def _run(case_runs, method_runs, repeat, progress, verify_tol, results, n_jobs, backend, scheduler, limits,
         isolate, folder, previous, Task, execute, tempfile, budget):
    import pandas as pd

    # ---- the tasks (cases built once, here: a case that fails to build gives error rows)
    plans: list[tuple[str, dict[str, Any], Any]] = []  # (run_key, base row, task or None)
    structures: dict[str, Structure | None] = {}
    marker_dir = tempfile.mkdtemp(prefix="blockmpec-progress-")
    sys_path = tuple(p for p in sys.path if p)
    labels: dict[int, str] = {}
    for case in case_runs:
        structure, case_error = None, ""
        try:
            structure = case.build()
            assemble(structure)  # bad geometry is reported once per case, not once per solve
        except Exception as exc:  # one bad case must not stop the run
            case_error = f"case failed to build: {type(exc).__name__}: {exc}"
            structure = None
        structures[case.label] = structure
        refs = {p: _closed_form(case, p) for p in ("associative", "non-associative")}
        for method in method_runs:
            cls = get_solver(method.name)
            for rep in range(repeat):
                key = run_key(case, method, rep)
                row = _base_row(case, method, rep, cls.problem, structure)
                row.update(closed_form=refs[cls.problem], wall_limit_s=limits[method.label], run_key=key)
                task = None
                if case_error:
                    row.update(status=Status.ERROR.value, message=case_error)
                elif key not in previous:
                    plugin = cls.__module__
                    task = Task(len(plans), structure, method.name, dict(method.options), verify_tol,
                                limits[method.label],
                                plugins=() if plugin.startswith("blockmpec.") else (plugin,),
                                sys_path=sys_path, marker_dir=marker_dir, settings=method.settings)
                    labels[task.task_id] = f"{case.label} · {method.label}"
                plans.append((key, row, task))
    rows: dict[int, dict[str, Any]] = {}
    for i, (key, row, task) in enumerate(plans):
        if key in previous:
            rows[i] = previous[key]
            if results is not None and folder is not None:
                res = folder.load_result(key)
                if res is not None:
                    results[(row["case"], row["method_label"], row["repetition"])] = (res, structures[row["case"]])
        elif task is None:  # the case failed to build
            rows[i] = row
            if folder is not None:
                folder.append(row)
    extra_previous = [r for k, r in previous.items() if k not in {p[0] for p in plans}]
    tasks = [t for _, _, t in plans if t is not None]
    total = len(plans)
    bar = None
    if progress is True or progress is None:
        bar = Progress(total, labels, marker_dir, enabled=True if progress else None, initial=total - len(tasks))
    callback = progress if callable(progress) else None
    last_write = time.perf_counter()

    def table():
        frame = [{**rows[i], "resumed": plans[i][0] in previous} for i in sorted(rows)]
        frame += [{**r, "resumed": True} for r in extra_previous]
        return _frame(pd, frame, budget)

    interrupted = None
    try:
        for outcome in execute(tasks, n_jobs=n_jobs, backend=backend, scheduler=scheduler, isolate=isolate):
            key, row, task = plans[outcome.task_id]
            row = dict(row)
            row["wall_time_s"] = float(outcome.wall_time_s)
            if outcome.result is not None:
                row.update(_result_fields(outcome.result))
                if results is not None:
                    results[(row["case"], row["method_label"], row["repetition"])] = (
                        outcome.result, structures[row["case"]])
            else:
                row.update(status=outcome.status, message=outcome.message)
                if outcome.traceback:
                    row["traceback"] = outcome.traceback
            rows[outcome.task_id] = row
            if folder is not None:
                folder.append(row, outcome.result)
                if time.perf_counter() - last_write > 5.0:  # the tables too, now and then (by rename)
                    folder.write_tables(table())
                    last_write = time.perf_counter()
            if bar is not None:
                bar.finished(row)
            if callback is not None:
                callback(len(rows), total, row["case"], row["method_label"])
    except KeyboardInterrupt as exc:
        interrupted = exc
    finally:
        if bar is not None:
            bar.close()
        import shutil

        shutil.rmtree(marker_dir, ignore_errors=True)
    df = table()
    if folder is not None:
        folder.write_tables(df)
    if interrupted is not None:
        raise ComparisonInterrupted(df, folder.path if folder is not None else None,
                                    getattr(interrupted, "signal_name", "SIGINT")) from None
    return df


def _frame(pd, rows: list[dict[str, Any]], budget=None):
    from blockmpec.bench.profiles import case_budgets

    df = pd.DataFrame(rows)
    for col in COLUMNS:
        if col not in df.columns:
            df[col] = None
    df = add_references(df)
    budgets = case_budgets(df, budget)
    df["budget_s"] = [budgets.get(c, math.nan) for c in df["case"]]
    df["resumed"] = df["resumed"].fillna(False).astype(bool)
    first = [c for c in COLUMNS if c in df.columns]
    params = sorted(c for c in df.columns if c.startswith(("p_case_", "p_method_")))
    rest = [c for c in df.columns if c not in first and c not in params]
    order = first[:3] + [c for c in params if c.startswith("p_case_")] + first[3:6] + \
        [c for c in params if c.startswith("p_method_")] + first[6:] + rest
    return df[order]


#: the fixed columns, in order (``p_case_*`` after ``case_name``, ``p_method_*`` after ``method_label``)
COLUMNS = (
    "case", "case_name", "blocks",
    "method", "method_label", "problem",
    "repetition", "status", "success", "verified", "certified", "multiplier",
    *RESIDUAL_NAMES, "max_residual",
    "build_time_s", "solve_time_s", "total_time_s", "iterations", "wall_time_s", "wall_limit_s",
    "reference", "reference_source", "reference_method", "reference_note", "abs_error", "rel_error", "anomaly",
    "closed_form", "message", "run_key",
    # added for issue 41 (after the columns above, so that their positions are unchanged)
    "signed_error", "abs_rel_error", "new_best", "budget_s", "resumed",
)


def _closed_form(case: CaseRun, problem: str) -> float | None:
    if case.name is None:
        return None
    try:
        return closed_form(case.name, problem, **case.params)
    except Exception:
        return None


def _base_row(case: CaseRun, method: MethodRun, rep: int, problem: str, structure: Structure | None) -> dict:
    row: dict[str, Any] = {
        "case": case.label, "case_name": case.name if case.name else (structure.name if structure else ""),
        "blocks": structure.n_free if structure is not None else None,
        "method": method.name, "method_label": method.label, "problem": problem, "repetition": rep,
        "status": None, "success": False, "verified": False, "certified": False, "multiplier": None,
        **{name: None for name in RESIDUAL_NAMES}, "max_residual": None,
        "build_time_s": None, "solve_time_s": None, "total_time_s": None, "iterations": None, "message": "",
    }
    for k, v in case.params.items():
        row[f"p_case_{k}"] = v if isinstance(v, (int, float, str, bool)) or v is None else str(v)
    for k, v in method.options.items():
        row[f"p_method_{k}"] = v if isinstance(v, (int, float, str, bool)) or v is None else str(v)
    return row


def _result_fields(res: Result) -> dict[str, Any]:
    out: dict[str, Any] = {
        "problem": res.problem, "status": res.status.value, "success": bool(res.success),
        "verified": bool(res.verified),
        # a certifying method's optimum is the certified minimum -- unless it was asked to maximise
        "certified": bool(res.problem == "non-associative" and res.status is Status.OPTIMAL and res.success
                          and certifies_minimum(res.method) and res.extra.get("sense", "min") == "min"),
        "multiplier": None if res.multiplier is None else float(res.multiplier),
        "max_residual": None if not res.residuals else float(res.max_residual),
        "build_time_s": float(res.build_time_s), "solve_time_s": float(res.solve_time_s),
        "total_time_s": float(res.build_time_s + res.solve_time_s), "iterations": int(res.iterations),
        "message": res.message,
    }
    for name in RESIDUAL_NAMES:
        v = res.residuals.get(name)
        out[name] = None if v is None else float(v)
    return out


# --------------------------------------------------------------------------- references




def _candidates(grp, column: str) -> list[tuple[float, str, str]]:
    """``(lam, method, method_label)`` of the rows of ``grp`` with a finite lam and a true ``column``."""
    out = []
    for lam, flag, method, label in zip(grp["multiplier"], grp[column], grp["method"], grp["method_label"]):
        if _finite(lam) and bool(flag) and not (isinstance(flag, float) and math.isnan(flag)):
            out.append((float(lam), str(method), str(label)))
    return out


def select_reference(rows, problem: str, method: str | None = None) -> tuple[float | None, str, str, str]:
    """The reference of the rows of one (case, problem) group, for a row of ``method``.

    Parameters
    ----------
    rows : pandas.DataFrame
        The rows of one case and one problem, with columns ``method``, ``method_label``,
        ``verified``, ``certified``, ``multiplier`` and ``closed_form``.
    problem : {"associative", "non-associative"}
    method : str, optional
        The method of the row to be graded: values it produced are left out (ranks 2 and 3).
        ``None``: the reference for a method that produced nothing (the table's headline).

    Returns
    -------
    (value or None, source, producing method label, note)
        ``source`` is one of :data:`REFERENCE_SOURCES`; the note says when the row's own
        method was passed over.
    """
    forms = [float(v) for v in rows["closed_form"] if _finite(v)]
    if forms:
        return forms[0], "closed-form", "", ""
    notes = []
    if problem == "non-associative":
        cert = _candidates(rows, "certified")
        other = [c for c in cert if c[1] != method]
        if other:
            lam, _, label = min(other)
            return lam, "certified", label, ""
        if cert:
            notes.append("the only certificate is this method's own")
    verified = _candidates(rows, "verified")
    other = [c for c in verified if c[1] != method]
    if other:
        lam, _, label = min(other)
        if verified and not notes and min(verified)[1] == method and min(verified)[0] < lam:
            notes.append("the best verified value is this method's own")
        return lam, "best", label, "; ".join(notes + ["graded against another method's best verified value"]
                                            if notes else [])
    if verified:
        notes.append("no other method produced a verified value")
    return None, "none", "", "; ".join(notes + ["not graded"]) if notes else ""


def add_references(df, tol: float = ANOMALY_TOL, match_tol: float = MATCH_TOL):
    """Fill ``reference``, ``reference_source``, ``reference_method``, ``reference_note``,
    ``abs_error``, ``rel_error`` (signed), ``signed_error``, ``abs_rel_error``, ``new_best`` and ``anomaly``.

    Works on any frame with columns ``case, problem, method, method_label, multiplier,
    verified, certified, closed_form`` (see the module docstring for the rules).  Returns
    the same frame (modified in place).

    Parameters
    ----------
    tol : float
        Tolerance of the anomaly checks, times ``max(1, |lam_ref|)`` (:data:`ANOMALY_TOL`).
    match_tol : float
        A verified non-associative multiplier with ``rel_error < -match_tol`` against a reference of source
        ``"best"`` is a new best (:data:`MATCH_TOL`).
    """
    import numpy as np

    n = len(df)
    cols = ("reference", "reference_source", "reference_method", "reference_note", "abs_error", "rel_error",
            "anomaly", "signed_error", "abs_rel_error", "new_best")
    if n == 0:
        for col in cols:
            df[col] = []
        return df
    if "method" not in df.columns:
        df["method"] = df["method_label"] if "method_label" in df.columns else ""
    if "method_label" not in df.columns:
        df["method_label"] = df["method"]
    reference = [None] * n
    source, producer, note, anomaly = ["none"] * n, [""] * n, [""] * n, [""] * n
    pos = {idx: i for i, idx in enumerate(df.index)}
    assoc_ref: dict[Any, float | None] = {}
    floor: dict[Any, list[tuple[float, str]]] = {}  # proven lower bounds of the non-associative minimum
    for (case, problem), grp in df.groupby(["case", "problem"], sort=False):
        if problem == "associative":
            assoc_ref[case] = select_reference(grp, problem)[0]
        else:
            floor[case] = [(c[0], "below-certified-minimum") for c in _candidates(grp, "certified")]
            floor[case] += [(float(v), "below-closed-form-minimum") for v in grp["closed_form"] if _finite(v)][:1]
        for idx, method in zip(grp.index, grp["method"]):
            i = pos[idx]
            reference[i], source[i], producer[i], note[i] = select_reference(grp, problem, str(method))
    verified = [_finite(lam) and _true(v) for lam, v in zip(df["multiplier"], df["verified"])]
    for i, (_, r) in enumerate(df.iterrows()):
        if not verified[i]:
            continue
        lam = float(r["multiplier"])
        flags = []
        if r["problem"] == "non-associative":
            for bound, flag in floor.get(r["case"], []):
                if lam < bound - tol * max(1.0, abs(bound)) and flag not in flags:
                    flags.append(flag)
            a = assoc_ref.get(r["case"])
            if a is not None and lam > a + tol * max(1.0, abs(a)):
                flags.append("above-associative")
        else:
            ref = reference[i]
            if ref is not None and abs(lam - ref) > tol * max(1.0, abs(ref)):
                flags.append("associative-mismatch")
        anomaly[i] = ";".join(flags)
    lam_arr = np.array([float(v) if _finite(v) else np.nan for v in df["multiplier"]])
    ref_arr = np.array([np.nan if v is None else float(v) for v in reference])
    signed = lam_arr - ref_arr
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(ref_arr != 0, signed / np.abs(ref_arr), np.where(signed == 0, 0.0, np.sign(signed) * np.inf))
    rel[np.isnan(signed)] = np.nan
    new_best = [bool(verified[i] and df["problem"].iloc[i] == "non-associative" and source[i] == "best"
                     and rel[i] < -match_tol) for i in range(n)]
    for i in range(n):
        if new_best[i]:  # the note of select_reference ("this method's own ...") becomes the plain statement
            keep = [t for t in note[i].split("; ") if t and not t.startswith(
                ("the best verified value is this method's own", "graded against another method's"))]
            note[i] = "; ".join(keep + [f"new best: below the best verified value of the other methods "
                                        f"({producer[i]}), so it is their reference"])
    df["reference"] = ref_arr
    df["reference_source"] = source
    df["reference_method"] = producer
    df["reference_note"] = note
    df["abs_error"] = np.abs(signed)
    df["rel_error"] = rel
    df["anomaly"] = anomaly
    df["signed_error"] = signed
    df["abs_rel_error"] = np.abs(rel)
    df["new_best"] = new_best
    return df


# --------------------------------------------------------------------------- output


def write_tables(df, out_dir: str | Path, stem: str = "results") -> list[Path]:
    """Write ``<stem>.csv`` and ``<stem>.parquet`` into ``out_dir`` (each by rename); returns the paths."""
    from blockmpec.bench.study import write_frame

    return write_frame(df, out_dir, stem)


def pivot(df, value: str, *, repetition: int = 0):
    """``case x method_label`` table of ``value`` at one repetition (associative methods first)."""
    sub = df[df["repetition"] == repetition]
    cases = list(dict.fromkeys(sub["case"]))
    assoc = list(dict.fromkeys(sub.loc[sub["problem"] == "associative", "method_label"]))
    na = list(dict.fromkeys(sub.loc[sub["problem"] != "associative", "method_label"]))
    table = sub.pivot(index="case", columns="method_label", values=value)
    return table.reindex(index=cases, columns=assoc + na)


#: the marks of the text tables and what they mean (:func:`cell_mark`, :func:`grade_marks`); a cell without a
#: mark is a verified success
MARKS = {
    "*": "not verified (a residual of (3) exceeds the tolerance)",
    "†": "verified but not certified (a certifying method stopped before closing its gap, e.g. at its time limit)",
    "‡": "verified, but the method stopped without claiming success (status in results.csv)",
    "×": "failed: no multiplier, or status error, infeasible, unbounded or infeasible_or_unbounded",
    "skip": "skipped (the method does not fit the case or cannot run here)",
    "↓": f"new best: verified and below the best verified value of every other method by more than {MATCH_TOL:g} "
         "(relative), so its error is negative and it is the reference of the others",
    "!": "ANOMALY: a verified value that cannot be right (below a certified or closed-form minimum, above the "
         "associative multiplier, or another associative optimum); see the ANOMALY lines",
}
#: statuses that make a row "failed" (×) whatever its multiplier
FAILED_STATUSES = ("error", "infeasible", "unbounded", "infeasible_or_unbounded")


def cell_mark(row) -> str:
    """The status mark of one row in the text tables: "" (verified success), or one of
    ``skip``, ``×``, ``*``, ``†``, ``‡`` of :data:`MARKS` (the rules, in this order, are the definitions printed
    under the tables)."""
    status = row["status"]
    if status == Status.SKIPPED.value:
        return "skip"
    if not _finite(row["multiplier"]) or status in FAILED_STATUSES:
        return "×"
    if _true(row["success"]):
        return ""
    if not _true(row["verified"]):
        return "*"
    try:
        certifying = row["problem"] == "non-associative" and certifies_minimum(str(row["method"]))
    except Exception:
        certifying = False
    return "†" if certifying else "‡"


def grade_marks(row) -> str:
    """The grading marks of one row: ``!`` for an anomaly, ``↓`` for a new best (see :data:`MARKS`), or ""."""
    marks = ""
    if str(row.get("anomaly", "") or "") not in ("", "nan"):
        marks += "!"
    if _true(row.get("new_best", False)):
        marks += "↓"
    return marks


def text_table(df, value: str, fmt: str, title: str, *, reference: bool = False, note: str = "",
               median: bool = False, grades: bool | None = None) -> str:
    """A printable ``case x method`` table of ``value`` (first repetition; ``median=True``: median over repetitions).

    Cells: the formatted value followed by its grading marks (:func:`grade_marks`: ``!`` anomaly, ``↓`` new
    best; with ``grades``, default ``reference``) and its status mark (:func:`cell_mark`), ``×`` for a failed
    run, ``skip`` for a skipped method; the footnote explains every mark present.  With
    ``reference=True`` a last column shows the non-associative reference a method that
    produced nothing would be graded against, its source (f = closed form, c = certified
    minimum, b = best verified value) and the method that produced it.
    """
    grades = reference if grades is None else grades
    sub = df[df["repetition"] == 0].copy()
    if median and df["repetition"].max() > 0:
        med = df.groupby(["case", "method_label"], sort=False)[value].median()
        sub[value] = [med.get((c, m)) for c, m in zip(sub["case"], sub["method_label"])]
    cases = list(dict.fromkeys(sub["case"]))
    assoc = list(dict.fromkeys(sub.loc[sub["problem"] == "associative", "method_label"]))
    na = list(dict.fromkeys(sub.loc[sub["problem"] != "associative", "method_label"]))
    methods = assoc + na
    cell: dict[tuple[str, str], str] = {}
    used: set[str] = set()
    for _, r in sub.iterrows():
        mark = cell_mark(r)
        used.add(mark)
        extra = grade_marks(r) if grades and mark not in ("skip", "×") else ""
        used.update(extra)
        if mark in ("skip", "×"):
            text = mark
        elif not _finite(r[value]):
            text = "–"
        else:
            text = fmt.format(float(r[value])) + extra + mark
        cell[(r["case"], r["method_label"])] = text
    ref_col = []
    if reference:
        short = {"certified": "c", "best": "b", "closed-form": "f", "none": ""}
        for c in cases:
            rr = df[(df["case"] == c) & (df["problem"] == "non-associative")]
            value_, src, by, _ = select_reference(rr, "non-associative") if len(rr) else (None, "none", "", "")
            ref_col.append("" if value_ is None else f"{value_:.5f} ({short[src]}{': ' + by if by else ''})")
    header = methods + (["NA reference"] if reference else [])
    widths = [max(len(h), 9) + 2 for h in header]
    if reference:
        widths[-1] = max(widths[-1], max((len(t) for t in ref_col), default=0) + 2)
    first = max(len(c) for c in cases + ["case"]) + 2
    lines = [title, "case".ljust(first) + "".join(h.rjust(w) for h, w in zip(header, widths))]
    for i, c in enumerate(cases):
        cells = [cell.get((c, m), "") for m in methods] + ([ref_col[i]] if reference else [])
        lines.append(c.ljust(first) + "".join(t.rjust(w) for t, w in zip(cells, widths)))
    legend = ["no mark = verified success"] + [f"{k} = {v}" for k, v in MARKS.items()
                                               if k in used or k in ("*", "×")]
    lines.append("\n".join(legend) + (note and "\n" + note))
    return "\n".join(lines)
