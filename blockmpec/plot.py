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

#: relative errors below this are drawn at this value on log axes (exact answers)
ERROR_FLOOR = 1e-16

_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*", "h", "p")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 10, "axes.titlesize": 10, "legend.fontsize": 8, "savefig.dpi": 200})
    return plt


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


# --------------------------------------------------------------------------- error vs time


def error_vs_time(df, path: str | Path, *, time_column: str = "solve_time_s", title: str | None = None) -> Path:
    """Relative error of ``lam`` against run time, every method on every case.

    One marker shape per method label, one colour per case; filled markers for
    verified answers (solutions of (3)), open markers for unverified ones.  The
    error is ``|lam - lam_ref| / |lam_ref|`` (columns of
    :func:`blockmpec.compare.compare`), floored at :data:`ERROR_FLOOR` so exact
    answers show on log axes.  Rows without a multiplier or reference are left out.

    Parameters
    ----------
    df : pandas.DataFrame
        The table of :func:`blockmpec.compare.compare`.
    path : path of the PNG.
    time_column : {"solve_time_s", "total_time_s"}
    """
    plt = _pyplot()
    methods = list(dict.fromkeys(df["method_label"]))
    cases = list(dict.fromkeys(df["case"]))
    colours = plt.get_cmap("tab10")
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for _, r in df.iterrows():
        err, t = r.get("rel_error"), r.get(time_column)
        if not _finite(err) or not _finite(t):
            continue
        m = _MARKERS[methods.index(r["method_label"]) % len(_MARKERS)]
        colour = colours(cases.index(r["case"]) % 10)
        verified = bool(r.get("verified"))
        ax.scatter(max(float(t), 1e-6), max(float(err), ERROR_FLOOR), marker=m, s=42,
                   facecolors=colour if verified else "none", edgecolors=colour, linewidths=1.2, zorder=3)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("solve time [s]" if time_column == "solve_time_s" else "set-up + solve time [s]")
    ax.set_ylabel(r"relative error $|\lambda-\lambda_{ref}|\,/\,\lambda_{ref}$")
    ax.axhline(ERROR_FLOOR, color="0.6", lw=0.8, ls=":")
    ax.text(1.01, 0.0, f"errors < {ERROR_FLOOR:.0e}\ndrawn at {ERROR_FLOOR:.0e}\n(dotted line)",
            transform=ax.transAxes, ha="left", va="bottom", fontsize=7, color="0.4")
    ax.grid(True, which="major", alpha=0.3)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], ls="", marker=_MARKERS[i % len(_MARKERS)], color="0.2", label=m)
               for i, m in enumerate(methods)]
    handles += [Line2D([], [], ls="", marker="s", color=colours(i % 10), label=c) for i, c in enumerate(cases)]
    handles.append(Line2D([], [], ls="", marker="o", markerfacecolor="none", color="0.2", label="not verified"))
    ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    ax.set_title(title or "Error of the collapse multiplier against run time\n"
                 "(reference: certified minimum, else best verified value, else closed form)")
    return _save(fig, path)


# --------------------------------------------------------------------------- convergence


