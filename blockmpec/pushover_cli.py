"""``blockmpec pushover``: the command line of :func:`blockmpec.pushover` (curves as CSV, the capacity-curve figure and
an optional animation); :mod:`blockmpec.cli` registers it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from blockmpec.contacts import CONTACT_LENGTH, CONTACT_TOLERANCE
from blockmpec.errors import OptionError
from blockmpec.pushover import pushover


def add_parser(sub, command) -> None:
    """Add ``blockmpec pushover`` to the CLI's subparsers (:mod:`blockmpec.cli`), run by ``command(args)``."""
    p = sub.add_parser("pushover", help="capacity curve: the load multiplier as the structure moves along its "
                       "mechanism (incremental limit analysis)")
    p.add_argument("case", help="built-in case name, structure file (.json) or drawing (.dxf, .svg, an image)")
    p.add_argument("--method", "-m", default="static-lp",
                   help="method, or comma-separated methods for one figure (default static-lp; fixed-point for "
                        "the non-associative problem)")
    p.add_argument("--control", metavar="BLOCK|X,Y", default=None,
                   help="control point: a free block's index (its centroid) or a point X,Y of a free block "
                        "(default: the centroid of the free block that moves fastest along the live load)")
    p.add_argument("--max-displacement", type=float, default=None, metavar="D",
                   help="control-point displacement at which the curve stops, in the structure's length unit "
                        "(default: half the median shorter side of the free blocks)")
    p.add_argument("--steps", type=int, default=20, help="equal displacement steps up to D (default 20)")
    p.add_argument("-p", "--param", action="append", metavar="KEY=VALUE", help="case parameter")
    p.add_argument("-O", "--option", action="append", metavar="[METHOD.]KEY=VALUE",
                   help="method option (for every method, or METHOD.KEY for one)")
    p.add_argument("--contact-tolerance", type=float, default=CONTACT_TOLERANCE,
                   help=f"blocks closer than this (relative to the smaller block) touch (default {CONTACT_TOLERANCE:g})")
    p.add_argument("--contact-length", type=float, default=CONTACT_LENGTH,
                   help=f"length of a point contact's interface, relative (default {CONTACT_LENGTH:g})")
    p.add_argument("--out", default="blockmpec-pushover", metavar="DIR",
                   help="output folder for pushover.csv and capacity_curve.png (default ./blockmpec-pushover)")
    p.add_argument("-o", "--output", metavar="FILE.csv", default=None, help="the curve's CSV (default DIR/pushover.csv)")
    p.add_argument("--figure", metavar="FILE.png", default=None,
                   help="the capacity-curve figure (default DIR/capacity_curve.png; .png, .pdf or .svg)")
    p.add_argument("--no-figure", action="store_true", help="write the CSV only")
    p.add_argument("--animation", metavar="FILE.gif", default=None,
                   help="also write an animation of the blocks (.gif, or .mp4 with ffmpeg); one per method, "
                        "FILE-METHOD.gif, when several")
    p.add_argument("--length-unit", default="length unit", help="the structure's length unit, for the axis label")
    p.add_argument("--verify-tol", default=1e-6, help="largest residual accepted as success (finite, > 0)")
    p.set_defaults(func=command)


def _parse_control(text: str | None):
    if text is None:
        return None
    parts = [t.strip() for t in text.split(",")]
    try:
        if len(parts) == 1:
            return int(parts[0])
        if len(parts) == 2:
            return (float(parts[0]), float(parts[1]))
    except ValueError:
        pass
    raise OptionError(f"--control {text}: expected a block index (3) or a point X,Y (0.5,1.2)")


