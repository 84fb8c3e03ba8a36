"""The fixed point at scale (issue 49): two questions measured on stone walls and running-bond walls.

1. **Is the associative answer a solution of (3)?**  The associative forces ``x_a`` (static LP (1)) solve (3) exactly
   when they are optimal for the step LP (5) at their own normal forces ``n* = n_a``: any optimal duals of that
   LP are then a mechanism with the ``tan(psi)`` flow, complementary to ``x_a``.  The study solves the step LP at
   ``n_a`` and reports its multiplier against ``lam_a`` and the residual of (3) of ``x_a`` with its duals.

2. **The capped sequence.**  Each step LP carries both the caps (5), ``+-t_k + tan(psi_k) n_k <= -(tan(phi_k) -
   tan(psi_k)) n*_k``, and Coulomb's rows ``+-t_k + tan(phi_k) n_k <= 0``, from the dead-load forces (the LP (1)
   with ``lam = 0``, least total compression), ``n* <- n`` after each step.  Every iterate is statically
   admissible, so ``lam`` stays below the associative multiplier; its limit solves (3) with a flow rule that may
   take any dilatancy between ``psi`` and ``phi`` where both rows are active (the duals of the two rows add up).
   The study records ``lam``, ``||n - n*||/||n||`` and the interfaces whose Coulomb rows carry a multiplier, then
   (``--thetas``) replaces Coulomb's rows by rows of slope ``tan(psi) + theta (tan(phi) - tan(psi))`` through the
   Coulomb point at ``n*`` (``theta = 0``: the paper's step LP (5)), for ``--theta-steps`` steps each.

Every LP is solved by the block interior-point method (:class:`blockmpec.solvers.engines.block_lp.BlockLP`, in the
problem's load units); the shared verifier (:func:`blockmpec.residuals`) judges each point as a solution of (3).

Usage::

    python studies/lab/fixed_point_capped.py --stones 500,1000,2000 --walls 32x63 --steps 20
    python studies/lab/fixed_point_capped.py --stones 500 --walls= --steps 8 --thetas 0.8,0.6,0.4,0.2,0 --theta-steps 8

Prints a markdown table and writes ``studies/output/fixed_point_capped/capped.csv`` (one row per structure) and
``steps.csv`` (one row per LP).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import blockmpec as bm
from blockmpec.formulations import LinearProgram
from blockmpec.solvers.engines.block_lp import BlockLP
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.plan import BLOCK_IPM_RULES

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from _tables import markdown, write_csv  # noqa: E402
from _walls import named_wall  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "fixed_point_capped"


def stone_wall_of(stones: int, seed: int) -> bm.Structure:
    """A 2:1 ``stone-wall`` of about ``stones`` stones of size 0.3 m, irregularity 0.7."""
    height = 0.3 * math.sqrt(stones / 2.0)
    return bm.cases.stone_wall(width=2.0 * height, height=height, stone_size=0.3, irregularity=0.7, seed=seed)


class StaticLPs:
    """Static-type LPs over ``(lam, x)``: equilibrium plus groups of per-interface rows ``M x <= rhs``."""

    def __init__(self, ops) -> None:
        self.ops = ops
        self.c = ops.n_interfaces
        self.units = LoadUnits.of(ops)
        self.unilateral = sp.csr_array(ops.N_u.T)
        self.coulomb = sp.csr_array(ops.N_f.T)
        self.gap = np.asarray(ops.friction - ops.dilatancy, float)

    def rows_of_slope(self, slope: np.ndarray) -> sp.csr_array:
        """``+-t_k + slope_k n_k`` (two rows per interface)."""
        return sp.csr_array(self.ops.friction_operator(slope).T)

    def solve(self, groups: list[tuple[str, sp.csr_array, np.ndarray]], lam_cost: float = -1.0,
              n_cost: float = 0.0, lam_fixed: float | None = None) -> dict:
        """``min lam_cost lam + n_cost sum n`` s.t. equilibrium (and ``lam = lam_fixed``) and ``M x <= rhs`` of each
        group; returns ``lam, x, u`` and each group's multipliers ``z = -y``, with the solve's status and seconds."""
        ops, c = self.ops, self.c
        b3 = ops.E.shape[0]
        blocks = [sp.hstack([sp.csr_array(ops.f_l.reshape(-1, 1)), ops.E])]
        lower, upper = [-ops.f_d], [-ops.f_d]
        rows = {"equilibrium": np.arange(b3)}
        start = b3
        if lam_fixed is not None:
            blocks.append(sp.csr_array(([1.0], ([0], [0])), shape=(1, 3 * c + 1)))
            lower.append(np.array([lam_fixed]))
            upper.append(np.array([lam_fixed]))
            start += 1
        for name, matrix, rhs in groups:
            blocks.append(sp.hstack([sp.csr_array((matrix.shape[0], 1)), matrix]))
            lower.append(np.full(matrix.shape[0], -np.inf))
            upper.append(np.asarray(rhs, float))
            rows[name] = np.arange(start, start + matrix.shape[0])
            start += matrix.shape[0]
        cost = np.zeros(3 * c + 1)
        cost[0] = lam_cost
        cost[2::3] = n_cost  # the normal forces' columns
        lp = LinearProgram(c=cost, A=sp.csr_array(sp.vstack(blocks).tocsr()), row_lower=np.concatenate(lower),
                           row_upper=np.concatenate(upper), col_lower=np.full(3 * c + 1, -np.inf),
                           col_upper=np.full(3 * c + 1, np.inf),
                           columns={"lam": np.array([0]), "x": np.arange(1, 3 * c + 1)}, rows=rows, objective_sign=1.0)
        row_scale, column_scale = self.units.static(lp)
        t0 = time.perf_counter()
        out = BlockLP(lp, lp.columns["x"].reshape(-1, 3), row_scale=row_scale, column_scale=column_scale,
                      rules=BLOCK_IPM_RULES).solve()
        seconds = time.perf_counter() - t0
        y = out.row_dual
        return {"status": out.status.value, "lam": float(out.v[0]), "x": out.v[1:], "u": -y[rows["equilibrium"]],
                "z": {name: -y[rows[name]] for name, _, _ in groups}, "seconds": seconds}

    def worst_residual(self, lam: float, x: np.ndarray, u: np.ndarray, z_u: np.ndarray, z_f: np.ndarray) -> float:
        """The largest residual of (3) (the shared verifier) of a point."""
        sol = bm.Solution(multiplier=lam, x=x, u=u, z_u=z_u, z_f=z_f)
        return max(bm.residuals(self.ops, sol, associative=False).values())


def associative_check(lps: StaticLPs) -> dict:
    """The static LP (1), then the step LP (5) at its normal forces (question 1 of the module docstring)."""
    zeros = np.zeros(2 * lps.c)
    assoc = lps.solve([("unilateral", lps.unilateral, zeros), ("coulomb", lps.coulomb, zeros)])
    n_a = np.minimum(assoc["x"][1::3], 0.0)
    caps = -np.repeat(lps.gap * n_a, 2)
    step = lps.solve([("unilateral", lps.unilateral, zeros),
                      ("caps", lps.rows_of_slope(lps.ops.dilatancy), caps)])
    residual = lps.worst_residual(assoc["lam"], assoc["x"], step["u"], step["z"]["unilateral"], step["z"]["caps"])
    return {"lp_lam": assoc["lam"], "lp_s": assoc["seconds"], "step_at_assoc_lam": step["lam"],
            "step_over_lp": step["lam"] / assoc["lam"] - 1, "assoc_residual_3": residual,
            "assoc_solves_3": residual <= 1e-6}


def capped_sequence(lps: StaticLPs, steps: int, thetas: list[float], theta_steps: int, label: str,
                    trace: list[dict]) -> dict:
    """The capped sequence from the dead-load forces, then the theta stages (module docstring, question 2)."""
    c, zeros = lps.c, np.zeros(2 * lps.c)
    dead = lps.solve([("unilateral", lps.unilateral, zeros), ("coulomb", lps.coulomb, zeros)], lam_cost=0.0,
                     n_cost=-1.0, lam_fixed=0.0)
    n_star = np.minimum(dead["x"][1::3], 0.0)
    caps_rows = lps.rows_of_slope(lps.ops.dilatancy)
    row: dict = {"dead_load_s": dead["seconds"]}
    lam_before = -np.inf
    stages = [(1.0, steps)] + [(theta, theta_steps) for theta in thetas]
    for stage, (theta, count) in enumerate(stages):
        slope = lps.ops.dilatancy + theta * lps.gap
        second = lps.rows_of_slope(slope)
        for k in range(1, count + 1):
            out = lps.solve([("unilateral", lps.unilateral, zeros), ("caps", caps_rows, -np.repeat(lps.gap * n_star, 2)),
                             ("second", second, -np.repeat((lps.ops.friction - slope) * n_star, 2))])
            n = out["x"][1::3]
            z_caps, z_second = out["z"]["caps"].reshape(c, 2).sum(1), out["z"]["second"].reshape(c, 2).sum(1)
            top = max(float(z_caps.max()), float(z_second.max()), 1e-300)
            residual = lps.worst_residual(out["lam"], out["x"], out["u"], out["z"]["unilateral"],
                                          out["z"]["caps"] + out["z"]["second"] if theta == 0 else out["z"]["caps"])
            record = {"structure": label, "theta": theta, "step": k, "lam": out["lam"],
                      "n_change": float(np.linalg.norm(n - n_star) / max(np.linalg.norm(n), 1e-300)),
                      "sliding_on_caps": int(np.sum(z_caps > 1e-6 * top)),
                      "sliding_on_second_rows": int(np.sum(z_second > 1e-6 * top)),
                      "residual_3": residual, "seconds": out["seconds"]}
            trace.append(record)
            print(f"  theta {theta:g} step {k}: lam {out['lam']:.8f}, ||n - n*||/||n|| {record['n_change']:.1e}, "
                  f"flow on caps {record['sliding_on_caps']}, on the second rows {record['sliding_on_second_rows']}, "
                  f"residual of (3) {residual:.1e} ({out['seconds']:.1f} s)", flush=True)
            n_star = np.minimum(n, 0.0)
            if stage == 0:
                row.update(capped_lam=out["lam"], capped_steps=k, capped_coulomb_flow=record["sliding_on_second_rows"],
                           capped_residual_3=residual)
                if abs(out["lam"] - lam_before) <= 1e-9 * max(1.0, abs(out["lam"])):
                    break
                lam_before = out["lam"]
            else:
                row[f"theta_{theta:g}_lam"] = out["lam"]
                row[f"theta_{theta:g}_residual_3"] = residual
    return row


COLUMNS = [
    ("structure", "structure", "{}"), ("blocks", "free blocks", "{:d}"), ("lp_lam", "static LP λ", "{:.8g}"),
    ("lp_s", "LP s", "{:.3g}"), ("step_at_assoc_lam", "step LP (5) at n_assoc", "{:.8g}"),
    ("step_over_lp", "above λ_assoc", "{:+.2%}"), ("assoc_residual_3", "x_assoc: residual of (3)", "{:.1e}"),
    ("capped_lam", "capped sequence λ", "{:.8g}"), ("capped_steps", "steps", "{}"),
    ("capped_coulomb_flow", "interfaces with Coulomb flow", "{}"), ("capped_residual_3", "residual of (3)", "{:.1e}"),
]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stones", default="500", help="comma-separated stone counts (2:1 stone walls, r = 0.7)")
    parser.add_argument("--seeds", default="0", help="comma-separated seeds of the stone walls")
    parser.add_argument("--walls", default="", help="running-bond walls CxB (comma-separated)")
    parser.add_argument("--steps", type=int, default=20, help="most steps of the capped sequence")
    parser.add_argument("--thetas", default="", help="theta stages after the capped sequence (e.g. 0.8,0.4,0)")
    parser.add_argument("--theta-steps", type=int, default=5)
    parser.add_argument("--no-sequence", action="store_true", help="only the associative check")
    args = parser.parse_args(argv)
    structures = [(f"stone-wall {n} seed {s}", stone_wall_of(int(n), int(s)))
                  for n in args.stones.split(",") if n.strip() for s in args.seeds.split(",") if s.strip()]
    structures += [(f"wall {w}", named_wall(w)) for w in args.walls.split(",") if w.strip()]
    thetas = [float(t) for t in args.thetas.split(",") if t.strip()]
    rows, trace = [], []
    for label, structure in structures:
        ops = bm.assemble(structure)
        print(f"{label}: {ops.n_free_blocks} free blocks, {ops.n_interfaces} interfaces", flush=True)
        lps = StaticLPs(ops)
        row = {"structure": label, "blocks": ops.n_free_blocks, **associative_check(lps)}
        print(f"  static LP {row['lp_lam']:.8f} ({row['lp_s']:.1f} s); step LP at its forces "
              f"{row['step_at_assoc_lam']:.8f}; x_assoc residual of (3) {row['assoc_residual_3']:.1e}", flush=True)
        if not args.no_sequence:
            row.update(capped_sequence(lps, args.steps, thetas, args.theta_steps, label, trace))
        rows.append(row)
    print(markdown(rows, COLUMNS))
    print(f"\nwrote {write_csv(OUT / 'capped.csv', rows)}")
    if trace:
        print(f"wrote {write_csv(OUT / 'steps.csv', trace)}")
    return rows


if __name__ == "__main__":
    main()
