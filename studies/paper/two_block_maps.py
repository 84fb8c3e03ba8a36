r"""The two-block problem over the (eta, mu) plane: collapse mechanisms and multipliers (paper Figs 5-6).

For each point of a grid of slenderness ``eta = h/b`` and friction ``mu`` (psi = 0)
the comparator (:func:`blockmpec.bench.compare.compare`) runs

* ``static-lp``: associative friction (Fig. 5a / 6a);
* ``milp``: the certified minimum non-associative multiplier (Fig. 5b / 6b);
* ``milp`` with ``sense="max"`` (label ``milp-max``): the certified *maximum*
  of ``lam`` over the solutions of the MCP (3), the largest non-associative
  multiplier (Fig. 5c / 6c);

and every solution is classified by its mechanism (:func:`classify`).

The paper (Sect. 3) states that on this problem the maximum coincides with the
associative multiplier, reached by the non-dilatant counterpart of the
associative mechanism (:data:`A_TO_NA`: A1 -> NA1, A2-1 and A2-2 -> NA2,
A3 -> NA3).  Panels (c) are computed, not relabelled; the table keeps that
prediction in ``na_max_predicted_mechanism`` for comparison.

Mechanism classes (from the solution ``u, z_u``; ``tol`` relative to the largest entry)
---------------------------------------------------------------------------------------
Blocks L (left) and R (right, on the side the live load pushes towards).

* ``sliding`` (A1 / NA1): no rotation, ``|theta_L|, |theta_R| <= tol``;
* ``coupled rocking`` (A3 / NA3): a rotation, and L and R move as one rigid body
  (no velocity jump at the ends of their common interface);
* ``single rocking`` (A2 / NA2): a rotation and a jump between L and R (each
  block rocks on its own toe, or R rocks alone).  For associative friction the
  dilatant sliding that comes with it splits the class: ``A2-1`` when friction
  flows (``z_f > tol``) at the base of R, ``A2-2`` when it flows at the base of L.

Closed forms (paper Sect. 3): associative ``lam = min(mu, [eta(1-mu^2)+mu]^-1,
(1+2mu^2)/[eta(1+mu^2)-mu], 2/eta)`` in that order of mechanisms A1, A2-1, A2-2,
A3; non-associative minimum ``mu`` (sliding) if ``mu <= 1/eta`` else ``1/eta``
(single rocking).

Run: ``python studies/paper/two_block_maps.py [--n 21] [--check]`` (``--smoke``: the smallest grid with ``--check``);
writes
``studies/output/two_block_maps/{two_block_maps.csv, mechanisms.png, multipliers.png}``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.bench.compare import compare

OUT = Path(__file__).resolve().parents[1] / "output" / "two_block_maps"

ASSOCIATIVE_CLASSES = ("A1", "A2-1", "A2-2", "A3")
NA_CLASSES = ("NA1", "NA2", "NA3")
NA_OF = {"sliding": "NA1", "single rocking": "NA2", "coupled rocking": "NA3"}
A_TO_NA = {"A1": "NA1", "A2-1": "NA2", "A2-2": "NA2", "A3": "NA3"}


def closed_form_candidates(eta: float, mu: float) -> dict[str, float]:
    """The paper's associative mechanism multipliers (those with a positive denominator).

    Not valid for squat blocks with ``mu > 1`` (``eta < 1``), where
    :func:`blockmpec.cases.closed_form` returns None.
    """
    cands = {"A1": mu, "A3": 2.0 / eta}
    d1 = eta * (1 - mu**2) + mu
    if d1 > 0:
        cands["A2-1"] = 1.0 / d1
    d2 = eta * (1 + mu**2) - mu
    if d2 > 0:
        cands["A2-2"] = (1 + 2 * mu**2) / d2
    return cands


def closed_form_mechanism(eta: float, mu: float) -> tuple[str, float]:
    """Associative mechanism of least multiplier by the paper's closed forms, and that multiplier."""
    cands = closed_form_candidates(eta, mu)
    best = min(cands, key=cands.get)
    return best, cands[best]


def _parts(structure: bm.Structure, ops: bm.Operators):
    """Free indices of L and R, and the interfaces: base of L, base of R, L-R."""
    free = [int(j) for j in ops.free_blocks]
    cx = structure.centroid[free, 0]
    left, right = (0, 1) if cx[0] < cx[1] else (1, 0)
    itf = structure.interfaces
    ids = [int(k) for k in ops.interface_ids]
    base_l = base_r = shared = None
    for pos, k in enumerate(ids):
        pair = {int(itf.minus[k]), int(itf.plus[k])}
        if pair == {free[0], free[1]}:
            shared = pos
        elif free[left] in pair:
            base_l = pos
        elif free[right] in pair:
            base_r = pos
    return left, right, base_l, base_r, shared, (itf.start[ids[shared]], itf.end[ids[shared]])


