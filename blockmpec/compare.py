r"""Run several methods over several cases and tabulate the answers in one long table.

>>> from blockmpec.compare import compare, write_tables
>>> df = compare({"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})},
...              ["static-lp", "fixed-point", ("fixed-point", {"relaxation": 0.5})])  # doctest: +SKIP
>>> df[["case", "method_label", "multiplier", "reference", "rel_error"]]  # doctest: +SKIP
>>> write_tables(df, "out")  # doctest: +SKIP

One row per (case, method with options, repetition).  Only the solve is timed
(:func:`blockmpec.solve` times set-up and solve apart; structure generation,
operator assembly and the residual evaluation are not timed).

Columns
-------
``case`` (label), ``case_name``, ``blocks`` (free blocks), ``p_case_<param>``,
``method``, ``method_label`` (``name[k=v,...]`` when options are given), ``problem``,
``p_method_<option>``, ``repetition``, ``status``, ``success``, ``verified``,
``certified`` (see below), ``multiplier``, one column per residual of
:data:`blockmpec.verify.RESIDUAL_NAMES` and ``max_residual``, ``build_time_s``,
``solve_time_s``, ``total_time_s`` (build + solve), ``iterations``, ``reference``,
``reference_source``, ``abs_error``, ``rel_error``, ``anomaly``, ``closed_form``
(the case's closed form for the row's problem, or empty) and ``message`` (the
reason of a skip or failure).

Reference multiplier
--------------------
Each row is compared with one reference value ``lam_ref`` per (case, problem):

non-associative rows (the minimum of the MPEC (4) is the target)
    1. ``"certified"``: the smallest multiplier of a successful run of a
       *certifying* method -- one whose class sets ``certifies_minimum = True``,
       as ``milp`` does -- with status ``optimal`` (a closed branch-and-bound
       gap: a proven global minimum of (4)); a run asked to maximise
       (``extra["sense"] == "max"``) is never taken as the minimum;
    2. else ``"best"``: the smallest *verified* non-associative multiplier of
       the run (every verified point solves (3), so this is an upper bound on
       the minimum);
    3. else ``"closed-form"``: :func:`blockmpec.cases.closed_form` (minimum);
    4. else ``"none"``.
associative rows
    ``"best"``: the smallest verified associative multiplier (the LP optimum is
    unique, so all verified values agree), else ``"closed-form"``, else ``"none"``.

``abs_error = |lam - lam_ref|`` and ``rel_error = abs_error / |lam_ref|``.

Anomalies (column ``anomaly``, ``;``-separated, empty when none), with
``tol = 1e-7 max(1, |lam_ref|)``:

* ``below-certified-minimum``: a verified non-associative multiplier below the
  certified minimum by more than ``tol`` (the certificate or the point is wrong);
* ``above-associative``: a verified non-associative multiplier above the
  associative one by more than ``tol`` (impossible: the forces of every solution
  of (3) are statically admissible for the associative LP (1));
* ``associative-mismatch``: two verified associative multipliers differ by more
  than ``tol`` (the LP optimum is unique).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from blockmpec.cases import CASES, closed_form, get_case
from blockmpec.geometry import Structure
from blockmpec.operators import assemble
from blockmpec.registry import get_solver
from blockmpec.result import Result, Status
from blockmpec.solver import solve
from blockmpec.verify import RESIDUAL_NAMES

#: absolute tolerance (times max(1, |lam_ref|)) of the anomaly checks
ANOMALY_TOL = 1e-7

#: per-method options of the built-in benchmark run (``blockmpec compare``): time limits for the
#: methods whose cost grows fast with the size of the structure
BENCHMARK_METHOD_OPTIONS: dict[str, dict[str, Any]] = {
    "milp": {"time_limit": 60.0},
    "nlp": {"time_limit": 60.0},
    "mcp-newton": {"time_limit": 60.0},
}

#: reference sources, in order of preference for non-associative rows
REFERENCE_SOURCES = ("certified", "best", "closed-form", "none")


# --------------------------------------------------------------------------- inputs


def parametrised_label(name: str, params: Mapping[str, Any]) -> str:
    """``name`` or ``name[k=v,...]``: a case or method with its non-default settings."""
    if not params:
        return name
    return f"{name}[{','.join(f'{k}={_short(v)}' for k, v in params.items())}]"


def _short(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v)) if not math.isinf(v) else str(v)
    return str(v)


@dataclasses.dataclass(frozen=True)
class CaseRun:
    """One case of a comparison: its label, built-in name (None for a bare structure) and parameters."""

    label: str
    name: str | None
    params: dict[str, Any]
    structure: Structure | None = None

    def build(self) -> Structure:
        """The structure (built from the name and parameters unless given)."""
        if self.structure is not None:
            return self.structure
        return get_case(self.name).build(**self.params)


@dataclasses.dataclass(frozen=True)
class MethodRun:
    """One method of a comparison: its label, registered name and options."""

    label: str
    name: str
    options: dict[str, Any]


def normalise_cases(cases: Any) -> list[CaseRun]:
    """Accepted forms of ``cases``.

    * a mapping ``label -> (case name, params)`` (like ``cli.BENCHMARK_SUITE``) or ``label -> Structure``;
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

    * a mapping ``label -> (method name, options)``;
    * an iterable of: a method name, ``(name, options)`` (label ``name[k=v,...]``),
      ``(label, name, options)`` or a :class:`MethodRun`.

    Unknown methods and bad options raise here, before anything runs.
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
        elif isinstance(item, tuple) and len(item) == 3:
            run = MethodRun(str(item[0]), item[1], dict(item[2] or {}))
        else:
            raise TypeError(f"cannot read a method from {item!r}: expected a name, (name, options) "
                            "or (label, name, options)")
        get_solver(run.name)(**run.options)  # unknown name / bad option -> error now
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


