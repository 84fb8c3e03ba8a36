r"""Figures of a comparison: error against run time, convergence, collapse mechanisms, performance profiles.

The drawing functions take ``ax=`` (or ``fig=``) and return the matplotlib objects, so that they go into a
researcher's own figures; given a ``path`` instead, they write a PNG there and return its path (what
``blockmpec compare`` does through :func:`comparison_figures`).  The PNG writers build their figures outside
pyplot (:class:`matplotlib.figure.Figure`), so they need no display and change no global state.

* :func:`error_vs_time`: the relative error of ``lam`` against run time, one panel per problem;
* :func:`convergence`: the comparator's convergence figure of one case, built from
  :func:`blockmpec.plot.convergence` (``lam`` against time for every method, the change of the normal
  forces against time and against LP steps);
* :func:`mechanisms`: collapse mechanisms side by side, from :func:`blockmpec.plot.mechanism` (hinges
  and sliding joints marked);
* :func:`performance_profile` / :func:`plot_profiles`:
  performance profiles.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.bench.profiles import SOLVED_TOL, budget_text, profile_data, rho, solved_definition
from blockmpec.bench.runs import _finite, _true
from blockmpec.plot import FLOOR as ERROR_FLOOR
from blockmpec.plot import METHOD_STYLES, method_style

__all__ = ["ERROR_FLOOR", "METHOD_STYLES", "comparison_figures", "convergence", "error_vs_time", "mechanisms",
           "method_style"]

#: the comparator's figure style (applied while its figures are drawn, never globally)
STYLE = {"font.size": 9, "axes.titlesize": 9, "legend.fontsize": 7}

PROBLEM_TITLES = {"associative": "associative problem (LP (1)/(2))",
                  "non-associative": "non-associative problem (MCP (3) / MPEC (4))"}


def _style():
    import matplotlib

    return matplotlib.rc_context(STYLE)


def _axes(ax=None):
    """``ax``, or the axes of a new pyplot figure (so that it shows in a notebook or a window)."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.subplots(layout="constrained")[1]


def _figure(fig=None, **kw: Any):
    """``fig``, or a new figure outside pyplot (constrained layout; nothing to close, no backend needed)."""
    if fig is not None:
        return fig
    from matplotlib.figure import Figure

    kw.setdefault("layout", "constrained")
    return Figure(**kw)


def _save(fig, path, dpi: int = 150) -> Path:
    """Write ``fig`` to ``path`` (folders made) and release it if pyplot holds it; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # constrained layout already fits the labels: a "tight" bounding box would draw everything twice
    fig.savefig(path, dpi=dpi, bbox_inches=None if fig.get_layout_engine() is not None else "tight")
    if getattr(fig.canvas, "manager", None) is not None:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return path


def _num(v: Any) -> float:
    return float(v) if _finite(v) else math.nan


# --------------------------------------------------------------------------- error vs time


def _bound_trace(trace: list[dict[str, Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(time_s, bound, incumbent)`` of a certifying method's trace (``bound`` or ``dual_bound``;
    ``incumbent``, else ``multiplier``); empty arrays when the trace has no bound."""
    t, lo, inc = [], [], []
    for r in trace or []:
        bound = r.get("bound", r.get("dual_bound"))
        if not (_finite(r.get("time_s")) and _finite(bound)):
            continue
        t.append(float(r["time_s"]))
        lo.append(float(bound))
        inc.append(_num(r.get("incumbent", r.get("multiplier"))))
    return np.array(t), np.array(lo), np.array(inc)


def _abs_rel_error(r) -> float:
    v = r.get("abs_rel_error")
    if _finite(v):
        return float(v)
    v = r.get("rel_error")
    return abs(float(v)) if _finite(v) else math.nan