def _method_options(methods: list[str], pairs: dict[str, Any]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {m: {} for m in methods}
    for key, value in pairs.items():
        method, dot, name = key.partition(".")
        if dot and method in out:
            out[method][name] = value
        elif dot:
            raise OptionError(f"-O {key}={value}: no method {method!r} in this run ({', '.join(methods)})")
        else:
            for m in methods:
                out[m][key] = value
    return out


def _output_path(text: str, default_dir: Path, suffixes: tuple[str, ...], flag: str) -> Path:
    path = Path(text) if text is not None else default_dir
    if path.suffix.lower() not in suffixes:
        raise OptionError(f"{flag} {path}: expected a file ending in {' or '.join(suffixes)}")
    if path.is_dir():
        raise OptionError(f"{flag} {path}: is a folder; give a file name")
    return path


def run_command(args, load, option_pairs: dict[str, Any], verify_tol: float) -> int:
    """``blockmpec pushover``: curves, CSV, figure and animation.

    ``load()`` builds the structure (after every option is checked), ``option_pairs`` are the parsed
    ``-O`` pairs and ``verify_tol`` the checked ``--verify-tol`` (:mod:`blockmpec.cli` parses them).
    Returns 0 when every curve's undeformed structure was solved, whatever ended the curve, else 1;
    bad input raises (exit 2)."""
    import pandas as pd

    from blockmpec.registry import get_solver

    methods = [m.strip() for m in args.method.split(",") if m.strip()]
    if not methods:
        raise OptionError("--method: give at least one method")
    options = _method_options(methods, option_pairs)
    for m in methods:
        get_solver(m)(**options[m])
    control = _parse_control(args.control)
    out_dir = Path(args.out)
    csv_path = _output_path(args.output, out_dir / "pushover.csv", (".csv",), "-o")
    figure_path = None if args.no_figure else _output_path(args.figure, out_dir / "capacity_curve.png",
                                                           (".png", ".pdf", ".svg"), "--figure")
    animation_path = None if args.animation is None else _output_path(args.animation, out_dir, (".gif", ".mp4"),
                                                                      "--animation")
    if animation_path is not None and animation_path.suffix.lower() == ".mp4":
        from matplotlib import animation as mpl_animation

        if not mpl_animation.writers.is_available("ffmpeg"):
            raise OptionError(f"--animation {animation_path}: an MP4 needs ffmpeg, which is not installed; "
                              "write a .gif instead")
    structure = load()
    # every input is checked (pushover raises on a bad control or step) before any file is written
    curves = {}
    for m in methods:
        curves[m] = pushover(structure, m, control=control, max_displacement=args.max_displacement,
                             steps=args.steps, contact_tolerance=args.contact_tolerance,
                             contact_length=args.contact_length, verify_tol=verify_tol, options=options[m])
        _print_curve(args.case, m, curves[m])
    for path in [csv_path, figure_path, animation_path]:
        if path is not None:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OptionError(f"{path}: cannot create folder {path.parent} ({exc.strerror or exc})") from None
    table = pd.concat([c.assign(method=m)[["method", *c.columns]] for m, c in curves.items()], ignore_index=True)
    table.to_csv(csv_path, index=False)
    written = [csv_path]
    if figure_path is not None:
        from blockmpec.pushover_plot import plot_capacity_curve

        ax = plot_capacity_curve(curves, length_unit=args.length_unit, title=f"{args.case}: capacity curve")
        ax.figure.savefig(figure_path, dpi=150)
        written.append(figure_path)
    if animation_path is not None:
        from blockmpec.pushover_plot import animate_pushover, save_animation

        for m, curve in curves.items():
            path = animation_path if len(curves) == 1 else animation_path.with_name(
                f"{animation_path.stem}-{m}{animation_path.suffix}")
            written.append(save_animation(animate_pushover(structure, curve), path))
    print("wrote " + ", ".join(str(p) for p in written))
    return 0 if all(c["status"].iloc[0] in _SOLVED and np.isfinite(c["multiplier"].iloc[0]) for c in curves.values()) else 1


_SOLVED = {"optimal", "locally_optimal", "converged", "acceptable"}


def _print_curve(case: str, method: str, curve) -> None:
    a = curve.attrs
    print(f"{case}: method={method} rows={len(curve)} control=block {a['control_block']} "
          f"step={a['step_size']:.4g} stop: {a['stop_reason']}")
    shown = curve[["step", "displacement", "rotation", "multiplier", "status", "event"]]
    print(shown.to_string(index=False, float_format=lambda v: f"{v + 0.0:.6g}"))  # + 0.0: no -0
    if a.get("ultimate_displacement") is not None:
        print(f"  lambda reaches 0 at displacement {a['ultimate_displacement']:.6g}")
