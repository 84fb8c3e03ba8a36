"""Irregular stone walls at scale (issue 42): the LPs and the fixed point on ``stone-wall`` beside regular walls.

For each structure (``stone-wall`` of about ``--stones`` stones, ``--irregularity``, a 2:1 wall of stones of
mean size ``--stone-size``; and the running-bond walls of ``--walls`` for comparison), in this process, one
after the other:

* ``static-lp`` and ``kinematic-lp``: solve time (set-up apart), lam, and their relative difference (issue 42:
  both exact and agreeing to 1e-8);
* ``fixed-point``: solve time, iterations, status, lam, whether it is verified and whether lam <= the
  associative lam (times 1 + 1e-9);
* the ratio of the fixed point's solve time to the static LP's (FP/LP).

With ``--certificate`` (default when ``--stones`` is at most 300) also ``milp`` (``--milp-time-limit``) and
``nlp`` on the stone wall: the certified minimum and the best verified of ``nlp``/``fixed-point``, and
whether they lie within 2 % of each other; when the time limit stops ``milp`` first, its certified lower
bound on the minimum takes the minimum's place (the best heuristic within 2 % above it is then within
2 % of the minimum too).

Usage::

    python studies/lab/stone_wall_scale.py                     # ~200 stones, the 10x20 wall, certificate
    python studies/lab/stone_wall_scale.py --stones 2000 --walls 40x50 --no-certificate
    python studies/lab/stone_wall_scale.py --stones 1000 --seeds 0,1,2 --walls= --no-kinematic --no-certificate

Prints a markdown table and writes ``studies/output/stone_wall_scale/scale_<stones>.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import blockmpec as bm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, peak_memory_mb, write_csv  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "stone_wall_scale"


def stone_wall_of(stones: int, irregularity: float, stone_size: float, seed: int, mu: float) -> bm.Structure:
    """A 2:1 ``stone-wall`` of about ``stones`` stones of mean size ``stone_size``."""
    height = stone_size * math.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2.0 * height, height=height, stone_size=stone_size,
                               irregularity=irregularity, seed=seed, mu=mu)


def measure(label: str, structure: bm.Structure, time_limit: float, certificate: bool,
            milp_time_limit: float, kinematic: bool = True) -> dict:
    """One row: the LPs (the kinematic one if ``kinematic``), the fixed point and (``certificate``) milp and nlp on
    ``structure``."""
    row: dict = {"structure": label, "blocks": structure.n_blocks - int(structure.fixed.sum()),
                 "non_convex": structure.metadata.get("non_convex_stones", 0), "interfaces": len(structure.interfaces)}
    t0 = time.perf_counter()
    bm.assemble(structure)
    row["assemble_s"] = time.perf_counter() - t0
    static = bm.solve(structure, "static-lp", time_limit=time_limit)
    fp = bm.solve(structure, "fixed-point", time_limit=time_limit)
    row.update(static_status=static.status.value, static_lam=static.multiplier, static_s=static.solve_time_s,
               static_setup_s=static.build_time_s, fp_status=fp.status.value, fp_verified=fp.success,
               fp_lam=fp.multiplier, fp_s=fp.solve_time_s, fp_iterations=fp.iterations,
               fp_sequence_lps=fp.extra.get("sequence_lps", 0))
    kin = bm.solve(structure, "kinematic-lp", time_limit=time_limit) if kinematic else None
    if kin is not None:
        row.update(kinematic_status=kin.status.value, kinematic_lam=kin.multiplier, kinematic_s=kin.solve_time_s)
    if kin is not None and static.multiplier is not None and kin.multiplier is not None:
        row["lp_rel_diff"] = abs(static.multiplier - kin.multiplier) / max(1.0, abs(static.multiplier))
        row["lps_agree"] = static.success and kin.success and row["lp_rel_diff"] <= 1e-8
    if fp.multiplier is not None and static.multiplier is not None:
        row["fp_below_lp"] = fp.multiplier <= static.multiplier * (1 + 1e-9)
    if static.solve_time_s > 0:
        row["fp_over_lp"] = fp.solve_time_s / static.solve_time_s
    if certificate:
        milp = bm.solve(structure, "milp", time_limit=milp_time_limit)
        nlp = bm.solve(structure, "nlp", time_limit=time_limit)
        row.update(milp_status=milp.status.value, milp_lam=milp.multiplier, milp_s=milp.solve_time_s,
                   nlp_status=nlp.status.value, nlp_lam=nlp.multiplier, nlp_s=nlp.solve_time_s)
        verified = [r.multiplier for r in (nlp, fp) if r.success and r.multiplier is not None]
        row["best_heuristic_lam"] = min(verified) if verified else math.nan
        # the certified lower bound on the minimum (also when the time limit stopped the search)
        row["milp_bound"] = milp.extra.get(bm.facts.BOUND, math.nan) if milp.extra.get(bm.facts.SENSE) == "min" \
            else math.nan
        if milp.success and verified:
            row["heuristic_vs_certificate"] = row["best_heuristic_lam"] / milp.multiplier - 1
            row["within_2pct"] = abs(row["heuristic_vs_certificate"]) <= 0.02
        elif verified and math.isfinite(row["milp_bound"]) and row["milp_bound"] > 0:
            # no certificate: how far the best heuristic lies above the certified bound
            row["heuristic_vs_certificate"] = row["best_heuristic_lam"] / row["milp_bound"] - 1
            row["within_2pct"] = row["heuristic_vs_certificate"] <= 0.02
    row["peak_memory_mb"] = peak_memory_mb()
    return row


COLUMNS = [
    ("structure", "structure", "{}"), ("blocks", "free blocks", "{:d}"), ("non_convex", "non-convex", "{:d}"),
    ("interfaces", "interfaces", "{:d}"), ("static_lam", "static-lp λ", "{:.8g}"), ("static_s", "static-lp s", "{:.3g}"),
    ("kinematic_s", "kinematic-lp s", "{:.3g}"), ("lp_rel_diff", "\\|Δλ\\| LPs", "{:.1e}"),
    ("fp_lam", "fixed-point λ", "{:.8g}"), ("fp_status", "fixed-point status", "{}"),
    ("fp_verified", "verified", "{}"), ("fp_below_lp", "λ_FP ≤ λ_LP", "{}"), ("fp_iterations", "iterations", "{}"),
    ("fp_s", "fixed-point s", "{:.3g}"), ("fp_over_lp", "FP/LP", "{:.3g}"),
    ("fp_sequence_lps", "damped LP steps", "{}"),
]
CERTIFICATE_COLUMNS = [
    ("structure", "structure", "{}"), ("milp_status", "milp status", "{}"), ("milp_lam", "milp λ", "{:.8g}"),
    ("milp_s", "milp s", "{:.3g}"), ("nlp_status", "nlp status", "{}"), ("nlp_lam", "nlp λ", "{:.8g}"),
    ("milp_bound", "milp bound", "{:.8g}"), ("nlp_s", "nlp s", "{:.3g}"), ("fp_lam", "fixed-point λ", "{:.8g}"),
    ("heuristic_vs_certificate", "best heuristic / (milp λ or bound) - 1", "{:+.2%}"),
    ("within_2pct", "within 2 %", "{}"),
]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stones", type=int, default=200, help="about this many stones (default 200)")
    parser.add_argument("--irregularity", type=float, default=0.7)
    parser.add_argument("--stone-size", type=float, default=0.3, help="mean stone size (m)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--seeds", default=None, help="comma-separated seeds, one stone wall each (default: --seed)")
    parser.add_argument("--kinematic", action=argparse.BooleanOptionalAction, default=True,
                        help="also the kinematic LP (default: yes)")
    parser.add_argument("--mu", type=float, default=0.65)
    parser.add_argument("--walls", default="10x20", help="running-bond walls CxB to compare with (default 10x20)")
    parser.add_argument("--time-limit", type=float, default=600.0, help="seconds per LP / fixed-point / nlp solve")
    parser.add_argument("--certificate", action=argparse.BooleanOptionalAction, default=None,
                        help="also milp and nlp on the stone wall (default: when --stones <= 300)")
    parser.add_argument("--milp-time-limit", type=float, default=300.0)
    args = parser.parse_args(argv)
    certificate = args.stones <= 300 if args.certificate is None else args.certificate
    seeds = [args.seed] if args.seeds is None else [int(s) for s in args.seeds.split(",") if s.strip()]
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        wall = stone_wall_of(args.stones, args.irregularity, args.stone_size, seed, args.mu)
        generated = time.perf_counter() - t0
        label = f"stone-wall {wall.metadata['width']:.3g}x{wall.metadata['height']:.3g} r={args.irregularity:g}"
        if len(seeds) > 1 or seed != 0:
            label += f" seed {seed}"
        print(f"{label}: {wall.metadata['stones']} stones ({wall.metadata['non_convex_stones']} non-convex), "
              f"{len(wall.interfaces)} interfaces, generated and validated in {generated:.2f} s", flush=True)
        rows.append(measure(label, wall, args.time_limit, certificate, args.milp_time_limit, args.kinematic))
        rows[-1]["generate_s"] = generated
    stone_rows = len(rows)
    for spec in [w for w in args.walls.split(",") if w.strip()]:
        rows.append(measure(f"wall {spec}", named_wall(spec, mu=args.mu), args.time_limit, False, 0.0,
                            args.kinematic))
    print(markdown(rows, COLUMNS))
    if certificate:
        print()
        print(markdown(rows[:stone_rows], CERTIFICATE_COLUMNS))
    path = write_csv(OUT / f"scale_{args.stones}.csv", rows)
    print(f"\nwrote {path}")
    return rows


if __name__ == "__main__":
    main()