def error_vs_time(df, path: str | Path | None = None, *, ax=None, problem: str | None = None,
                  time_column: str = "solve_time_s", title: str | None = None, results: dict | None = None,
                  legend: bool = True):
    r"""The relative error of ``lam`` against run time, in the methods' fixed colours and markers.

    The error drawn is ``|rel_error| = |lam - lam_ref| / |lam_ref|`` (column ``abs_rel_error`` of
    :func:`blockmpec.bench.compare.compare`) on log axes, floored at :data:`ERROR_FLOOR` (the dotted line)
    so that exact answers show.  Filled markers: verified answers; open markers: not verified; a **new
    best** (a verified ``lam`` below the best verified value of every other method, ``rel_error < 0``)
    is drawn as ``↓`` in its method's colour, at the height of its distance below the others.  Rows
    without a multiplier or a reference are left out.  Where ``results`` holds a trace with a bound
    (``milp``), the certificate is drawn as it closes over time: the bound's distance to the reference
    (dashed) and the incumbent's (solid).  The legend names only what is drawn.

    Parameters
    ----------
    df : pandas.DataFrame
        The table of :func:`blockmpec.bench.compare.compare`.
    path : path, optional
        Write a PNG there (one panel per problem, with the definitions under the panels) and return the
        path.
    ax : matplotlib.axes.Axes, optional
        Draw one panel, for ``problem``, into ``ax`` and return ``ax``.
    problem : {"associative", "non-associative"}, optional
        The problem of the panel drawn into ``ax`` (default: the table's only problem; the associative
        and non-associative references are never mixed).
    time_column : {"solve_time_s", "total_time_s"}
    title : str, optional
        The figure's title (without ``ax``).
    results : dict, optional
        ``(case, method_label, repetition) -> (Result, Structure)`` as filled by ``compare``.
    legend : bool

    Returns
    -------
    matplotlib.axes.Axes, matplotlib.figure.Figure or pathlib.Path
        ``ax`` when given; else the figure; with ``path``, the path written.
    """
    if ax is not None:
        return _error_panel(ax, df, problem or _only_problem(df), time_column, results, legend)
    problems = [p for p in ("associative", "non-associative")
                if "problem" in df.columns and (df["problem"] == p).any()]
    if "problem" not in df.columns:
        problems = ["all"]
    problems = problems or ["associative"]
    with _style():
        fig = _figure(None, figsize=(6.6 * len(problems), 5.0))
        grid = fig.add_gridspec(2, len(problems), height_ratios=[1.0, 0.1])
        for j, problem_ in enumerate(problems):
            _error_panel(fig.add_subplot(grid[0, j]), df, problem_, time_column, results, legend)
        notes = fig.add_subplot(grid[1, :])
        notes.set_axis_off()
        notes.text(0.0, 1.0, _wrap(
            "error = |lam - reference| / |reference|; reference by rank: closed form > certified minimum > best "
            "verified value of another method; a new best (↓) lies below that reference, its height is its "
            f"distance below it; errors below {ERROR_FLOOR:.0e} are drawn on the dotted line; filled markers: "
            "verified, open: not verified", int(fig.get_figwidth() * 16)),
            transform=notes.transAxes, va="top", ha="left", fontsize=7, color="0.3")
        fig.suptitle(title or "Error of the collapse multiplier against run time")
        return _save(fig, path) if path is not None else fig


def _wrap(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width))


def _only_problem(df) -> str:
    if "problem" not in df.columns:
        return "all"
    got = list(dict.fromkeys(df["problem"]))
    if len(got) != 1:
        raise ValueError(f"the table holds rows of {', '.join(map(str, got)) or 'no'} problem(s); "
                         "pass problem='associative' or 'non-associative' (their errors are never mixed)")
    return str(got[0])


