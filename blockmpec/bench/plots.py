r"""Figures of a comparison: error against run time, convergence traces, collapse mechanisms.

matplotlib is imported inside each function, with the non-interactive Agg
backend; every function writes one PNG and returns its path.

Mechanism drawing
-----------------
Free block ``i`` (structure block ``ops.free_blocks[i]``) moves rigidly with
``u[3i:3i+3] = (u_x, u_y, theta)`` at its centroid ``c_i``, lengths in units of
``ops.length_scale``.  A vertex ``p`` of the block is drawn at

.. math:: c_i + s\,\ell\,(u_x, u_y) + R(s\,\theta)\,(p - c_i),

with ``ell = ops.length_scale``, ``R`` the rotation matrix and ``s`` one scale
factor per panel chosen so that the largest vertex displacement is a fixed
fraction (``amplitude``) of the structure's size.  The mechanism is defined up
to a positive factor (normalisation ``f_l^T u = 1``), so only its shape matters.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.result import is_finite_number as _finite

#: relative errors below this are drawn at this value on log axes (exact answers)
ERROR_FLOOR = 1e-16

#: one fixed colour and marker per method, in every figure of every run
METHOD_STYLES: dict[str, tuple[str, str]] = {
    "static-lp": ("#1f77b4", "o"),
    "kinematic-lp": ("#17becf", "s"),
    "fixed-point": ("#2ca02c", "^"),
    "slp": ("#8c564b", "X"),
    "mcp-newton": ("#9467bd", "D"),
    "nlp": ("#ff7f0e", "P"),
    "milp": ("#d62728", "v"),
}
_EXTRA_COLOURS = ("#e377c2", "#7f7f7f", "#bcbd22", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*", "h", "p")


def method_style(label: str, method: str | None = None) -> tuple[str, str]:
    """The fixed ``(colour, marker)`` of a method label.

    A registered method has its own entry in :data:`METHOD_STYLES`; a label with options
    (``fixed-point[relaxation=0.5]``) keeps its method's colour and takes a marker derived
    from the label; an unknown method gets a colour and marker derived from its name
    (CRC-32, so the same in every run).
    """
    import zlib

    name = method or label.split("[", 1)[0]
    if name not in METHOD_STYLES:
        name = next((m for m in sorted(METHOD_STYLES, key=len, reverse=True) if label.startswith(m)), name)
    if name in METHOD_STYLES:
        colour, marker = METHOD_STYLES[name]
        if label != name:
            marker = _MARKERS[zlib.crc32(label.encode()) % len(_MARKERS)]
        return colour, marker
    h = zlib.crc32(name.encode())
    return _EXTRA_COLOURS[h % len(_EXTRA_COLOURS)], _MARKERS[(h // 7) % len(_MARKERS)]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "legend.fontsize": 8, "savefig.dpi": 150})
    return plt


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # constrained layout already fits the labels: a "tight" bounding box would draw everything twice
    fig.savefig(path, bbox_inches=None if fig.get_layout_engine() is not None else "tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


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


def error_vs_time(df, path: str | Path, *, time_column: str = "solve_time_s", title: str | None = None,
                  results: dict | None = None) -> Path:
    """Relative error of ``lam`` against run time: one panel per problem (associative and
    non-associative references are never mixed), one fixed colour and marker per method.

    Filled markers: verified answers (solutions of (3)); open markers: not verified.  The
    error is ``|lam - lam_ref| / |lam_ref|`` (columns of :func:`blockmpec.bench.compare.compare`),
    floored at :data:`ERROR_FLOOR` so exact answers show on log axes.  Rows without a
    multiplier or reference are left out.  Where ``results`` holds a trace with a bound
    (``milp``), the certificate is drawn as it closes over time: the bound's distance to the
    reference (dashed) and the incumbent's (solid), in the method's colour.

    Parameters
    ----------
    df : pandas.DataFrame
        The table of :func:`blockmpec.bench.compare.compare`.
    path : path of the PNG.
    time_column : {"solve_time_s", "total_time_s"}
    results : dict, optional
        ``(case, method_label, repetition) -> (Result, Structure)`` as filled by ``compare``.
    """
    plt = _pyplot()
    problems = [p for p in ("associative", "non-associative")
                if "problem" not in df.columns or (df["problem"] == p).any()] or ["associative"]
    if "problem" not in df.columns:
        problems = ["all"]
    fig, axes = plt.subplots(1, len(problems), figsize=(5.4 * len(problems), 4.4), squeeze=False,
                             layout="constrained")
    from matplotlib.lines import Line2D

    for ax, problem in zip(axes[0], problems):
        sub = df if problem == "all" else df[df["problem"] == problem]
        labels = list(dict.fromkeys(sub["method_label"]))
        methods = dict(zip(sub["method_label"], sub["method"] if "method" in sub.columns else sub["method_label"]))
        drawn = False
        for _, r in sub.iterrows():
            err, t = r.get("rel_error"), r.get(time_column)
            if not _finite(err) or not _finite(t):
                continue
            colour, marker = method_style(r["method_label"], methods.get(r["method_label"]))
            verified = bool(r.get("verified"))
            ax.scatter(max(float(t), 1e-6), max(float(err), ERROR_FLOOR), marker=marker, s=42,
                       facecolors=colour if verified else "none", edgecolors=colour, linewidths=1.2, zorder=3)
            drawn = True
            got = (results or {}).get((r["case"], r["method_label"], r.get("repetition", 0)))
            ref = r.get("reference")
            if got is not None and _finite(ref) and float(ref) != 0:
                ts, lo, inc = _bound_trace(getattr(got[0], "trace", None))
                if ts.size:
                    ref = float(ref)
                    ax.plot(np.maximum(ts, 1e-6), np.maximum(np.abs(ref - lo) / abs(ref), ERROR_FLOOR), ls="--",
                            lw=0.9, color=colour, alpha=0.7, drawstyle="steps-post")
                    ok = np.isfinite(inc)
                    if ok.any():
                        ax.plot(np.maximum(ts[ok], 1e-6), np.maximum(np.abs(inc[ok] - ref) / abs(ref), ERROR_FLOOR),
                                ls="-", lw=0.9, color=colour, alpha=0.7, drawstyle="steps-post")
        ax.set_xscale("log")
        ax.set_yscale("log")
        from matplotlib.ticker import NullFormatter

        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("solve time [s]" if time_column == "solve_time_s" else "set-up + solve time [s]")
        ax.set_ylabel(r"relative error $|\lambda-\lambda_{ref}|\,/\,\lambda_{ref}$")
        ax.axhline(ERROR_FLOOR, color="0.6", lw=0.8, ls=":")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_title({"associative": "associative problem (LP (1)/(2))",
                      "non-associative": "non-associative problem (MCP (3) / MPEC (4))"}.get(problem, "all rows"))
        if not drawn:
            ax.text(0.5, 0.5, "no row with a multiplier and a reference", transform=ax.transAxes, ha="center")
        handles = [Line2D([], [], ls="", marker=method_style(m, methods.get(m))[1],
                          color=method_style(m, methods.get(m))[0], label=m) for m in labels]
        handles.append(Line2D([], [], ls="", marker="o", markerfacecolor="none", color="0.2", label="not verified"))
        if problem == "non-associative" and results:
            handles.append(Line2D([], [], ls="--", color="0.3", label="certificate: bound (trace)"))
            handles.append(Line2D([], [], ls="-", color="0.3", label="certificate: incumbent (trace)"))
        ax.legend(handles=handles, loc="best", frameon=False, fontsize=7)
    fig.suptitle(title or f"Error of the collapse multiplier against run time (errors below {ERROR_FLOOR:.0e} drawn "
                 f"on the dotted line)\nreference: closed form > certified minimum > best verified value of another "
                 "method")
    return _save(fig, path)


# --------------------------------------------------------------------------- convergence


def convergence(traces: dict[str, list[dict[str, Any]]], path: str | Path, *, title: str = "",
                without: Sequence[str] = (), methods: dict[str, str] | None = None) -> Path:
    r"""Convergence traces: ``lam`` and ``||n - n^*|| / ||n||`` against iteration and time.

    Parameters
    ----------
    traces : dict
        Method label -> :attr:`Result.trace` (records with ``iteration``, ``time_s``,
        ``multiplier`` and, for the LP-sequence methods, ``n_change`` ``= ||n - n^*|| / ||n||``;
        a certifying method's ``bound``).  Methods with an empty trace are left out.
    path : path of the PNG.
    without : labels of the methods that ran but recorded no trace (named on the figure).
    methods : label -> method name (for the fixed styles), optional.

    Four panels: ``lam`` vs iteration and vs time (a method's bound dashed, where its trace
    has one), ``n_change`` vs iteration and vs time (log scale; only the methods whose trace
    has the measure, named in the panel).  Every method records ``time_s`` as time elapsed
    since its run started.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(8.6, 6.4), sharex="col", layout="constrained")
    series = [(label, tr) for label, tr in traces.items() if tr]
    with_n, no_lam = [], []
    for label, tr in series:
        colour, m = method_style(label, (methods or {}).get(label))
        it = np.array([_num(r.get("iteration")) for r in tr])
        ts = np.array([_num(r.get("time_s")) for r in tr])
        lam = np.array([_num(r.get("incumbent", r.get("multiplier"))) for r in tr])
        kw = dict(marker=m, ms=3.5, lw=1.0, label=label, color=colour)
        if np.isfinite(lam).any():
            axes[0, 0].plot(it, lam, **kw)
            axes[0, 1].plot(ts, lam, **kw)
        else:
            no_lam.append(label)
        tb, lo, _ = _bound_trace(tr)
        if tb.size:
            itb = np.array([_num(r.get("iteration")) for r in tr if _finite(r.get("bound", r.get("dual_bound")))
                            and _finite(r.get("time_s"))])
            # bounds far below the answer (the first, from the LP relaxations) would flatten the panel
            floor = np.nanmin(lam) - 0.5 * abs(np.nanmin(lam)) if np.isfinite(lam).any() else -np.inf
            keep = lo >= floor
            axes[0, 0].plot(itb[keep], lo[keep], ls="--", lw=1.0, color=colour)
            axes[0, 1].plot(tb[keep], lo[keep], ls="--", lw=1.0, color=colour, label=f"{label}: bound")
        if any("n_change" in r for r in tr):
            dn = np.array([max(_num(r.get("n_change")), ERROR_FLOOR) for r in tr])
            axes[1, 0].plot(it, dn, **kw)
            axes[1, 1].plot(ts, dn, **kw)
            with_n.append(label)
    for ax in axes[1]:
        ax.set_yscale("log")
    from matplotlib.ticker import MaxNLocator

    for ax in axes[0]:
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
        lo, hi = ax.get_ylim()
        mid = 0.5 * (lo + hi)
        if series and hi - lo < 1e-3 * max(abs(mid), 1e-12):  # flat traces: show 5 significant digits, not noise
            half = 5e-4 * max(abs(mid), 1e-12)
            ax.set_ylim(mid - half, mid + half)
    for ax in axes[:, 1]:
        ax.set_xscale("log")
    axes[1, 0].xaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in axes[1]:
        lo, hi = ax.get_ylim()
        if with_n and hi / max(lo, ERROR_FLOOR) < 100:
            ax.set_ylim(max(lo / 10, ERROR_FLOOR / 10), hi * 10)
    axes[0, 0].set_ylabel(r"$\lambda$")
    axes[1, 0].set_ylabel(r"$\|n-n^*\|\,/\,\|n\|$")
    axes[1, 0].set_xlabel("iteration")
    axes[1, 1].set_xlabel("time [s]")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    others = [label for label, _ in series if label not in with_n]
    axes[1, 0].text(0.02, 0.02, "only the fixed-point-type methods measure this"
                    + (f"\nno such measure: {', '.join(others)}" if others else ""),
                    transform=axes[1, 0].transAxes, fontsize=7, color="0.35", va="bottom")
    if not series:
        axes[0, 0].text(0.5, 0.5, "no method recorded a trace", transform=axes[0, 0].transAxes, ha="center")
    else:
        axes[0, 1].legend(loc="best", frameon=False)
    missing = list(without) + no_lam
    note = f"\nno trace recorded (nothing to plot): {', '.join(missing)}" if missing else ""
    fig.suptitle((title or "Convergence") + note)
    return _save(fig, path)