def classify(structure: bm.Structure, ops: bm.Operators, solution: bm.Solution, problem: str,
             tol: float = 1e-6) -> str:
    """Mechanism class of a two-block solution (see the module docstring)."""
    if solution.u is None:
        return "none"
    left, right, base_l, base_r, _, (p0, p1) = _parts(structure, ops)
    u = np.asarray(solution.u, float).reshape(-1, 3)
    ell = ops.length_scale
    scale = max(np.abs(u[:, :2]).max() * ell, np.abs(u[:, 2]).max() * np.ptp(structure.vertices[..., 1]))
    rotation = np.abs(u[:, 2]).max() * np.ptp(structure.vertices[..., 1]) > tol * scale
    if not rotation:
        kind = "sliding"
    else:
        def velocity(i: int, p: np.ndarray) -> np.ndarray:
            c = structure.centroid[int(ops.free_blocks[i])]
            ux, uy, th = u[i]
            return np.array([ux * ell - th * (p[1] - c[1]), uy * ell + th * (p[0] - c[0])])

        jump = max(np.linalg.norm(velocity(right, p) - velocity(left, p)) for p in (p0, p1))
        kind = "coupled rocking" if jump <= tol * scale else "single rocking"
    if problem != "associative":
        return NA_OF[kind]
    if kind == "sliding":
        return "A1"
    if kind == "coupled rocking":
        return "A3"
    z_f = np.abs(np.asarray(solution.z_f, float))
    top = z_f.max() if z_f.size and z_f.max() > 0 else 1.0
    flows_r = z_f[2 * base_r:2 * base_r + 2].max() > tol * top
    flows_l = z_f[2 * base_l:2 * base_l + 2].max() > tol * top
    if flows_r and not flows_l:
        return "A2-1"
    if flows_l and not flows_r:
        return "A2-2"
    return "A2"


#: (column prefix, comparator label, method, options) of the three panels
RUNS = (("associative", "static-lp", "static-lp", {}),
        ("na_min", "milp", "milp", {}),
        ("na_max", "milp-max", "milp", {"sense": "max"}))


def sample(etas, mus, *, progress=None, isolate: bool = True):
    """Run static-lp, milp (min) and milp (max) on every (eta, mu); one row per point.

    Returns
    -------
    (pandas.DataFrame, pandas.DataFrame)
        The per-point table (columns ``{associative, na_min, na_max}_{lam, mechanism,
        status}``, closed forms, ``na_max_predicted_mechanism``) and the comparator's
        long-format table.
    """
    import pandas as pd

    cases = {f"eta={eta:.6g},mu={mu:.6g}": ("two-blocks", {"eta": float(eta), "mu": float(mu)})
             for eta in etas for mu in mus}
    results: dict = {}
    have_milp = "milp" in bm.list_solvers()
    methods = [(label, method, options) for _, label, method, options in RUNS if have_milp or method != "milp"]
    df = compare(cases, methods, progress=progress, results=results, isolate=isolate)
    rows = []
    for label, (_, params) in cases.items():
        eta, mu = params["eta"], params["mu"]
        row = {"eta": eta, "mu": mu}
        cf_lam = bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu)
        cf_mech = closed_form_mechanism(eta, mu)[0] if cf_lam is not None else "n/a"
        row.update(closed_form_associative=np.nan if cf_lam is None else cf_lam, closed_form_mechanism=cf_mech,
                   closed_form_na_min=bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu))
        for key, method_label, _, _ in RUNS:
            got = results.get((label, method_label, 0))
            if got is None:
                row.update({f"{key}_lam": np.nan, f"{key}_mechanism": "none", f"{key}_status": "not run"})
                continue
            res, structure = got
            ops = bm.assemble(structure)
            ok = res.success
            row[f"{key}_lam"] = res.multiplier if ok else np.nan
            row[f"{key}_status"] = res.status.value
            row[f"{key}_mechanism"] = classify(structure, ops, res.solution, res.problem) if ok else "none"
        row["na_max_predicted_mechanism"] = A_TO_NA.get(row["associative_mechanism"], "none")
        rows.append(row)
    return pd.DataFrame(rows), df


