r"""Drawings of results: collapse mechanisms with their joints, convergence, collapse-multiplier maps.

Every function draws into a matplotlib ``ax`` you pass (``ax=None``: a new figure through
:mod:`matplotlib.pyplot`) and returns the matplotlib objects; nothing is written to a file, and no
global setting (backend, ``rcParams``) is changed.  Put the drawings into your own figures::

    import matplotlib.pyplot as plt
    import blockmpec as bm

    wall = bm.cases.wall(courses=4, blocks_per_course=3)
    res = bm.solve(wall, "fixed-point")
    fig, ax = plt.subplots()
    bm.plot.mechanism(res, wall, ax=ax)
    fig.savefig("mechanism.pdf")

The comparator's figures (:mod:`blockmpec.bench.plots`: error against time, performance profiles and the
PNG files of ``blockmpec compare``) are built from these.

Collapse mechanism (:func:`mechanism`, :func:`joints`)
------------------------------------------------------
The mechanism is :attr:`blockmpec.Result.mechanism`: the velocity ``(u_x, u_y)`` of each free block's
centroid ``c`` and its rotation rate ``theta`` (counter-clockwise), in the structure's frame and units.
A point ``p`` of block ``i`` moves with

.. math:: v_i(p) = (u_x - \theta\,(p_y - c_y),\; u_y + \theta\,(p_x - c_x)),

and a fixed block does not move.  At interface ``k`` (minus block ``m``, plus block ``q``, end points
``s`` and ``e``, tangent ``tau = (e - s)/L``, normal ``nu = rot90(tau)`` from minus into plus, as in
:mod:`blockmpec.report`) the relative velocity of the plus block is ``w(p) = v_q(p) - v_m(p)``.  Its
tangential part ``slip = w . tau`` is the same at every point of the interface (a rigid motion), its
normal part ``opening(p) = w(p) . nu`` varies linearly along it.  With ``v_ref`` the largest speed of a
vertex of a free block and ``eps = tol v_ref``:

* **sliding** joint: ``|slip| > eps`` (relative tangential motion);
* **hinge** at an end of a joint that does not slide: the opening is at most ``eps`` at that end and more
  than ``eps`` at the other -- the blocks rotate relative to each other about that end (the rotation
  centre);
* **opening**: the opening exceeds ``eps`` at both ends (the blocks separate);
* **rest**: no relative motion beyond ``eps``.

A block drawn displaced is moved rigidly, vertex ``p`` to ``c + s (u_x, u_y) + R(s theta)(p - c)``, with
one factor ``s`` per drawing so that the largest first-order vertex displacement is ``amplitude`` times
the structure's size (a mechanism is defined up to a positive factor, so only its shape matters).

Collapse-multiplier map (:func:`multiplier_map`)
------------------------------------------------
The collapse multiplier over a grid of two parameters of a case (the seed paper's Figs 5-6 for the
two-block problem over slenderness ``eta`` and friction ``mu``): one :func:`blockmpec.solve` per grid
point, drawn as a colour map of ``lam`` with contour lines (``show="multiplier"``, Fig. 6 style) or as a
partition of the plane into regions of the same mechanism (``show="mechanism"``, Fig. 5 style), two
mechanisms being the same when every joint is in the same state (:func:`joints`).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

__all__ = ["METHOD_STYLES", "MapResult", "convergence", "joints", "mechanism", "method_style", "multiplier_map"]

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

#: colours of the mechanism drawing
MOVING, STILL, HINGE, SLIDING, LOAD = "#d9822b", "#e8e2d4", "#111111", "#c0392b", "#1f4e9c"
#: relative errors and changes below this are drawn at this value on log axes
FLOOR = 1e-16


def method_style(label: str, method: str | None = None) -> tuple[str, str]:
    """The fixed ``(colour, marker)`` of a method label.

    A registered method has its own entry in :data:`METHOD_STYLES`; a label with options
    (``fixed-point[relaxation=0.5]``) keeps its method's colour and takes a marker derived
    from the label; an unknown method gets a colour and marker derived from its name
    (CRC-32, so the same in every run).
    """
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


# --------------------------------------------------------------------------- figure helpers


def _axes(ax=None, **subplots: Any):
    """``ax``, or the axes of a new pyplot figure (so that it shows in a notebook or a window)."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    subplots.setdefault("layout", "constrained")
    return plt.subplots(**subplots)[1]


def _finite(v: Any) -> bool:
    try:
        return v is not None and not isinstance(v, bool) and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _num(v: Any) -> float:
    return float(v) if _finite(v) else math.nan


# --------------------------------------------------------------------------- mechanism


def _mechanism_frame(result: Any):
    """The mechanism DataFrame of a Result, or the frame itself (None: no mechanism)."""
    import pandas as pd

    frame = result if isinstance(result, pd.DataFrame) else getattr(result, "mechanism", None)
    if frame is None or not len(frame):
        return None
    return frame


