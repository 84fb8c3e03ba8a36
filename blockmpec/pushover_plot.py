"""Figures of capacity curves (:func:`blockmpec.pushover.pushover`): the curve, the blocks, an animation.

Every function takes an optional matplotlib ``ax`` (a new figure when None) and returns the
matplotlib object it drew; matplotlib is imported inside the functions (the ``Agg`` backend when
none is chosen yet), so importing this module costs nothing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path as _FilePath
from typing import Any

import numpy as np

from blockmpec.errors import OptionError
from blockmpec.geometry import Structure
from blockmpec.plot import METHOD_STYLES  # one colour and marker per method, as in every other figure

_OTHER_COLOURS = ("#e377c2", "#7f7f7f", "#bcbd22", "#393b79", "#637939", "#8c6d31")

#: The x axes a capacity curve can be drawn against: column -> axis label (``{unit}``: the length unit).
X_AXES = {
    "displacement": "control-point displacement along the live load [{unit}]",
    "rotation": "control-block rotation [rad]",
}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _curves(curves: Any) -> list[tuple[str, Any]]:
    """``(label, frame)`` pairs from one frame, a mapping label -> frame or a sequence of frames."""
    import pandas as pd

    if isinstance(curves, pd.DataFrame):
        items = [(None, curves)]
    elif isinstance(curves, Mapping):
        items = list(curves.items())
    elif isinstance(curves, Sequence) and not isinstance(curves, str):
        items = [(None, c) for c in curves]
    else:
        raise OptionError(f"curves: expected a DataFrame from pushover, a list or a dict of them; got "
                          f"{type(curves).__name__}")
    out = []
    for label, frame in items:
        if not isinstance(frame, pd.DataFrame) or not {"displacement", "multiplier"} <= set(frame.columns):
            raise OptionError(f"curves: {label or 'an item'} is not a curve from pushover (no displacement and "
                              "multiplier columns)")
        out.append((label or str(frame.attrs.get("method", f"curve {len(out) + 1}")), frame))
    return out


def _style(label: str, k: int) -> tuple[str, str]:
    name = next((m for m in sorted(METHOD_STYLES, key=len, reverse=True) if label.startswith(m)), None)
    return METHOD_STYLES[name] if name else (_OTHER_COLOURS[k % len(_OTHER_COLOURS)], "o")


def plot_capacity_curve(curves: Any, ax=None, *, x: str = "displacement", length_unit: str = "length unit",
                        title: str | None = None):
    """The load multiplier against the control point's displacement (or the control block's rotation).

    Parameters
    ----------
    curves : DataFrame, list of DataFrames, or dict label -> DataFrame
        Curves from :func:`blockmpec.pushover.pushover`; each is labelled by its dict key, else by
        its method (``attrs["method"]``).  Rows where no multiplier holds the configuration (a
        snap, a failure) break the line; a curve that reaches ``lam = 0`` ends with a cross at the
        interpolated ultimate displacement.
    ax : matplotlib Axes, optional
    x : {"displacement", "rotation"}
    length_unit : str
        The structure's length unit, for the axis label (the structures carry none).
    title : str, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    if x not in X_AXES:
        raise OptionError(f"x: must be one of {', '.join(X_AXES)}; got {x!r}")
    items = _curves(curves)
    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.0), layout="constrained")
    for k, (label, frame) in enumerate(items):
        colour, marker = _style(label, k)
        xs = frame[x].to_numpy(float)
        lam = frame["multiplier"].to_numpy(float)
        ax.plot(xs, lam, color=colour, marker=marker, markersize=3.5, linewidth=1.4, label=label)
        ultimate = frame.attrs.get("ultimate_displacement")
        if x == "displacement" and ultimate is not None:
            ax.plot([ultimate], [0.0], color=colour, marker="x", markersize=8, linestyle="none")
    ax.axhline(0.0, color="0.6", linewidth=0.8)
    ax.set_xlabel(X_AXES[x].format(unit=length_unit))
    ax.set_ylabel("load multiplier λ [–] (live load / weight)")
    if title:
        ax.set_title(title)
    ax.legend(title="method")
    ax.grid(True, linewidth=0.4, alpha=0.5)
    return ax