def _error_panel(ax, df, problem: str, time_column: str, results: dict | None, legend: bool):
    from matplotlib.lines import Line2D

    sub = df if problem == "all" else df[df["problem"] == problem]
    methods = dict(zip(sub["method_label"], sub["method"] if "method" in sub.columns else sub["method_label"]))
    drawn: dict[str, set[str]] = {}  # label -> what was drawn of it: "marker" and/or "best"
    unverified = new_best = bound_drawn = incumbent_drawn = False
    for _, r in sub.iterrows():
        err, t = _abs_rel_error(r), r.get(time_column)
        if not math.isfinite(err) or not _finite(t):
            continue
        label = r["method_label"]
        colour, marker = method_style(label, methods.get(label))
        verified = _true(r.get("verified"))
        best = verified and _true(r.get("new_best", False))
        x, y = max(float(t), 1e-6), max(err, ERROR_FLOOR)
        if best:
            ax.plot(x, y, ls="", marker=r"$\downarrow$", ms=12, color=colour, zorder=4)
            new_best = True
        else:
            ax.scatter(x, y, marker=marker, s=42, facecolors=colour if verified else "none", edgecolors=colour,
                       linewidths=1.2, zorder=3)
            unverified |= not verified
        drawn.setdefault(label, set()).add("best" if best else "marker")
        got = (results or {}).get((r["case"], label, r.get("repetition", 0)))
        ref = r.get("reference")
        if got is not None and _finite(ref) and float(ref) != 0:
            ts, lo, inc = _bound_trace(getattr(got[0], "trace", None))
            if ts.size:
                ref = float(ref)
                ax.plot(np.maximum(ts, 1e-6), np.maximum(np.abs(ref - lo) / abs(ref), ERROR_FLOOR), ls="--",
                        lw=0.9, color=colour, alpha=0.7, drawstyle="steps-post")
                bound_drawn = True
                ok = np.isfinite(inc)
                if ok.any():
                    ax.plot(np.maximum(ts[ok], 1e-6), np.maximum(np.abs(inc[ok] - ref) / abs(ref), ERROR_FLOOR),
                            ls="-", lw=0.9, color=colour, alpha=0.7, drawstyle="steps-post")
                    incumbent_drawn = True
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import NullFormatter

    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("solve time [s]" if time_column == "solve_time_s" else "set-up + solve time [s]")
    ax.set_ylabel(r"relative error $|\lambda-\lambda_{ref}|\,/\,|\lambda_{ref}|$")
    ax.axhline(ERROR_FLOOR, color="0.6", lw=0.8, ls=":")
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(PROBLEM_TITLES.get(problem, "all rows"))
    if not drawn:
        ax.text(0.5, 0.5, "no row with a multiplier and a reference", transform=ax.transAxes, ha="center")
    if legend and drawn:
        handles = []
        for m, kinds in drawn.items():  # a method drawn only as new bests is shown as its arrow
            colour, marker = method_style(m, methods.get(m))
            handles.append(Line2D([], [], ls="", marker=marker if "marker" in kinds else r"$\downarrow$",
                                  ms=6 if "marker" in kinds else 10, color=colour, label=m))
        if unverified:
            handles.append(Line2D([], [], ls="", marker="o", markerfacecolor="none", color="0.2", label="not verified"))
        if new_best:
            handles.append(Line2D([], [], ls="", marker=r"$\downarrow$", ms=10, color="0.2",
                                  label="new best (below the reference)"))
        if bound_drawn:
            handles.append(Line2D([], [], ls="--", color="0.3", label="certificate: bound (trace)"))
        if incumbent_drawn:
            handles.append(Line2D([], [], ls="-", color="0.3", label="certificate: incumbent (trace)"))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=7)
    return ax


# --------------------------------------------------------------------------- convergence


