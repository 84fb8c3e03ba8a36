r"""Two blocks over the (eta, mu) plane: collapse multipliers and mechanisms (the seed paper's Sect. 3, Figs 5-6).

Two equal blocks of width ``b`` and height ``h`` stand side by side on a fixed base; each carries its
weight ``W`` as dead load and a horizontal force ``W`` as live load; every joint has Coulomb friction
``mu = tan(phi)`` and zero dilatancy.  Over a grid of slenderness ``eta = h/b`` and ``mu`` this script solves

* the associative problem, static LP (1), with ``static-lp`` (panel a);
* the non-associative problem's *minimum* multiplier, the MPEC (4), with ``milp``, which certifies it
  (panel b);
* the *maximum* multiplier over the solutions of the MCP (3), with ``milp`` and ``sense="max"`` (panel c);

and classifies each collapse mechanism from ``res.mechanism`` as sliding, single rocking or coupled
rocking.  The paper gives closed forms: associative ``lam = min(mu, 1/[eta(1-mu^2)+mu],
(1+2mu^2)/[eta(1+mu^2)-mu], 2/eta)`` (the terms with a positive denominator), non-associative minimum
``lam = mu`` (sliding) for ``mu <= 1/eta``, else ``1/eta`` (single rocking); and it states that the
maximum equals the associative multiplier.  The script checks every point against them and exits with
status 1 if one disagrees.

Run::

    python docs/gallery/two_block_maps.py            # 21 x 21 grid, about a minute
    python docs/gallery/two_block_maps.py --small    # 4 x 4 grid, a few seconds (what CI runs)

It writes ``multipliers.png``, ``mechanisms.png`` and ``two_block_maps.csv`` into ``--out``
(default ``gallery-output/two_block_maps``).  It uses only the public API (``import blockmpec as bm``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import blockmpec as bm

#: (column prefix, title, method, options) of the three panels
PANELS = (
    ("associative", "(a) associative (static-lp)", "static-lp", {}),
    ("na_min", "(b) non-associative min (milp)", "milp", {}),
    ("na_max", "(c) non-associative max (milp, max)", "milp", {"sense": "max"}),
)
MECHANISMS = ("sliding", "single rocking", "coupled rocking")


def mechanism_class(structure: bm.Structure, mechanism: pd.DataFrame, tol: float = 1e-6) -> str:
    """Sliding (no block rotates), coupled rocking (the two blocks move as one rigid body) or single rocking.

    ``mechanism`` is ``res.mechanism``: one row per free block, ``u_x, u_y`` the velocity of its centroid
    and ``rotation`` its rotation rate, in the structure's frame and units.
    """
    if mechanism.empty:
        return "none"
    size = np.ptp(structure.vertices[..., 1])  # the blocks' height: turns a rotation into a velocity
    u = mechanism[["u_x", "u_y"]].to_numpy()
    theta = mechanism["rotation"].to_numpy()
    scale = max(np.abs(u).max(), np.abs(theta).max() * size)
    if np.abs(theta).max() * size <= tol * scale:
        return "sliding"
    (a, b) = mechanism["block"].to_numpy()
    ca, cb = structure.centroid[a], structure.centroid[b]
    # velocity of block b's rigid motion at block a's centroid, against block a's own velocity
    ub = u[1] + theta[1] * np.array([-(ca[1] - cb[1]), ca[0] - cb[0]])
    rigid = abs(theta[0] - theta[1]) * size <= tol * scale and np.linalg.norm(ub - u[0]) <= tol * scale
    return "coupled rocking" if rigid else "single rocking"


def sample(etas: np.ndarray, mus: np.ndarray) -> pd.DataFrame:
    """Solve the three problems at every grid point; one row per point."""
    rows = []
    for eta in etas:
        for mu in mus:
            structure = bm.cases.two_blocks(eta=float(eta), mu=float(mu))
            row = {"eta": eta, "mu": mu,
                   "closed_form_associative": bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu),
                   "closed_form_na_min": bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu)}
            for key, _, method, options in PANELS:
                res = bm.solve(structure, method, **options)
                row[f"{key}_status"] = res.status.value
                row[f"{key}_lam"] = res.multiplier if res.success else np.nan
                row[f"{key}_mechanism"] = mechanism_class(structure, res.mechanism) if res.success else "none"
            rows.append(row)
    return pd.DataFrame(rows)


def check(table: pd.DataFrame) -> list[str]:
    """Disagreements with the paper's closed forms (an empty list when there are none)."""
    problems = []
    for key, expected in (("associative", "closed_form_associative"), ("na_min", "closed_form_na_min"),
                          ("na_max", "closed_form_associative")):
        known = table[expected].notna()  # the associative formula does not hold for squat blocks with mu > 1
        bad = known & ~np.isclose(table[f"{key}_lam"], table[expected], rtol=1e-7, atol=1e-12)
        problems += [f"{key}: eta={r.eta:.4g} mu={r.mu:.4g} lam={r[f'{key}_lam']!r}, closed form {r[expected]:.8g}"
                     for _, r in table[bad].iterrows()]
    slides = table["na_min_mechanism"] == "sliding"
    # the minimum slides below mu = 1/eta and rocks above it (on the line itself both mechanisms give lam = mu)
    off_line = ~np.isclose(table["mu"] * table["eta"], 1.0)
    wrong = off_line & (slides != (table["mu"] < 1 / table["eta"]))
    problems += [f"na_min mechanism: eta={r.eta:.4g} mu={r.mu:.4g} is {r.na_min_mechanism}"
                 for _, r in table[wrong].iterrows()]
    return problems