def draw_configuration(structure: Structure, curve, row: int = -1, ax=None, *, control: bool = True):
    """The blocks at one row of a curve (fixed blocks grey), with the control point.

    Returns
    -------
    matplotlib.collections.PatchCollection
    """
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Polygon

    from blockmpec.pushover import block_polygons

    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.5), layout="constrained")
    row = row % len(curve)
    patches = [Polygon(p, closed=True) for p in block_polygons(structure, curve, row)]
    colours = np.where(structure.fixed, "0.75", "#f4d9a6")
    collection = PatchCollection(patches, facecolor=list(colours), edgecolor="0.25", linewidth=0.6)
    ax.add_collection(collection)
    if control and np.isfinite(curve["control_x"].iloc[row]):
        ax.plot([curve["control_x"].iloc[row]], [curve["control_y"].iloc[row]], "o", color="#d62728", markersize=4)
    v = structure.vertices.reshape(-1, 2)
    pad = 0.05 * float(np.ptp(v, axis=0).max())
    ax.set_xlim(v[:, 0].min() - pad, v[:, 0].max() + pad)
    ax.set_ylim(v[:, 1].min() - pad, v[:, 1].max() + pad)
    ax.set_aspect("equal")
    return collection


def _frame_title(curve, row: int) -> str:
    r = curve.iloc[row]
    lam = r["multiplier"]
    lam_text = f"λ = {lam:.4g}" if np.isfinite(lam) else f"no λ ({r['status']})"
    return f"{curve.attrs.get('method', '')}  step {int(r['step'])}: displacement {r['displacement']:.4g}, {lam_text}"


def animate_pushover(structure: Structure, curve, ax=None, *, interval: float = 200.0):
    """An animation of the blocks through the rows of a curve.

    Save it with :func:`save_animation` (GIF through Pillow, MP4 through ffmpeg).

    Returns
    -------
    matplotlib.animation.FuncAnimation
    """
    from matplotlib.animation import FuncAnimation
    from matplotlib.patches import Polygon

    from blockmpec.pushover import block_polygons

    plt = _pyplot()
    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.5), layout="constrained")
    collection = draw_configuration(structure, curve, 0, ax, control=False)
    (marker,) = ax.plot([], [], "o", color="#d62728", markersize=4)
    title = ax.set_title(_frame_title(curve, 0), fontsize=9)

    def update(row: int):
        collection.set_paths([Polygon(p, closed=True) for p in block_polygons(structure, curve, row)])
        marker.set_data([curve["control_x"].iloc[row]], [curve["control_y"].iloc[row]])
        title.set_text(_frame_title(curve, row))
        return collection, marker, title

    return FuncAnimation(ax.figure, update, frames=len(curve), interval=interval, blit=False)


def save_animation(animation, path: str | _FilePath, fps: float = 5.0) -> _FilePath:
    """Write an animation as ``.gif`` (matplotlib's PillowWriter) or ``.mp4`` (FFMpegWriter, needs ffmpeg)."""
    from matplotlib import animation as mpl_animation

    path = _FilePath(path)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        writer = mpl_animation.PillowWriter(fps=fps)
    elif suffix == ".mp4":
        if not mpl_animation.writers.is_available("ffmpeg"):
            raise OptionError(f"{path}: an MP4 animation needs ffmpeg, which is not installed; write a .gif instead")
        writer = mpl_animation.FFMpegWriter(fps=fps)
    else:
        raise OptionError(f"{path}: an animation is written as .gif or .mp4; got {suffix or 'no suffix'}")
    if not path.parent.is_dir():
        raise OptionError(f"{path}: folder {path.parent} does not exist")
    animation.save(str(path), writer=writer)
    return path