class ProgressBar:
    """Plain-text progress line on a stream (stderr by default), rewritten with ``\\r``.

    Call it as ``bar(done, total, case_label, method_label)`` before each run and
    ``bar.close()`` at the end.
    """

    def __init__(self, stream: Any = None, width: int = 24) -> None:
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.t0 = time.perf_counter()
        self._last = 0

    def __call__(self, done: int, total: int, case: str, method: str) -> None:
        filled = int(self.width * done / max(total, 1))
        text = (f"[{'#' * filled}{'.' * (self.width - filled)}] {done}/{total} "
                f"{time.perf_counter() - self.t0:6.1f}s  {case} · {method}")
        pad = max(self._last - len(text), 0)
        self._last = len(text)
        self.stream.write("\r" + text + " " * pad)
        self.stream.flush()

    def close(self) -> None:
        """End the line."""
        self.stream.write("\n")
        self.stream.flush()


# --------------------------------------------------------------------------- the run


def compare(
    cases: Any,
    methods: Any,
    *,
    repeat: int = 1,
    progress: Callable[[int, int, str, str], None] | bool | None = None,
    verify_tol: float = 1e-6,
    results: dict | None = None,
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
    progress : callable, True or None
        ``progress(done, total, case_label, method_label)`` before each run;
        ``True`` shows a :class:`ProgressBar` on stderr.
    verify_tol : float
        Passed to :func:`blockmpec.solve`.
    results : dict, optional
        If given, filled with ``(case_label, method_label, repetition) -> (Result, Structure)``
        (for figures of mechanisms and traces).

    Returns
    -------
    pandas.DataFrame
        One row per (case, method, repetition); columns described in the module
        docstring and :data:`COLUMNS`.  Reference columns come from
        :func:`add_references`.
    """
    import pandas as pd

    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat must be an integer >= 1; got {repeat!r}")
    case_runs = normalise_cases(cases)
    method_runs = normalise_methods(methods)
    bar = ProgressBar() if progress is True else (progress or None)
    total = len(case_runs) * len(method_runs) * repeat
    done = 0
    rows: list[dict[str, Any]] = []
    for case in case_runs:
        structure, ops, case_error = None, None, ""
        try:
            structure = case.build()
            ops = assemble(structure)
        except Exception as exc:  # one bad case must not stop the run
            case_error = f"case failed to build: {type(exc).__name__}: {exc}"
        refs = {p: _closed_form(case, p) for p in ("associative", "non-associative")}
        for method in method_runs:
            cls = get_solver(method.name)
            for rep in range(repeat):
                done += 1
                if bar:
                    bar(done, total, case.label, method.label)
                row = _base_row(case, method, rep, cls.problem, structure)
                row["closed_form"] = refs[cls.problem]
                if case_error:
                    row.update(status=Status.ERROR.value, message=case_error)
                    rows.append(row)
                    continue
                try:
                    res = solve(ops, method.name, verify_tol=verify_tol, **method.options)
                except Exception as exc:  # solve() already turns backend failures into a status
                    row.update(status=Status.ERROR.value,
                               message=f"run failed: {type(exc).__name__}: {exc}",
                               traceback=traceback.format_exc(limit=3))
                    rows.append(row)
                    continue
                row.update(_result_fields(res))
                rows.append(row)
                if results is not None:
                    results[(case.label, method.label, rep)] = (res, structure)
    if bar and hasattr(bar, "close"):
        bar.close()
    df = pd.DataFrame(rows)
    for col in COLUMNS:
        if col not in df.columns:
            df[col] = None
    df = add_references(df)
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
    "build_time_s", "solve_time_s", "total_time_s", "iterations",
    "reference", "reference_source", "abs_error", "rel_error", "anomaly",
    "closed_form", "message",
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


def _finite(v: Any) -> bool:
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def select_reference(rows, problem: str) -> tuple[float | None, str]:
    """The reference multiplier of one (case, problem) group and its source.

    Parameters
    ----------
    rows : pandas.DataFrame
        The rows of one case and one problem, with columns ``verified``,
        ``certified``, ``multiplier`` and ``closed_form``.
    problem : {"associative", "non-associative"}

    Returns
    -------
    (float or None, str)
        The value and its source (one of :data:`REFERENCE_SOURCES`).
    """
    lam = rows["multiplier"]
    ok = [_finite(v) for v in lam]
    if problem == "non-associative":
        cert = [float(v) for v, c, g in zip(lam, rows["certified"], ok) if g and bool(c)]
        if cert:
            return min(cert), "certified"
    verified = [float(v) for v, vv, g in zip(lam, rows["verified"], ok) if g and bool(vv)]
    if verified:
        return min(verified), "best"
    forms = [float(v) for v in rows["closed_form"] if _finite(v)]
    if forms:
        return forms[0], "closed-form"
    return None, "none"


def add_references(df, tol: float = ANOMALY_TOL):
    """Fill ``reference``, ``reference_source``, ``abs_error``, ``rel_error`` and ``anomaly``.

    Works on any frame with columns ``case, problem, multiplier, verified,
    certified, closed_form`` (see the module docstring for the rules).  Returns
    the same frame (modified in place).
    """
    import numpy as np

    n = len(df)
    reference = [None] * n
    source = ["none"] * n
    anomaly = [""] * n
    if n == 0:
        for col in ("reference", "reference_source", "abs_error", "rel_error", "anomaly"):
            df[col] = []
        return df
    pos = {idx: i for i, idx in enumerate(df.index)}
    assoc_ref: dict[Any, float | None] = {}
    for (case, problem), grp in df.groupby(["case", "problem"], sort=False):
        value, src = select_reference(grp, problem)
        if problem == "associative":
            assoc_ref[case] = value
        for idx in grp.index:
            reference[pos[idx]] = value
            source[pos[idx]] = src
    for i, (idx, r) in enumerate(df.iterrows()):
        lam, ref = r["multiplier"], reference[i]
        if not (_finite(lam) and bool(r["verified"])):
            continue
        lam = float(lam)
        flags = []
        if r["problem"] == "non-associative":
            if source[i] == "certified" and lam < ref - tol * max(1.0, abs(ref)):
                flags.append("below-certified-minimum")
            a = assoc_ref.get(r["case"])
            if a is not None and lam > a + tol * max(1.0, abs(a)):
                flags.append("above-associative")
        elif ref is not None and abs(lam - ref) > tol * max(1.0, abs(ref)):
            flags.append("associative-mismatch")
        anomaly[i] = ";".join(flags)
    lam_arr = np.array([float(v) if _finite(v) else np.nan for v in df["multiplier"]])
    ref_arr = np.array([np.nan if v is None else float(v) for v in reference])
    abs_err = np.abs(lam_arr - ref_arr)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_err = np.where(ref_arr != 0, abs_err / np.abs(ref_arr), np.where(abs_err == 0, 0.0, np.inf))
    rel_err[np.isnan(abs_err)] = np.nan
    df["reference"] = ref_arr
    df["reference_source"] = source
    df["abs_error"] = abs_err
    df["rel_error"] = rel_err
    df["anomaly"] = anomaly
    return df


# --------------------------------------------------------------------------- output


def write_tables(df, out_dir: str | Path, stem: str = "results") -> list[Path]:
    """Write ``<stem>.csv`` (and ``<stem>.parquet`` when pyarrow is importable) into ``out_dir``.

    Returns the paths written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{stem}.csv"]
    df.drop(columns=[c for c in ("traceback",) if c in df.columns]).to_csv(paths[0], index=False)
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return paths
    path = out / f"{stem}.parquet"
    try:
        safe = df.copy()
        for col in safe.columns:
            if safe[col].dtype == object:
                safe[col] = safe[col].map(lambda v: None if v is None else str(v))
        safe.to_parquet(path, index=False)
        paths.append(path)
    except Exception:  # parquet is a convenience; the CSV is the table of record
        pass
    return paths


def pivot(df, value: str, *, repetition: int = 0):
    """``case x method_label`` table of ``value`` at one repetition (associative methods first)."""
    sub = df[df["repetition"] == repetition]
    cases = list(dict.fromkeys(sub["case"]))
    assoc = list(dict.fromkeys(sub.loc[sub["problem"] == "associative", "method_label"]))
    na = list(dict.fromkeys(sub.loc[sub["problem"] != "associative", "method_label"]))
    table = sub.pivot(index="case", columns="method_label", values=value)
    return table.reindex(index=cases, columns=assoc + na)


def text_table(df, value: str, fmt: str, title: str, *, reference: bool = False, note: str = "",
               median: bool = False) -> str:
    """A printable ``case x method`` table of ``value`` (first repetition; ``median=True``: median over repetitions).

    Cells: the formatted value, ``*`` appended when not verified, ``×`` for a failed
    run (error, infeasible, no multiplier), ``skip`` for a skipped method.  With
    ``reference=True`` a last column shows the non-associative reference and its
    source (c = certified minimum, b = best verified value, f = closed form).
    """
    sub = df[df["repetition"] == 0].copy()
    if median and df["repetition"].max() > 0:
        med = df.groupby(["case", "method_label"], sort=False)[value].median()
        sub[value] = [med.get((c, m)) for c, m in zip(sub["case"], sub["method_label"])]
    cases = list(dict.fromkeys(sub["case"]))
    assoc = list(dict.fromkeys(sub.loc[sub["problem"] == "associative", "method_label"]))
    na = list(dict.fromkeys(sub.loc[sub["problem"] != "associative", "method_label"]))
    methods = assoc + na
    cell: dict[tuple[str, str], str] = {}
    for _, r in sub.iterrows():
        v = r[value]
        if r["status"] == Status.SKIPPED.value:
            text = "skip"
        elif not _finite(v) or r["status"] in ("error", "infeasible", "unbounded"):
            text = "×"
        else:
            text = fmt.format(float(v)) + ("" if bool(r["success"]) else "*")
        cell[(r["case"], r["method_label"])] = text
    ref_col = []
    if reference:
        short = {"certified": "c", "best": "b", "closed-form": "f", "none": ""}
        for c in cases:
            rr = sub[(sub["case"] == c) & (sub["problem"] == "non-associative")]
            if len(rr) and _finite(rr["reference"].iloc[0]):
                ref_col.append(f"{float(rr['reference'].iloc[0]):.5f} ({short[rr['reference_source'].iloc[0]]})")
            else:
                ref_col.append("")
    header = methods + (["NA reference"] if reference else [])
    widths = [max(len(h), 9) + 2 for h in header]
    first = max(len(c) for c in cases + ["case"]) + 2
    lines = [title, "case".ljust(first) + "".join(h.rjust(w) for h, w in zip(header, widths))]
    for i, c in enumerate(cases):
        cells = [cell.get((c, m), "") for m in methods] + ([ref_col[i]] if reference else [])
        lines.append(c.ljust(first) + "".join(t.rjust(w) for t, w in zip(cells, widths)))
    lines.append("* = not verified (a residual of (3) exceeds the tolerance); × = failed; skip = method does not fit"
                 + (note and "\n" + note))
    return "\n".join(lines)