# --------------------------------------------------------------------------- mechanisms


def displaced_polygons(structure, ops, u: np.ndarray, amplitude: float = 0.12) -> tuple[dict[int, np.ndarray], float]:
    """Rigidly displaced polygons of the free blocks and the scale factor used.

    Parameters
    ----------
    structure : Structure
    ops : Operators
        Its assembled operators (for ``free_blocks`` and ``length_scale``).
    u : ndarray, shape (3b,)
        The mechanism in scaled units.
    amplitude : float
        Largest vertex displacement as a fraction of the structure's size
        (the larger side of its bounding box).

    Returns
    -------
    (dict, float)
        Structure block index -> displaced vertices, and the factor ``s``.
    """
    u = ops.velocities_to_structure(u).reshape(-1, 3)  # canonical frame -> structure axes (mirror)
    ell = float(ops.length_scale)
    centroid = structure.centroid
    polys = {int(j): structure.polygon(int(j)) for j in ops.free_blocks}
    all_xy = np.vstack([structure.polygon(i) for i in range(structure.n_blocks) if not structure.fixed[i]])
    size = float(np.ptp(all_xy, axis=0).max())
    # unit-scale motion size: translation + rotation arm
    reach = 0.0
    for i, j in enumerate(ops.free_blocks):
        arm = np.linalg.norm(polys[int(j)] - centroid[j], axis=1).max()
        reach = max(reach, ell * np.hypot(u[i, 0], u[i, 1]) + abs(u[i, 2]) * arm)
    s = amplitude * size / reach if reach > 0 else 0.0
    out = {}
    for i, j in enumerate(ops.free_blocks):
        c = centroid[j]
        a = s * u[i, 2]
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        out[int(j)] = c + s * ell * u[i, :2] + (polys[int(j)] - c) @ rot.T
    return out, s