def _maps(table, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap

    etas = np.sort(table["eta"].unique())
    mus = np.sort(table["mu"].unique())

    def grid(col):
        g = table.pivot(index="mu", columns="eta", values=col)
        return g.reindex(index=mus, columns=etas)

    panels = [("associative_mechanism", "(a) associative\n(static-lp)"),
              ("na_min_mechanism", "(b) non-associative, minimum\n(milp, certified)"),
              ("na_max_mechanism", "(c) non-associative, maximum\n(milp sense=max, certified)")]
    classes = list(ASSOCIATIVE_CLASSES) + ["A2"] + list(NA_CLASSES) + ["none"]
    colours = ["#4c72b0", "#dd8452", "#c44e52", "#55a868", "#937860", "#4c72b0", "#dd8452", "#55a868", "#ffffff"]
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(len(classes) + 1) - 0.5, len(classes))
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True, layout="constrained")
    for ax, (col, title) in zip(axes, panels):
        g = grid(col).map(lambda v: classes.index(v) if v in classes else classes.index("none"))
        ax.pcolormesh(etas, mus, g.values.astype(float), cmap=cmap, norm=norm, shading="nearest")
        present = [c for c in classes if (grid(col) == c).values.any()]
        for c in present:
            sel = grid(col) == c
            ii, jj = np.nonzero(sel.values)
            ax.text(etas[int(np.median(jj))], mus[int(np.median(ii))], c, ha="center", va="center",
                    fontsize=9, weight="bold", color="white" if c != "none" else "black")
        e = np.linspace(etas.min(), etas.max(), 200)
        ax.plot(e, 1 / e, "k--", lw=1.0, label=r"$\mu = 1/\eta$")
        ax.set_ylim(mus.min(), mus.max())
        ax.set_title(title)
        ax.set_xlabel(r"slenderness $\eta = h/b$")
    axes[0].set_ylabel(r"friction coefficient $\mu$")
    axes[0].legend(loc="upper right", fontsize=8)
    fig.suptitle("Two blocks: collapse mechanisms over the parameter plane (cf. paper Fig. 5)")
    p1 = out / "mechanisms.png"
    fig.savefig(p1, dpi=200)
    plt.close(fig)

    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True, layout="constrained")
    lam_cols = [("associative_lam", "(a) associative (static-lp)"),
                ("na_min_lam", "(b) non-associative, minimum (milp)"),
                ("na_max_lam", "(c) non-associative, maximum (milp sense=max)")]
    vmax = np.nanmax(table[["associative_lam", "na_min_lam", "na_max_lam"]].values)
    for ax, (col, title) in zip(axes, lam_cols):
        im = ax.pcolormesh(etas, mus, grid(col).values, shading="nearest", vmin=0, vmax=vmax, cmap="viridis")
        cs = ax.contour(etas, mus, grid(col).values, levels=[0.2, 0.4, 0.6, 0.8, 1.0], colors="w", linewidths=0.7)
        ax.clabel(cs, fontsize=7, fmt="%.1f")
        ax.set_title(title)
        ax.set_xlabel(r"slenderness $\eta = h/b$")
    axes[0].set_ylabel(r"friction coefficient $\mu$")
    fig.colorbar(im, ax=axes, label=r"collapse multiplier $\lambda$", shrink=0.9)
    fig.suptitle("Two blocks: collapse multiplier over the parameter plane (cf. paper Fig. 6)")
    p2 = out / "multipliers.png"
    fig.savefig(p2, dpi=200)
    plt.close(fig)
    return [p1, p2]


def check(table) -> list[str]:
    """The paper's statements on the computed table (Sect. 3, Figs 5-6); one line per statement that fails.

    * the certified minimum slides (NA1) iff ``mu < 1/eta``, else single rocking (NA2), at ``min(mu, 1/eta)``;
    * the associative mechanism is the closed forms' argmin away from region boundaries (the two least candidates
      more than 1 % apart), and each of A1, A2-1, A2-2, A3 shows up (on a grid crossing every boundary);
    * the certified maximum equals the associative multiplier, and away from boundaries its mechanism is the
      non-dilatant counterpart of the associative one (:data:`A_TO_NA`), NA1, NA2 and NA3 each showing up.
    """
    failures = []
    certified = table["na_min_status"] == "optimal"
    if certified.mean() <= 0.9:
        failures.append(f"the minimum is certified at {certified.mean():.0%} of the points only")
    t = table[certified & (np.abs(table["mu"] - 1 / table["eta"]) > 1e-6)]
    sliding = t["na_min_mechanism"] == "NA1"
    if not np.array_equal(sliding.values, (t["mu"] < 1 / t["eta"]).values):
        failures.append("the certified minimum does not slide exactly where mu < 1/eta")
    if set(t.loc[~sliding, "na_min_mechanism"]) != {"NA2"}:
        failures.append(f"the rocking minima are {set(t.loc[~sliding, 'na_min_mechanism'])}, not NA2")
    if not np.allclose(t["na_min_lam"], np.minimum(t["mu"], 1 / t["eta"]), rtol=1e-7):
        failures.append("the certified minimum is not min(mu, 1/eta)")

    def clear(r) -> bool:
        values = sorted(closed_form_candidates(r["eta"], r["mu"]).values())
        return not np.isnan(r["closed_form_associative"]) and (len(values) == 1 or values[1] > values[0] * 1.01)

    rows = table[table.apply(clear, axis=1)]
    wrong = rows[rows["associative_mechanism"] != rows["closed_form_mechanism"]]
    if len(wrong):
        failures.append(f"associative mechanism not the closed forms' argmin at {list(zip(wrong.eta, wrong.mu))}")
    if not {"A1", "A2-1", "A2-2", "A3"} <= set(table["associative_mechanism"]):
        failures.append(f"associative mechanisms seen: {sorted(set(table['associative_mechanism']))}")
    if not (table["na_max_status"] == "optimal").all():
        failures.append("the maximum is not certified at every point")
    if not np.allclose(table["na_max_lam"], table["associative_lam"], rtol=1e-7):
        failures.append("the certified maximum is not the associative multiplier")
    want = rows["associative_mechanism"].map(A_TO_NA)
    bad = rows[rows["na_max_mechanism"] != want]
    if len(bad):
        failures.append(f"maximum mechanism not the counterpart at {list(zip(bad.eta, bad.mu))}")
    if set(rows["na_max_mechanism"]) != {"NA1", "NA2", "NA3"}:
        failures.append(f"maximum mechanisms seen: {sorted(set(rows['na_max_mechanism']))}")
    return failures