def convergence(traces: Mapping[str, Any], path: str | Path | None = None, *, title: str = "",
                without: Sequence[str] = (), methods: Mapping[str, str] | None = None, fig=None):
    r"""The comparator's convergence figure of one case: three panels from :func:`blockmpec.plot.convergence`.

    (a) ``lam`` against time for every method (a certifying method's bound dashed; a method without a
    trace as the point of its answer), (b) ``||n - n*|| / ||n||`` against time and (c) against the LP
    step, for the methods that measure it (only those whose iteration is one LP in (c), so that one
    axis means one thing).  What could not be drawn is named under the panels, outside them.

    Parameters
    ----------
    traces : mapping
        Method label -> :class:`~blockmpec.Result` (or its :attr:`~blockmpec.Result.trace`, a list of records).
    path : path, optional
        Write a PNG there and return the path.
    title : str
    without : sequence of str
        Labels of methods that ran but have nothing to draw (named under the panels).
    methods : mapping, optional
        Label -> method name (for the fixed styles).
    fig : matplotlib.figure.Figure, optional
        Draw into this figure (default: a new one).

    Returns
    -------
    matplotlib.figure.Figure or pathlib.Path
    """
    from blockmpec.plot import convergence as draw

    with _style():
        fig = _figure(fig, figsize=(12.5, 5.0))
        grid = fig.add_gridspec(3, 3, height_ratios=[1.0, 0.09, 0.12])
        a, b, c = (fig.add_subplot(grid[0, j]) for j in range(3))
        for ax, y, x in ((a, "multiplier", "time"), (b, "n_change", "time"), (c, "n_change", "lp_step")):
            draw(traces, y=y, x=x, ax=ax, methods=methods, legend=False)
        a.set_title(r"(a) $\lambda$ against time, every method")
        b.set_title("(b) change of the normal forces against time")
        c.set_title("(c) the same against LP steps")
        handles: dict[str, Any] = {}
        for ax in (a, b, c):  # one legend: every entry is drawn in some panel
            for h in ax.convergence_handles:
                handles.setdefault(h.get_label(), h)
        box = fig.add_subplot(grid[1, :])
        box.set_axis_off()
        if handles:
            box.legend(handles=list(handles.values()), loc="center", ncol=min(len(handles), 5), frameon=False)
        lines = []
        if without:
            lines.append(f"nothing to draw (no trace, no multiplier): {', '.join(without)}")
        for ax, what in ((a, "(a)"), (b, "(b)"), (c, "(c)")):
            gone = [f"{label} ({why})" for label, why in getattr(ax, "convergence_missing", [])
                    if label not in without]
            if gone:
                lines.append(f"not in {what}: " + "; ".join(gone))
        lines.append("time: seconds since the run started (its set-up excluded); n*: the previous LP step's "
                     "normal forces (fixed-point-type methods); a method without a trace is drawn in (a) as the "
                     "point of its answer")
        notes = fig.add_subplot(grid[2, :])
        notes.set_axis_off()
        width = int(fig.get_figwidth() * 16)  # characters of 7-point text across the figure
        notes.text(0.0, 1.0, "\n".join(_wrap(t, width) for t in lines), transform=notes.transAxes, va="top",
                   ha="left", fontsize=7, color="0.3")
        fig.suptitle(title or "Convergence")
        return _save(fig, path) if path is not None else fig


# --------------------------------------------------------------------------- mechanisms


def mechanisms(structure, panels: Sequence[tuple[str, Any]], path: str | Path | None = None, *, ops=None,
               amplitude: float = 0.12, title: str = "", fig=None):
    """Collapse mechanisms side by side (e.g. associative beside non-associative), hinges and sliding joints
    marked (:func:`blockmpec.plot.mechanism`).

    Parameters
    ----------
    structure : Structure
    panels : sequence of (title, mechanism)
        ``mechanism``: a :class:`~blockmpec.Result`, its :attr:`~blockmpec.Result.mechanism` frame, the
        internal :attr:`Solution.u <blockmpec.Solution.u>` array of ``ops`` (canonical frame), or None.
    path : path, optional
        Write a PNG there and return the path.
    ops : Operators, optional
        ``assemble(structure)`` if not given (only read for a ``Solution.u`` array).
    amplitude : float
        The largest vertex displacement drawn, as a fraction of the structure's size.
    fig : matplotlib.figure.Figure, optional

    Returns
    -------
    matplotlib.figure.Figure or pathlib.Path
    """
    import blockmpec as bm
    from blockmpec.plot import mechanism as draw

    if getattr(structure, "dim", 2) == 3:
        return _mechanisms_3d(structure, panels, path, ops=ops, amplitude=amplitude, title=title, fig=fig)
    xy = np.vstack([structure.polygon(i) for i in range(structure.n_blocks)])
    w, h = np.ptp(xy, axis=0)
    n = max(len(panels), 1)
    panel_w = 4.6
    with _style():
        fig = _figure(fig, figsize=(panel_w * n, panel_w * min(max(h / w, 0.45), 1.4) + 1.6))
        axes = fig.subplots(1, n, squeeze=False)[0]
        handles: dict[str, Any] = {}
        note = ""
        for ax, (label, value) in zip(axes, panels):
            if isinstance(value, np.ndarray):
                ops = ops if ops is not None else bm.assemble(structure)
                value = bm.mechanism_frame(ops, value)
            draw(value, structure, ax=ax, amplitude=amplitude, title=label, legend=False)
            for h in ax.mechanism_handles:  # one legend for all panels: every entry is drawn in some panel
                handles.setdefault(h.get_label(), h)
            note = note or ax.mechanism_note
        fig.legend(handles=list(handles.values()), loc="outside lower center", ncol=min(len(handles), 4),
                   frameon=False, title=note.replace("\n", " "), title_fontsize=7)
        if title:
            fig.suptitle(title)
        return _save(fig, path) if path is not None else fig