_MOVING, _STILL = "#d9822b", "#e8e2d4"


def _draw_mechanism(ax, structure, ops, u, title: str, amplitude: float) -> None:
    from matplotlib.patches import FancyArrowPatch, Polygon

    for i in range(structure.n_blocks):
        if structure.fixed[i]:
            ax.add_patch(Polygon(structure.polygon(i), closed=True, facecolor="0.75", edgecolor="0.35", lw=0.6,
                                 hatch="///"))
        else:
            ax.add_patch(Polygon(structure.polygon(i), closed=True, fill=False, edgecolor="0.65", lw=0.6, ls="--"))
    if u is not None:
        moved, _ = displaced_polygons(structure, ops, u, amplitude)
        uu = np.asarray(u, float).reshape(-1, 3)
        mag = np.hypot(uu[:, 0], uu[:, 1]) + np.abs(uu[:, 2])
        top = mag.max() if mag.size and mag.max() > 0 else 1.0
        for i, j in enumerate(ops.free_blocks):
            moving = mag[i] > 1e-6 * top
            ax.add_patch(Polygon(moved[int(j)], closed=True, facecolor=_MOVING if moving else _STILL,
                                 edgecolor="0.1", lw=0.7, alpha=0.9))
        ax.text(0.0, -0.02, f"amplitude: largest vertex displacement drawn = {amplitude:.0%} of the structure's size\n"
                "(a mechanism is defined up to a positive factor)", transform=ax.transAxes, fontsize=7,
                color="0.3", va="top")
    else:
        ax.text(0.5, 0.5, "no mechanism", transform=ax.transAxes, ha="center")
    # the live load: a horizontal body force, direction x factor x weight
    xy = np.vstack([structure.polygon(i) for i in range(structure.n_blocks) if not structure.fixed[i]])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    size = float(max(hi - lo))
    sign = 1.0 if float(getattr(structure, "live_direction", 1)) * float(getattr(structure, "live_factor", 1.0)) >= 0 \
        else -1.0
    y = lo[1] + 0.8 * (hi[1] - lo[1])
    if sign > 0:  # the arrow stands on the side the load pushes from
        x0, x1 = lo[0] - 0.30 * size, lo[0] - 0.08 * size
    else:
        x0, x1 = hi[0] + 0.30 * size, hi[0] + 0.08 * size
    ax.add_patch(FancyArrowPatch((x0, y), (x1, y), arrowstyle="-|>", mutation_scale=14, color="#1f4e9c", lw=1.6))
    ax.text(0.5 * (x0 + x1), y + 0.03 * size, r"$\lambda f_l$", color="#1f4e9c", ha="center", va="bottom", fontsize=9)
    ax.set_title(title)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.04)
    ax.set_axis_off()