def main(argv: list[str] | None = None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=21, help="grid points per axis")
    parser.add_argument("--eta", default="0.5,5", help="eta range lo,hi")
    parser.add_argument("--mu", default="0.1,1.5", help="mu range lo,hi")
    parser.add_argument("--check", action="store_true",
                        help="assert the paper's statements on the table (exit 1 naming each that fails)")
    parser.add_argument("--smoke", action="store_true",
                        help="the smallest grid crossing every region boundary (6 x 6 on eta 1.1..5.6, mu 0.15..1.4, "
                             "plus the paper's point 3, 0.65), solved in this process, with --check (CI)")
    args = parser.parse_args(argv)
    if args.smoke:
        etas = list(np.linspace(1.1, 5.6, 6)) + [3.0]
        mus = list(np.linspace(0.15, 1.4, 6)) + [0.65]
        args.check = True
    else:
        e0, e1 = (float(v) for v in args.eta.split(","))
        m0, m1 = (float(v) for v in args.mu.split(","))
        etas, mus = np.linspace(e0, e1, args.n), np.linspace(m0, m1, args.n)
    table, long = sample(etas, mus, progress=not args.smoke, isolate=not args.smoke)
    OUT.mkdir(parents=True, exist_ok=True)
    table.to_csv(OUT / "two_block_maps.csv", index=False)
    long.to_csv(OUT / "runs.csv", index=False)
    paths = _maps(table, OUT)
    # agreement with the closed forms
    ok_n = np.isclose(table["na_min_lam"], table["closed_form_na_min"], rtol=1e-7)
    known = table["closed_form_mechanism"] != "n/a"
    same_mech = (table.loc[known, "associative_mechanism"] == table.loc[known, "closed_form_mechanism"]).mean()
    ok_a = np.isclose(table["associative_lam"], table["closed_form_associative"], rtol=1e-7)[known.values]
    na_slide = table["na_min_mechanism"] == "NA1"
    pred_slide = table["mu"] <= 1 / table["eta"]
    print(f"{len(table)} points ({known.sum()} with an associative closed form); associative lam = closed form "
          f"at {ok_a.mean():.1%}, mechanism = closed-form argmin at {same_mech:.1%} (ties on boundaries may differ)")
    print(f"NA minimum lam = closed form at {ok_n.mean():.1%}; sliding iff mu <= 1/eta at "
          f"{(na_slide == pred_slide).mean():.1%} of points")
    certified_max = table["na_max_status"] == "optimal"
    ok_max = np.isclose(table["na_max_lam"], table["associative_lam"], rtol=1e-7, atol=1e-12)
    same_max_mech = table["na_max_mechanism"] == table["na_max_predicted_mechanism"]
    print(f"NA maximum (milp sense=max): certified at {certified_max.mean():.1%}; = associative lam at "
          f"{ok_max.mean():.1%}; mechanism = paper's A->NA counterpart at {same_max_mech.mean():.1%}")
    for key, method_label, _, _ in RUNS:
        secs = long.loc[long["method_label"] == method_label, "total_time_s"].astype(float)
        if len(secs):
            print(f"  {key} ({method_label}): {secs.sum():.1f} s total, {secs.median() * 1e3:.1f} ms median, "
                  f"{secs.max() * 1e3:.0f} ms max per point")
    for p in paths:
        print(f"wrote {p}")
    if args.check:
        failures = check(table)
        for line in failures:
            print(f"check failed: {line}")
        if failures:
            raise SystemExit(1)
        print("check: every statement of the paper holds on this grid")
    return table


if __name__ == "__main__":
    main()