def figures(table: pd.DataFrame, out: Path) -> list[Path]:
    """Fig. 6 style (multiplier over the plane) and Fig. 5 style (mechanism over the plane), three panels each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap

    etas, mus = np.sort(table["eta"].unique()), np.sort(table["mu"].unique())

    def grid(column: str) -> pd.DataFrame:
        return table.pivot(index="mu", columns="eta", values=column).reindex(index=mus, columns=etas)

    line = np.linspace(etas.min(), etas.max(), 200)
    paths = []
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True, layout="constrained")
    vmax = np.nanmax(table[[f"{key}_lam" for key, *_ in PANELS]].to_numpy())
    for ax, (key, title, _, _) in zip(axes, PANELS):
        image = ax.pcolormesh(etas, mus, grid(f"{key}_lam").to_numpy(float), shading="nearest", vmin=0, vmax=vmax)
        ax.plot(line, 1 / line, "w--", lw=1)
        ax.set(title=title, xlabel=r"slenderness $\eta = h/b$", ylim=(mus.min(), mus.max()))
    axes[0].set_ylabel(r"friction coefficient $\mu$")
    fig.colorbar(image, ax=axes, label=r"collapse multiplier $\lambda$", shrink=0.9)
    paths.append(out / "multipliers.png")
    fig.savefig(paths[-1], dpi=150)
    plt.close(fig)

    classes = (*MECHANISMS, "none")
    cmap = ListedColormap(["#dd8452", "#4c72b0", "#55a868", "#ffffff"])
    norm = BoundaryNorm(np.arange(len(classes) + 1) - 0.5, len(classes))
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True, layout="constrained")
    for ax, (key, title, _, _) in zip(axes, PANELS):
        codes = grid(f"{key}_mechanism").map(classes.index).to_numpy(float)
        ax.pcolormesh(etas, mus, codes, cmap=cmap, norm=norm, shading="nearest")
        ax.plot(line, 1 / line, "k--", lw=1, label=r"$\mu = 1/\eta$")
        ax.set(title=title, xlabel=r"slenderness $\eta = h/b$", ylim=(mus.min(), mus.max()))
    axes[0].set_ylabel(r"friction coefficient $\mu$")
    handles = [plt.Rectangle((0, 0), 1, 1, color=cmap(i)) for i in range(len(MECHANISMS))]
    fig.legend(handles, MECHANISMS, loc="outside lower center", ncols=3)
    paths.append(out / "mechanisms.png")
    fig.savefig(paths[-1], dpi=150)
    plt.close(fig)
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="a 4 x 4 grid (the CI run)")
    parser.add_argument("--n", type=int, default=21, help="grid points per axis (default 21)")
    parser.add_argument("--out", default="gallery-output/two_block_maps", help="output folder")
    args = parser.parse_args(argv)
    n = 4 if args.small else args.n
    etas, mus = np.linspace(0.5, 5.0, n), np.linspace(0.1, 1.5, n)
    table = sample(etas, mus)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "two_block_maps.csv", index=False)
    for path in figures(table, out):
        print(f"wrote {path}")
    counts = {key: table[f"{key}_mechanism"].value_counts().to_dict() for key, *_ in PANELS}
    print(f"{len(table)} points; mechanisms: {counts}")
    problems = check(table)
    for line in problems:
        print("disagrees with the closed form:", line, file=sys.stderr)
    print("every point agrees with the paper's closed forms" if not problems else f"{len(problems)} disagreements")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