def _mechanism_legend(fig) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [
        Patch(facecolor="none", edgecolor="0.5", ls="--", label="undeformed"),
        Patch(facecolor="0.75", edgecolor="0.35", hatch="///", label="fixed (support)"),
        Patch(facecolor=_MOVING, edgecolor="0.1", label="moving block (displaced)"),
        Patch(facecolor=_STILL, edgecolor="0.1", label="block at rest"),
        Line2D([], [], color="#1f4e9c", marker=">", lw=1.6, label=r"live load $\lambda f_l$ (horizontal)"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=5, frameon=False, fontsize=8, bbox_to_anchor=(0.5, -0.02))


def mechanisms(
    structure,
    panels: Sequence[tuple[str, np.ndarray | None]],
    path: str | Path,
    *,
    ops=None,
    amplitude: float = 0.12,
    title: str = "",
) -> Path:
    """Collapse mechanisms side by side (e.g. associative beside non-associative).

    Undeformed blocks are dashed outlines, fixed blocks hatched grey, displaced blocks
    filled (orange if they move, pale if their motion is below 1e-6 of the largest); an
    arrow shows the live load's direction; a legend explains them, and each panel states
    its amplitude (the largest vertex displacement drawn, as a fraction ``amplitude`` of
    the structure's size; see the module docstring).

    Parameters
    ----------
    structure : Structure
    panels : sequence of (title, u)
        ``u`` is :attr:`Solution.u` (scaled units) or None.
    path : path of the PNG.
    ops : Operators, optional
        ``assemble(structure)`` if not given.
    """
    plt = _pyplot()
    if ops is None:
        from blockmpec.operators import assemble

        ops = assemble(structure)
    xy = np.vstack([structure.polygon(i) for i in range(structure.n_blocks)])
    w, h = np.ptp(xy, axis=0)
    n = max(len(panels), 1)
    panel_w = 4.6
    fig, axes = plt.subplots(1, n, figsize=(panel_w * n, panel_w * min(max(h / w, 0.35), 1.6) + 1.4), squeeze=False,
                             layout="constrained")
    for ax, (label, u) in zip(axes[0], panels):
        _draw_mechanism(ax, structure, ops, u, label, amplitude)
    _mechanism_legend(fig)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


# --------------------------------------------------------------------------- helpers




def _num(v: Any) -> float:
    return float(v) if _finite(v) else math.nan


# --------------------------------------------------------------------------- all figures of a comparison


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in text).strip("_")