def _motions(structure, frame) -> tuple[np.ndarray, np.ndarray]:
    """Per structure block: ``(u_x, u_y, theta)`` (zeros for fixed and missing blocks), and a mask of the
    blocks that have a row in ``frame``."""
    n = structure.n_blocks
    u = np.zeros((n, 3))
    have = np.zeros(n, bool)
    if frame is not None:
        blocks = np.asarray(frame["block"], int)
        if blocks.size and (blocks.min() < 0 or blocks.max() >= n):
            from blockmpec.errors import StructureError

            raise StructureError(f"mechanism: block {int(blocks.max())} is not a block of this structure "
                                 f"({n} blocks); pass the structure the result was solved for")
        u[blocks] = np.column_stack([np.asarray(frame[c], float) for c in ("u_x", "u_y", "rotation")])
        have[blocks] = True
    return u, have


def _velocity(u: np.ndarray, centroid: np.ndarray, block: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Velocity of the points ``p`` (k x 2) as points of ``block`` (k,)."""
    ux, uy, th = u[block, 0], u[block, 1], u[block, 2]
    c = centroid[block]
    return np.column_stack([ux - th * (p[:, 1] - c[:, 1]), uy + th * (p[:, 0] - c[:, 0])])


def _reference_speed(structure, u: np.ndarray, have: np.ndarray) -> float:
    """The largest speed of a vertex of a block that moves (``v_ref`` of the module docstring)."""
    centroid = structure.centroid
    top = 0.0
    for i in np.flatnonzero(have):
        poly = structure.polygon(int(i))
        v = _velocity(u, centroid, np.full(len(poly), i), poly)
        top = max(top, float(np.hypot(v[:, 0], v[:, 1]).max()))
    return top


def joints(result: Any, structure, *, tol: float = 1e-6):
    """The state of every interface in a collapse mechanism: sliding, hinge, opening or at rest.

    Parameters
    ----------
    result : Result or pandas.DataFrame
        A result with a mechanism (:attr:`blockmpec.Result.mechanism`), or such a frame (columns
        ``block, u_x, u_y, rotation``, e.g. read back from ``blockmpec solve --mechanism``).
    structure : Structure
        The structure it was solved for (its blocks and interfaces in its own frame).
    tol : float
        Relative threshold: motions below ``tol`` times the largest vertex speed count as none.

    Returns
    -------
    pandas.DataFrame
        One row per interface of the structure, in its order: ``interface, minus, plus, slip`` (relative
        tangential velocity of the plus block, ``w . tau``), ``opening_start, opening_end`` (``w . nu`` at the
        two ends), ``sliding`` (bool), ``hinge`` (``"start"``, ``"end"`` or ``""``), ``hinge_x, hinge_y`` (the
        rotation centre, NaN without a hinge) and ``state`` (``"sliding"``, ``"hinge"``, ``"opening"`` or
        ``"rest"``; a joint that slides is ``"sliding"`` whatever its opening).  Definitions in the module
        docstring.  Empty (with these columns) when the result has no mechanism.
    """
    import pandas as pd

    columns = ("interface", "minus", "plus", "slip", "opening_start", "opening_end", "sliding", "hinge", "hinge_x",
               "hinge_y", "state")
    frame = _mechanism_frame(result)
    itf = structure.interfaces
    if frame is None:
        return pd.DataFrame({c: [] for c in columns})
    u, have = _motions(structure, frame)
    centroid = structure.centroid
    minus, plus = np.asarray(itf.minus, int), np.asarray(itf.plus, int)
    start, end = np.asarray(itf.start, float).reshape(-1, 2), np.asarray(itf.end, float).reshape(-1, 2)
    length = np.hypot(*(end - start).T)
    tau = (end - start) / np.where(length > 0, length, 1.0)[:, None]
    nu = np.column_stack([-tau[:, 1], tau[:, 0]])
    w_start = _velocity(u, centroid, plus, start) - _velocity(u, centroid, minus, start)
    w_end = _velocity(u, centroid, plus, end) - _velocity(u, centroid, minus, end)
    slip = np.einsum("kd,kd->k", w_start, tau)
    open_s, open_e = np.einsum("kd,kd->k", w_start, nu), np.einsum("kd,kd->k", w_end, nu)
    eps = tol * _reference_speed(structure, u, have)
    sliding = np.abs(slip) > eps
    still_s, still_e = np.abs(open_s) <= eps, np.abs(open_e) <= eps
    hinge = np.where(~sliding & still_s & ~still_e, "start", np.where(~sliding & still_e & ~still_s, "end", ""))
    hinge_xy = np.full((len(minus), 2), np.nan)
    hinge_xy[hinge == "start"] = start[hinge == "start"]
    hinge_xy[hinge == "end"] = end[hinge == "end"]
    state = np.where(sliding, "sliding", np.where(hinge != "", "hinge",
                                                  np.where(~still_s & ~still_e, "opening", "rest")))
    return pd.DataFrame({
        "interface": np.arange(len(minus)), "minus": minus, "plus": plus, "slip": slip + 0.0,
        "opening_start": open_s + 0.0, "opening_end": open_e + 0.0, "sliding": sliding, "hinge": hinge,
        "hinge_x": hinge_xy[:, 0], "hinge_y": hinge_xy[:, 1], "state": state,
    })


def displaced_polygons(structure, frame, amplitude: float = 0.12) -> tuple[dict[int, np.ndarray], float]:
    """Rigidly displaced polygons of the blocks of a mechanism, and the factor ``s`` used.

    Parameters
    ----------
    structure : Structure
    frame : pandas.DataFrame or Result
        The mechanism (:attr:`blockmpec.Result.mechanism`, the structure's frame and units).
    amplitude : float
        The largest first-order vertex displacement ``s (|u| + |theta| r)`` as a fraction of the
        structure's size (the larger side of the bounding box of its free blocks).

    Returns
    -------
    (dict, float)
        Structure block index -> displaced vertices (every block of the frame), and ``s``.
    """
    frame = _mechanism_frame(frame)
    u, have = _motions(structure, frame)
    centroid = structure.centroid
    free = [i for i in range(structure.n_blocks) if not structure.fixed[i]] or list(range(structure.n_blocks))
    size = float(np.ptp(np.vstack([structure.polygon(i) for i in free]), axis=0).max())
    reach = 0.0
    for i in np.flatnonzero(have):
        arm = np.linalg.norm(structure.polygon(int(i)) - centroid[i], axis=1).max()
        reach = max(reach, float(np.hypot(u[i, 0], u[i, 1]) + abs(u[i, 2]) * arm))
    s = amplitude * size / reach if reach > 0 else 0.0
    out = {}
    for i in np.flatnonzero(have):
        c = centroid[i]
        a = s * u[i, 2]
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        out[int(i)] = c + s * u[i, :2] + (structure.polygon(int(i)) - c) @ rot.T
    return out, s


def _moved_point(p: np.ndarray, block: int, u: np.ndarray, centroid: np.ndarray, s: float,
                 fixed: bool) -> np.ndarray:
    """Where the drawing puts point ``p`` of ``block`` (displaced with its block)."""
    if fixed:
        return p
    c = centroid[block]
    a = s * u[block, 2]
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return c + s * u[block, :2] + rot @ (p - c)


def mechanism(result: Any, structure, *, ax=None, amplitude: float = 0.12, show_joints: bool = True,
              tol: float = 1e-6, legend: bool = True, load_arrow: bool = True, title: str | None = None):
    """Draw a collapse mechanism: the blocks at rest and displaced, hinges and sliding joints marked.

    Undeformed blocks are dashed outlines, fixed blocks hatched grey, displaced blocks filled (orange
    if they move, pale if they stay at rest); **hinges** (relative rotation centres at interface ends)
    are black dots, **sliding joints** (relative tangential motion) red lines along the interface with
    an arrow giving the plus block's motion relative to the minus block (:func:`joints`); an arrow shows
    the live load.  The legend, beside the drawing, names only what is drawn and states the amplitude.

    Parameters
    ----------
    result : Result or pandas.DataFrame
        A result with a mechanism, or its :attr:`~blockmpec.Result.mechanism` frame.  A result without
        a mechanism draws the structure alone, saying so.
    structure : Structure
        The structure the result was solved for.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    amplitude : float
        The largest vertex displacement drawn, as a fraction of the structure's size.
    show_joints : bool
        Mark hinges and sliding joints.
    tol : float
        Threshold of :func:`joints`.
    legend : bool
        Add the legend (right of the axes, outside the drawing).
    load_arrow : bool
        Draw the live load's direction.
    title : str, optional
        Axes title (default: the method and ``lam`` of a result).

    Returns
    -------
    matplotlib.axes.Axes
        With ``ax.mechanism_handles``, the legend entries of what was drawn (for one legend over several
        drawings, as the comparator's figures have), and ``ax.mechanism_note``, the amplitude statement.

    Examples
    --------
    >>> wall = bm.cases.wall(courses=4, blocks_per_course=3)          # doctest: +SKIP
    >>> ax = bm.plot.mechanism(bm.solve(wall, "fixed-point"), wall)   # doctest: +SKIP
    >>> ax.figure.savefig("mechanism.png")                            # doctest: +SKIP

    A 3D structure (:class:`~blockmpec.three_d.Structure3D`) is drawn by :func:`blockmpec.three_d.plot.mechanism`
    (``ax`` then a 3D axes).
    """
    if getattr(structure, "dim", 2) == 3:
        from blockmpec.three_d.plot import mechanism as mechanism_3d

        return mechanism_3d(result, structure, ax=ax, amplitude=amplitude, title=title)
    from matplotlib.patches import Patch

    ax = _axes(ax)
    frame = _mechanism_frame(result)
    handles = [Patch(facecolor="none", edgecolor="0.5", ls="--", label="undeformed")]
    lo, hi, size = _draw_at_rest(ax, structure, handles)
    legend_title = None
    if frame is not None:
        moved, s = displaced_polygons(structure, frame, amplitude)
        u, _ = _motions(structure, frame)
        _draw_displaced(ax, structure, frame, moved, tol, handles)
        if show_joints:
            _draw_joints(ax, structure, frame, u, s, tol, handles)
        legend_title = (f"largest displacement drawn = {amplitude:.0%} of the structure's size\n"
                        "(a mechanism is defined up to a positive factor)")
        lo = np.minimum(lo, np.vstack(list(moved.values())).min(axis=0)) if moved else lo
        hi = np.maximum(hi, np.vstack(list(moved.values())).max(axis=0)) if moved else hi
    else:
        ax.text(0.5, 0.5, "no mechanism", transform=ax.transAxes, ha="center")
    if load_arrow:
        _draw_load_arrow(ax, structure, lo, hi, size, handles)
    if title is None and frame is not None and getattr(result, "method", None):
        lam = getattr(result, "multiplier", None)
        title = f"{result.method}" + (f": $\\lambda$ = {lam:.6g}" if _finite(lam) else "")
    if title:
        ax.set_title(title)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.margins(0.04)
    ax.set_axis_off()
    ax.mechanism_handles = handles
    ax.mechanism_note = legend_title or ""
    if legend:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False, fontsize=7,
                  title=legend_title, title_fontsize=7, alignment="left")
    return ax


def _draw_at_rest(ax, structure, handles: list) -> tuple[np.ndarray, np.ndarray, float]:
    """The blocks at rest (fixed ones hatched grey, free ones dashed outlines); ``(lo, hi, size)`` of the free
    blocks' bounding box."""
    from matplotlib.patches import Patch, Polygon

    if any(structure.fixed):
        handles.append(Patch(facecolor="0.75", edgecolor="0.35", hatch="///", label="fixed (support)"))
    for i in range(structure.n_blocks):
        if structure.fixed[i]:
            ax.add_patch(Polygon(structure.polygon(i), closed=True, facecolor="0.75", edgecolor="0.35", lw=0.6,
                                 hatch="///"))
        else:
            ax.add_patch(Polygon(structure.polygon(i), closed=True, fill=False, edgecolor="0.65", lw=0.6, ls="--"))
    free = [i for i in range(structure.n_blocks) if not structure.fixed[i]] or list(range(structure.n_blocks))
    xy = np.vstack([structure.polygon(i) for i in free])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    return lo, hi, float(max(hi - lo))


def _draw_displaced(ax, structure, frame, moved: dict, tol: float, handles: list) -> None:
    """The displaced blocks, orange when they move and pale when they stay at rest."""
    from matplotlib.patches import Patch, Polygon

    u, have = _motions(structure, frame)
    centroid = structure.centroid
    v_ref = _reference_speed(structure, u, have)
    kinds = set()
    for j, poly in moved.items():
        arm = np.linalg.norm(structure.polygon(j) - centroid[j], axis=1).max()
        moving = np.hypot(u[j, 0], u[j, 1]) + abs(u[j, 2]) * arm > tol * v_ref
        kinds.add(moving)
        ax.add_patch(Polygon(poly, closed=True, facecolor=MOVING if moving else STILL, edgecolor="0.1", lw=0.7,
                             alpha=0.9))
    if True in kinds:
        handles.append(Patch(facecolor=MOVING, edgecolor="0.1", label="moving block (displaced)"))
    if False in kinds:
        handles.append(Patch(facecolor=STILL, edgecolor="0.1", label="block at rest"))


def _draw_joints(ax, structure, frame, u: np.ndarray, s: float, tol: float, handles: list) -> None:
    """Sliding joints (red lines with the plus block's relative motion) and hinges (black dots), displaced."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch

    centroid = structure.centroid
    state = joints(frame, structure, tol=tol)
    itf = structure.interfaces
    n_hinge = n_slide = 0
    for k in np.flatnonzero(state["sliding"].to_numpy()):
        m = int(itf.minus[k])
        a = _moved_point(np.asarray(itf.start[k], float), m, u, centroid, s, bool(structure.fixed[m]))
        b = _moved_point(np.asarray(itf.end[k], float), m, u, centroid, s, bool(structure.fixed[m]))
        ax.plot([a[0], b[0]], [a[1], b[1]], color=SLIDING, lw=2.6, solid_capstyle="butt", zorder=4)
        t = (b - a) / max(np.hypot(*(b - a)), 1e-300) * math.copysign(1.0, state["slip"].iloc[k])
        mid, half = 0.5 * (a + b), 0.22 * np.hypot(*(b - a))
        ax.add_patch(FancyArrowPatch(tuple(mid - half * t), tuple(mid + half * t), arrowstyle="-|>",
                                     mutation_scale=8, color=SLIDING, lw=1.0, zorder=5))
        n_slide += 1
    for k in np.flatnonzero((state["hinge"] != "").to_numpy()):
        m = int(itf.minus[k])
        p = np.array([state["hinge_x"].iloc[k], state["hinge_y"].iloc[k]])
        q = _moved_point(p, m, u, centroid, s, bool(structure.fixed[m]))
        ax.plot(q[0], q[1], "o", ms=5.5, mfc=HINGE, mec="white", mew=0.8, zorder=6)
        n_hinge += 1
    if n_hinge:
        handles.append(Line2D([], [], ls="", marker="o", ms=5.5, mfc=HINGE, mec="white",
                              label="hinge: relative rotation centre"))
    if n_slide:
        handles.append(Line2D([], [], color=SLIDING, lw=2.6, marker=">", ms=4,
                              label="sliding joint: relative tangential motion"))


def _draw_load_arrow(ax, structure, lo: np.ndarray, hi: np.ndarray, size: float, handles: list) -> None:
    """An arrow on the side the live load pushes from."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch

    sign = float(getattr(structure, "live_direction", 1)) * float(getattr(structure, "live_factor", 1.0))
    y = lo[1] + 0.8 * (hi[1] - lo[1])
    if sign >= 0:  # the arrow stands on the side the load pushes from
        x0, x1 = lo[0] - 0.30 * size, lo[0] - 0.08 * size
    else:
        x0, x1 = hi[0] + 0.30 * size, hi[0] + 0.08 * size
    ax.add_patch(FancyArrowPatch((x0, y), (x1, y), arrowstyle="-|>", mutation_scale=14, color=LOAD, lw=1.6))
    ax.text(0.5 * (x0 + x1), y + 0.03 * size, r"$\lambda f_l$", color=LOAD, ha="center", va="bottom",
            fontsize=9)
    handles.append(Line2D([], [], color=LOAD, marker=">", lw=1.6, label=r"live load $\lambda f_l$ (direction)"))


# --------------------------------------------------------------------------- convergence


def _trace_of(value: Any) -> list[dict[str, Any]]:
    if isinstance(value, list):
        return value
    return list(getattr(value, "trace", None) or [])


#: what :func:`convergence` can draw: ``y`` -> (axis label, log scale)
CONVERGENCE_MEASURES = {
    "multiplier": (r"$\lambda$ (incumbent)", False),
    "n_change": (r"$\|n-n^*\|\,/\,\|n\|$", True),
}
#: ``x`` -> axis label; ``"lp_step"`` counts LP steps, the one iteration that means the same in every method
#: that records it (``fixed-point``'s simplex engine, ``slp``: one LP solved per step; their traces carry
#: ``lp_iterations``)
CONVERGENCE_AXES = {
    "time": "time since the run started [s]",
    "lp_step": "LP step (one LP solved per step: fixed-point, slp)",
}


def convergence(results: Mapping[str, Any] | Sequence[Any], *, y: str = "multiplier", x: str = "time", ax=None,
                legend: bool = True, methods: Mapping[str, str] | None = None, bounds: bool = True):
    r"""Draw convergence: a measure of each method's iterates against time (or LP steps).

    Parameters
    ----------
    results : mapping or sequence
        ``label -> Result`` (or ``label -> trace``, a list of records), or a sequence of results
        (labelled by their method).  A result's :attr:`~blockmpec.Result.trace` holds records with
        ``time_s`` (seconds since its run started), ``iteration``, ``multiplier`` (or ``incumbent``), and
        for the LP-sequence methods ``n_change``; a certifying method's records carry its ``bound``.
    y : {"multiplier", "n_change"}
        ``lam`` of the iterates (with a certifying method's lower bound dashed, where it lies within
        the panel's range), or the change of the normal forces ``||n - n*|| / ||n||`` (log scale).
    x : {"time", "lp_step"}
        Time (log scale), for every method; or the LP step, only for the methods whose iteration is one LP
        (their traces carry ``lp_iterations``), so that one axis means one thing.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    legend : bool
        Add a legend (every entry is drawn on the axes).
    methods : mapping, optional
        Label -> method name, for the fixed styles of labels with options.
    bounds : bool
        Draw certifying methods' bounds (``y="multiplier"``).

    Returns
    -------
    matplotlib.axes.Axes
        ``ax.convergence_missing`` lists ``(label, reason)`` of the methods not drawn, ``ax.convergence_handles``
        the legend entries of what was drawn (for one legend over several panels).

    Notes
    -----
    With ``x="time"`` and ``y="multiplier"`` every method with a multiplier appears: one without a trace
    (the LPs) as a single point at its solve time.  A bound far below the answers (the first LP
    relaxations, more than half the answer's size below it) is left out rather than flatten the panel;
    the y-range always holds every point drawn.
    """
    if y not in CONVERGENCE_MEASURES:
        raise ValueError(f"y must be one of {', '.join(CONVERGENCE_MEASURES)}; got {y!r}")
    if x not in CONVERGENCE_AXES:
        raise ValueError(f"x must be one of {', '.join(CONVERGENCE_AXES)}; got {x!r}")
    ax = _axes(ax)
    if not isinstance(results, Mapping):
        results = {getattr(r, "method", f"run {i}"): r for i, r in enumerate(results)}
    methods = dict(methods or {})
    missing: list[tuple[str, str]] = []
    drawn_y: list[float] = []
    handles = []
    bound_lines = []
    for label, value in results.items():
        bound = _draw_trace(ax, label, value, x, y, methods, missing, drawn_y, handles)
        if bound is not None and y == "multiplier" and bounds:
            bound_lines.append(bound)
    if bound_lines and drawn_y:
        _draw_bounds(ax, bound_lines, x, missing, drawn_y, handles)
    _convergence_axes(ax, x, y, drawn_y)
    if legend and handles:
        ax.legend(handles=handles, loc="best", frameon=False, fontsize=7)
    ax.convergence_missing = missing
    ax.convergence_handles = handles
    return ax


def _draw_trace(ax, label: str, value: Any, x: str, y: str, methods: dict, missing: list, drawn_y: list,
                handles: list):
    """One method's trace (or its answer alone, without one); ``(label, colour, bound points)`` when the trace
    records a bound, else None (nothing drawn: ``missing`` says why)."""
    from matplotlib.lines import Line2D

    tr = _trace_of(value)
    colour, marker = method_style(label, methods.get(label) or getattr(value, "method", None))
    kw = dict(marker=marker, ms=3.5, lw=1.0, color=colour)
    if x == "lp_step" and not any("lp_iterations" in r for r in tr):
        missing.append((label, "its iterations are not LP steps" if tr else "no trace"))
        return None
    if y == "n_change" and not any("n_change" in r for r in tr):
        missing.append((label, "does not measure n_change" if tr else "no trace"))
        return None
    xs = np.array([_num(r.get("time_s")) if x == "time" else _num(r.get("iteration")) for r in tr])
    if y == "multiplier":
        ys = np.array([_num(r.get("incumbent", r.get("multiplier"))) for r in tr])
    else:
        ys = np.array([max(_num(r.get("n_change")), FLOOR) if _finite(r.get("n_change")) else math.nan
                       for r in tr])
    ok = np.isfinite(xs) & np.isfinite(ys)
    if x == "time":
        xs = np.maximum(xs, 1e-4)
    if ok.any():
        ax.plot(xs[ok], ys[ok], **kw)
        drawn_y += list(ys[ok])
        handles.append(Line2D([], [], label=label, **kw))
    elif y == "multiplier" and x == "time" and _finite(getattr(value, "multiplier", None)) \
            and _finite(getattr(value, "solve_time_s", None)):
        t, lam = max(float(value.solve_time_s), 1e-4), float(value.multiplier)
        ax.plot([t], [lam], ls="", marker=marker, ms=6, color=colour)
        drawn_y.append(lam)
        handles.append(Line2D([], [], ls="", marker=marker, ms=6, color=colour, label=f"{label} (no trace: answer)"))
    else:
        missing.append((label, "no trace"))
        return None
    pts = [(_num(r.get("time_s")) if x == "time" else _num(r.get("iteration")),
            _num(r.get("bound", r.get("dual_bound")))) for r in tr]
    pts = [(a, b) for a, b in pts if math.isfinite(a) and math.isfinite(b)]
    return (label, colour, np.array(pts)) if pts else None


def _draw_bounds(ax, bound_lines: list, x: str, missing: list, drawn_y: list, handles: list) -> None:
    """The lower bounds of the traces that record one, as dashed steps (those far below every answer left out)."""
    from matplotlib.lines import Line2D

    lam_min = min(drawn_y)
    floor = lam_min - 0.5 * max(abs(lam_min), 1e-12)
    for label, colour, pts in bound_lines:
        keep = pts[:, 1] >= floor
        if not keep.any():
            missing.append((f"{label}'s lower bound", f"stayed below {floor:.4g}, far below the answers"))
            continue
        bx = np.maximum(pts[keep, 0], 1e-4) if x == "time" else pts[keep, 0]
        bkw = dict(ls="--", lw=1.0, color=colour, marker="o", ms=4, mfc="white", mec=colour)
        ax.plot(bx, pts[keep, 1], drawstyle="steps-post", zorder=3, **bkw)  # markers: seen on the incumbent too
        drawn_y += list(pts[keep, 1])
        handles.append(Line2D([], [], label=f"{label}: lower bound", **bkw))


def _convergence_axes(ax, x: str, y: str, drawn_y: list) -> None:
    """Scales, limits, ticks, labels and grid of a convergence plot."""
    label_y, log_y = CONVERGENCE_MEASURES[y]
    if x == "time":
        ax.set_xscale("log")
        _log_ticks(ax.xaxis, [v for line in ax.lines for v in np.asarray(line.get_xdata(), float)])
    if log_y:
        ax.set_yscale("log")
    if drawn_y:
        lo, hi = min(drawn_y), max(drawn_y)
        if log_y:
            ax.set_ylim(lo / 3.0, hi * 3.0)
        else:
            mid, span = 0.5 * (lo + hi), hi - lo
            pad = max(0.06 * span, 5e-4 * max(abs(mid), 1e-12))  # flat traces: 5 significant digits, not noise
            ax.set_ylim(lo - pad, hi + pad)
            ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    else:
        ax.text(0.5, 0.5, "nothing to draw", transform=ax.transAxes, ha="center")
    if x == "lp_step":
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(CONVERGENCE_AXES[x])
    ax.set_ylabel(label_y)
    ax.grid(True, alpha=0.3)


def _log_ticks(axis, values) -> None:
    """Readable labels on a log axis: minor labels 2 and 5 (as plain numbers) when the data span about a decade
    or less, none otherwise (matplotlib's own crowd each other on a narrow range)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    values = [v for v in values if math.isfinite(v) and v > 0]
    if values and max(values) / min(values) < 15.0:
        axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
        axis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    else:
        axis.set_minor_formatter(NullFormatter())


# --------------------------------------------------------------------------- multiplier map


class MapResult(NamedTuple):
    """What :func:`multiplier_map` returns: the table of the grid and the axes drawn (``ax.figure`` the figure)."""

    data: Any
    ax: Any

    @property
    def fig(self):
        """The figure of the drawing."""
        return self.ax.figure


def _mechanism_key(state) -> tuple:
    """The joints' states of a mechanism as a hashable key (same key: same mechanism)."""
    return tuple((s if s != "hinge" else f"hinge-{h}") for s, h in zip(state["state"], state["hinge"]))


def _mechanism_name(key: tuple) -> str:
    """A short description of a mechanism key, e.g. ``slide 0,1; hinge 2(end)``."""
    parts = {"sliding": [], "hinge": [], "opening": []}
    for k, s in enumerate(key):
        if s == "sliding":
            parts["sliding"].append(str(k))
        elif s.startswith("hinge"):
            parts["hinge"].append(f"{k}({s.split('-', 1)[1]})")
        elif s == "opening":
            parts["opening"].append(str(k))
    text = "; ".join(f"{name} {','.join(v)}" for name, v in (("slide", parts["sliding"]), ("hinge", parts["hinge"]),
                                                              ("open", parts["opening"])) if v)
    return text or "no relative motion"


def multiplier_map(case: str | Callable[..., Any], x: tuple[str, Sequence[float]], y: tuple[str, Sequence[float]], *,
                   method: str = "static-lp", params: Mapping[str, Any] | None = None,
                   options: Mapping[str, Any] | None = None, show: str = "multiplier", ax=None,
                   colorbar: bool = True, levels: int | Sequence[float] = 8, tol: float = 1e-6,
                   progress: Callable[[int, int], None] | None = None) -> MapResult:
    r"""The collapse multiplier over a grid of two parameters, drawn as a map (the seed paper's Figs 5-6).

    One :func:`blockmpec.solve` per grid point.

    Parameters
    ----------
    case : str or callable
        A built-in case name (:data:`blockmpec.cases.CASES`), or a function returning a
        :class:`~blockmpec.Structure` from keyword parameters (called as ``case(**params, x_name=xv,
        y_name=yv)``).
    x, y : (str, sequence of float)
        The parameter on each axis and its values, e.g. ``("eta", np.linspace(1, 6, 21))``.
    method : str
        The method solving each point (``"static-lp"``: associative; ``"milp"``: the certified minimum
        of the non-associative problem; ``"fixed-point"``: a non-associative solution ...).
    params : mapping, optional
        The case's other parameters.
    options : mapping, optional
        The method's options (e.g. ``{"time_limit": 30}``).
    show : {"multiplier", "mechanism"}
        Colour by ``lam`` with contour lines (Fig. 6 style), or by mechanism (Fig. 5 style: regions of the
        same mechanism, :func:`joints`, each in its own colour, named in the legend).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    colorbar : bool
        Add a colour bar of ``lam`` (``show="multiplier"``).
    levels : int or sequence
        Contour levels of ``lam``.
    tol : float
        Threshold of :func:`joints` for the mechanism classes.
    progress : callable, optional
        Called as ``progress(done, total)`` after each point.

    Returns
    -------
    MapResult
        ``(data, ax)``: ``data`` a DataFrame with one row per grid point, columns ``<x>, <y>, multiplier``
        (NaN unless the solve succeeded), ``status, success, verified, mechanism`` (an integer class, -1
        without a mechanism) and ``mechanism_name``; ``ax`` the axes drawn (``.fig`` the figure).

    Examples
    --------
    The two-block problem over slenderness and friction (the seed paper's Sect. 3), associative:

    >>> import numpy as np
    >>> data, ax = bm.plot.multiplier_map("two-blocks", x=("eta", np.linspace(1, 6, 11)),
    ...                                   y=("mu", np.linspace(0.2, 1.0, 9)), method="static-lp")  # doctest: +SKIP
    """
    import pandas as pd

    import blockmpec as bm

    if show not in ("multiplier", "mechanism"):
        raise ValueError(f"show must be 'multiplier' or 'mechanism'; got {show!r}")
    (x_name, x_values), (y_name, y_values) = x, y
    x_values, y_values = np.asarray(x_values, float), np.asarray(y_values, float)
    if x_values.ndim != 1 or y_values.ndim != 1 or not x_values.size or not y_values.size:
        raise ValueError("x and y must each be (name, a non-empty sequence of values)")
    params = dict(params or {})
    options = dict(options or {})
    bm.get_solver(method)(**options)  # a bad method or option fails now, not at every point
    build = (lambda **p: bm.build_case(case, **p)) if isinstance(case, str) else case
    rows, keys = [], {}
    total, done = x_values.size * y_values.size, 0
    for yv in y_values:
        for xv in x_values:
            structure = build(**{**params, x_name: float(xv), y_name: float(yv)})
            res = bm.solve(structure, method, **options)
            ok = bool(res.success) and _finite(res.multiplier)
            mech, name = -1, ""
            if ok and res.solution is not None and res.solution.u is not None:
                key = _mechanism_key(joints(res, structure, tol=tol))
                mech = keys.setdefault(key, len(keys))
                name = _mechanism_name(key)
            rows.append({x_name: float(xv), y_name: float(yv), "multiplier": float(res.multiplier) if ok else math.nan,
                         "status": res.status.value, "success": bool(res.success), "verified": bool(res.verified),
                         "mechanism": mech, "mechanism_name": name})
            done += 1
            if progress is not None:
                progress(done, total)
    data = pd.DataFrame(rows)
    ax = _axes(ax)
    shape = (y_values.size, x_values.size)
    lam = data["multiplier"].to_numpy().reshape(shape)
    X, Y = np.meshgrid(x_values, y_values)
    if show == "multiplier":
        mesh = ax.pcolormesh(X, Y, lam, shading="nearest", cmap="viridis")
        if np.isfinite(lam).sum() >= 4 and min(shape) >= 2:
            cs = ax.contour(X, Y, np.ma.masked_invalid(lam), levels=levels, colors="white", linewidths=0.7)
            ax.clabel(cs, fontsize=7, fmt="%.3g")
        if colorbar:
            ax.figure.colorbar(mesh, ax=ax, label=rf"collapse multiplier $\lambda$ ({method})")
    else:
        from matplotlib.colors import BoundaryNorm, ListedColormap
        from matplotlib.patches import Patch

        ids = data["mechanism"].to_numpy().reshape(shape).astype(float)
        ids[ids < 0] = np.nan
        n = max(len(keys), 1)
        palette = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c",
                   "#ccb974", "#64b5cd"]
        colours = [palette[i % len(palette)] for i in range(n)]
        ax.pcolormesh(X, Y, ids, shading="nearest", cmap=ListedColormap(colours),
                      norm=BoundaryNorm(np.arange(n + 1) - 0.5, n))
        names = {v: _mechanism_name(k) for k, v in keys.items()}
        handles = [Patch(color=colours[i], label=f"{chr(65 + i) if i < 26 else i}: {names[i]}") for i in range(len(keys))]
        if np.isnan(ids).any():
            handles.append(Patch(facecolor="white", edgecolor="0.5", label="no mechanism (no success)"))
        if handles:
            ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False, fontsize=7,
                      title="mechanism (interfaces)", title_fontsize=7)
    ax.set_xlabel(x_name)
    ax.set_ylabel(y_name)
    ax.set_title(f"{case if isinstance(case, str) else getattr(case, '__name__', 'case')}: "
                 f"{'collapse multiplier' if show == 'multiplier' else 'collapse mechanism'} ({method})")
    return MapResult(data, ax)