def _mechanisms_3d(structure, panels, path, *, ops, amplitude, title, fig):
    """:func:`mechanisms` of a 3D structure: one 3D axes per panel (:func:`blockmpec.three_d.plot.mechanism`)."""
    import blockmpec as bm
    from blockmpec.three_d.plot import mechanism as draw

    n = max(len(panels), 1)
    with _style():
        fig = _figure(fig, figsize=(4.6 * n, 5.0))
        for k, (label, value) in enumerate(panels):
            if isinstance(value, np.ndarray):
                ops = ops if ops is not None else bm.assemble(structure)
                value = bm.mechanism_frame(ops, value)
            if value is None:
                value = bm.mechanism_frame(None, None)
            draw(value, structure, ax=fig.add_subplot(1, n, k + 1, projection="3d"), amplitude=amplitude, title=label)
        if title:
            fig.suptitle(title)
        return _save(fig, path) if path is not None else fig


# --------------------------------------------------------------------------- all figures of a comparison


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in text).strip("_")


def comparison_figures(df, results: dict, out_dir: str | Path, *, budget: Any = None) -> list[Path]:
    """Every figure of a comparison into ``out_dir``; returns the paths.

    * ``error_vs_time.png``: :func:`error_vs_time`, associative and non-associative panels,
      with the certificates' traces;
    * ``performance_profile.png``: :func:`plot_profiles` (``budget`` as there);
    * ``convergence_<case>.png``: :func:`convergence` of every method of the case (first repetition),
      naming under the panels those with nothing to draw;
    * ``mechanism_<case>.png``: :func:`mechanisms`, associative (the first successful
      associative method, ``static-lp`` preferred) beside non-associative (the
      successful non-associative run with the smallest ``lam``), hinges and sliding joints marked.

    ``results`` is the dict filled by :func:`blockmpec.bench.compare.compare` (``results=``).
    """

    out = Path(out_dir)
    paths = [error_vs_time(df, out / "error_vs_time.png", results=results)]
    with _style():
        paths.append(plot_profiles(df, out / "performance_profile.png", budget=budget))
    first = df[df["repetition"] == 0]
    for case in dict.fromkeys(first["case"]):
        rows = first[first["case"] == case]
        runs, without = {}, []
        for _, r in rows.iterrows():
            got = results.get((case, r["method_label"], 0))
            if got is not None and (got[0].trace or _finite(got[0].multiplier)):
                runs[r["method_label"]] = got[0]
            elif r["status"] != "skipped":
                without.append(r["method_label"])
        names = dict(zip(rows["method_label"], rows["method"]))
        paths.append(convergence(runs, out / f"convergence_{_slug(case)}.png", title=f"Convergence: {case}",
                                 without=without, methods=names))
        ok = rows["success"].astype(bool) & rows.apply(lambda r: (case, r["method_label"], 0) in results, axis=1)
        assoc = rows[(rows["problem"] == "associative") & ok]
        if len(assoc):
            order = sorted(range(len(assoc)), key=lambda k: assoc["method"].iloc[k] != "static-lp")
            assoc = assoc.iloc[order[:1]]
        na = rows[(rows["problem"] == "non-associative") & ok]
        if len(na):
            na = na.loc[[na["multiplier"].astype(float).idxmin()]]
        panels, structure = [], None
        for kind, sel in (("associative", assoc), ("non-associative", na)):
            if len(sel):
                label = sel["method_label"].iloc[0]
                res, structure = results[(case, label, 0)]
                panels.append((f"{kind} ({label})\n$\\lambda$ = {res.multiplier:.5f}", res))
            else:
                panels.append((f"{kind}: no successful run", None))
        if structure is None:
            got = next((results[k] for k in results if k[0] == case), None)
            structure = got[1] if got else None
        if structure is not None:
            paths.append(mechanisms(structure, panels, out / f"mechanism_{_slug(case)}.png",
                                    title=f"Collapse mechanisms: {case}"))
    return paths