def convergence(traces: dict[str, list[dict[str, Any]]], path: str | Path, *, title: str = "") -> Path:
    r"""Convergence traces: ``lam`` and ``||n - n^*|| / ||n||`` against iteration and time.

    Parameters
    ----------
    traces : dict
        Method label -> :attr:`Result.trace` (records with ``iteration``,
        ``time_s``, ``multiplier`` and, for the LP-sequence methods, ``n_change``
        ``= ||n - n^*|| / ||n||``).  Methods with an empty trace are left out.
    path : path of the PNG.

    Four panels: ``lam`` vs iteration, ``lam`` vs time, ``n_change`` vs iteration
    and vs time (log scale; only methods whose trace has ``n_change``).  Every
    method records ``time_s`` as time elapsed since its run started.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(8.0, 6.0), sharex="col", layout="constrained")
    series = [(label, tr) for label, tr in traces.items() if tr]
    for i, (label, tr) in enumerate(series):
        m = _MARKERS[i % len(_MARKERS)]
        it = np.array([_num(r.get("iteration")) for r in tr])
        ts = np.array([_num(r.get("time_s")) for r in tr])
        lam = np.array([_num(r.get("multiplier")) for r in tr])
        kw = dict(marker=m, ms=3.5, lw=1.0, label=label, color=plt.get_cmap("tab10")(i % 10))
        axes[0, 0].plot(it, lam, **kw)
        axes[0, 1].plot(ts, lam, **kw)
        if any("n_change" in r for r in tr):
            dn = np.array([max(_num(r.get("n_change")), ERROR_FLOOR) for r in tr])
            axes[1, 0].plot(it, dn, **kw)
            axes[1, 1].plot(ts, dn, **kw)
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
        if series and hi / max(lo, ERROR_FLOOR) < 100:
            ax.set_ylim(max(lo / 10, ERROR_FLOOR / 10), hi * 10)
    axes[0, 0].set_ylabel(r"$\lambda$")
    axes[1, 0].set_ylabel(r"$\|n-n^*\|\,/\,\|n\|$")
    axes[1, 0].set_xlabel("iteration")
    axes[1, 1].set_xlabel("time [s]")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    if not series:
        axes[0, 0].text(0.5, 0.5, "no method recorded a trace", transform=axes[0, 0].transAxes, ha="center")
    else:
        axes[0, 1].legend(loc="best", frameon=False)
    fig.suptitle(title or "Convergence")
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
    u = np.asarray(u, float).reshape(-1, 3)
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


def _draw_mechanism(ax, structure, ops, u, title: str, amplitude: float) -> None:
    from matplotlib.patches import Polygon

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
            ax.add_patch(Polygon(moved[int(j)], closed=True, facecolor="#d9822b" if moving else "#e8e2d4",
                                 edgecolor="0.1", lw=0.7, alpha=0.9))
    else:
        ax.text(0.5, 0.5, "no mechanism", transform=ax.transAxes, ha="center")
    ax.set_title(title)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.04)
    ax.set_axis_off()


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

    Undeformed blocks are dashed outlines, fixed blocks hatched grey, displaced
    blocks filled (orange if they move, pale if their motion is below 1e-6 of
    the largest).  Each panel is scaled on its own (see the module docstring).

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
    panel_w = 4.2
    fig, axes = plt.subplots(1, n, figsize=(panel_w * n, panel_w * min(max(h / w, 0.35), 1.6) + 0.8), squeeze=False,
                             layout="constrained")
    for ax, (label, u) in zip(axes[0], panels):
        _draw_mechanism(ax, structure, ops, u, label, amplitude)
    if title:
        fig.suptitle(title)
    return _save(fig, path)


# --------------------------------------------------------------------------- helpers


def _finite(v: Any) -> bool:
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _num(v: Any) -> float:
    return float(v) if _finite(v) else math.nan


# --------------------------------------------------------------------------- all figures of a comparison


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in text).strip("_")


def comparison_figures(df, results: dict, out_dir: str | Path) -> list[Path]:
    """Every figure of a comparison into ``out_dir``; returns the paths.

    * ``error_vs_time.png``: :func:`error_vs_time` over all rows;
    * ``convergence_<case>.png``: :func:`convergence` of the methods that kept a trace
      (first repetition);
    * ``mechanism_<case>.png``: :func:`mechanisms`, associative (the first successful
      associative method, ``static-lp`` preferred) beside non-associative (the
      successful non-associative run with the smallest ``lam``, i.e. the one that
      set or matched the reference).

    ``results`` is the dict filled by :func:`blockmpec.compare.compare` (``results=``).
    """
    from blockmpec.operators import assemble

    out = Path(out_dir)
    paths = [error_vs_time(df, out / "error_vs_time.png")]
    first = df[df["repetition"] == 0]
    for case in dict.fromkeys(first["case"]):
        rows = first[first["case"] == case]
        traces = {}
        for _, r in rows.iterrows():
            got = results.get((case, r["method_label"], 0))
            if got is not None and got[0].trace:
                traces[r["method_label"]] = got[0].trace
        paths.append(convergence(traces, out / f"convergence_{_slug(case)}.png", title=f"Convergence: {case}"))
        assoc = rows[(rows["problem"] == "associative") & rows["success"].astype(bool)]
        if len(assoc):
            order = sorted(range(len(assoc)), key=lambda k: assoc["method"].iloc[k] != "static-lp")
            assoc = assoc.iloc[order[:1]]
        na = rows[(rows["problem"] == "non-associative") & rows["success"].astype(bool)]
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