def comparison_figures(df, results: dict, out_dir: str | Path) -> list[Path]:
    """Every figure of a comparison into ``out_dir``; returns the paths.

    * ``error_vs_time.png``: :func:`error_vs_time`, associative and non-associative panels,
      with the certificates' traces;
    * ``performance_profile.png``: :func:`blockmpec.bench.profiles.plot_profiles`;
    * ``convergence_<case>.png``: :func:`convergence` of the methods that kept a trace
      (first repetition), naming those that did not;
    * ``mechanism_<case>.png``: :func:`mechanisms`, associative (the first successful
      associative method, ``static-lp`` preferred) beside non-associative (the
      successful non-associative run with the smallest ``lam``).

    ``results`` is the dict filled by :func:`blockmpec.bench.compare.compare` (``results=``).
    """
    from blockmpec.bench.profiles import plot_profiles
    from blockmpec.operators import assemble

    out = Path(out_dir)
    paths = [error_vs_time(df, out / "error_vs_time.png", results=results),
             plot_profiles(df, out / "performance_profile.png")]
    first = df[df["repetition"] == 0]
    for case in dict.fromkeys(first["case"]):
        rows = first[first["case"] == case]
        traces, without = {}, []
        for _, r in rows.iterrows():
            got = results.get((case, r["method_label"], 0))
            if got is not None and got[0].trace:
                traces[r["method_label"]] = got[0].trace
            elif r["status"] != "skipped":
                without.append(r["method_label"])
        names = dict(zip(rows["method_label"], rows["method"]))
        paths.append(convergence(traces, out / f"convergence_{_slug(case)}.png", title=f"Convergence: {case}",
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
                panels.append((f"{kind} ({label})\n$\\lambda$ = {res.multiplier:.5f}", res.solution.u))
            else:
                panels.append((f"{kind}: no successful run", None))
        if structure is None:
            got = next((results[k] for k in results if k[0] == case), None)
            structure = got[1] if got else None
        if structure is not None:
            paths.append(mechanisms(structure, panels, out / f"mechanism_{_slug(case)}.png",
                                    ops=assemble(structure), title=f"Collapse mechanisms: {case}"))
    return paths