def performance_profile(df, problem: str = "non-associative", *, ax=None, tol: float = SOLVED_TOL,
                        budget: float | Mapping[str, float] | None = None, legend: bool = True):
    """Draw the Dolan--Moré performance profile of one problem into ``ax`` (see the module docstring).

    Parameters
    ----------
    df : pandas.DataFrame
        A comparison table (:func:`blockmpec.bench.compare.compare`).
    problem : {"associative", "non-associative"}
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    tol, budget
        As for :func:`solved`.
    legend : bool
        Add a legend of the methods.

    Returns
    -------
    matplotlib.axes.Axes

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig, ax = plt.subplots()                                          # doctest: +SKIP
    >>> performance_profile(df, "non-associative", ax=ax)                 # doctest: +SKIP
    >>> fig.savefig("profile.pdf")                                        # doctest: +SKIP
    """
    ax = _axes(ax)
    data = profile_data(df, tol, budget).get(problem)
    if data is None:
        ax.text(0.5, 0.5, f"no {problem} runs", ha="center", transform=ax.transAxes)
        ax.set_axis_off()
        return ax
    ratios = data["ratios"]
    finite = [r[np.isfinite(r)] for r in ratios.values()]
    top = max([float(f.max()) for f in finite if f.size] + [2.0]) * 1.5
    tau = np.geomspace(1.0, top, 400)
    methods = dict(zip(df["method_label"], df["method"])) if "method" in df.columns else {}
    for j, (label, r) in enumerate(ratios.items()):
        colour, marker = method_style(label, methods.get(label))
        y = rho(r, tau)
        # markers staggered between methods, so that coinciding curves (e.g. all at 0) stay told apart
        ax.step(tau, y, where="post", color=colour, lw=1.4, label=label, marker=marker,
                markevery=((17 * j) % 80, 80), ms=5)
    ax.set_xscale("log", base=2)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(1.0, top)
    ax.set_xlabel(r"$\tau$ (solve time within $\tau\times$ the fastest)")
    ax.set_ylabel(r"$\rho(\tau)$: fraction of cases solved")
    ax.set_title(f"{problem} problem ({len(data['cases'])} case{'s' if len(data['cases']) != 1 else ''})")
    ax.grid(True, alpha=0.3)
    if legend:  # beside the axes: the curves run along the bottom and right edges
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return ax


def plot_profiles(df, path: str | Path | None = None, tol: float = SOLVED_TOL, *, fig=None,
                  budget: float | Mapping[str, float] | None = None):
    """Dolan--Moré performance profiles, one panel per problem (:func:`performance_profile`), in the methods'
    fixed styles, with the definition of "solved" and the budgets under the panels.

    Returns the figure, or with ``path`` the path of the PNG written there (the comparator's use).
    """
    data = profile_data(df, tol, budget)
    problems = [p for p in ("associative", "non-associative") if p in data]
    n = max(len(problems), 1)
    fig = _figure(fig, figsize=(6.4 * n, 4.6))
    grid = fig.add_gridspec(2, n, height_ratios=[1.0, 0.16])
    axes = [fig.add_subplot(grid[0, j]) for j in range(n)]
    for ax, problem in zip(axes, problems):
        performance_profile(df, problem, ax=ax, tol=tol, budget=budget)
    if not problems:
        axes[0].text(0.5, 0.5, "no runs", ha="center", transform=axes[0].transAxes)
    notes = fig.add_subplot(grid[1, :])
    notes.set_axis_off()
    budgets = {c: b for d in data.values() for c, b in d["budgets"].items()}
    width = int(fig.get_figwidth() * 16)  # characters of 7-point text across the figure
    notes.text(0.0, 1.0, _wrap(solved_definition(tol), width) + "\n" + _wrap(budget_text(budgets, budget is not None),
                                                                           width),
               transform=notes.transAxes, va="top", ha="left", fontsize=7, color="0.3")
    fig.suptitle("Performance profiles")
    return _save(fig, path) if path is not None else fig
