"""Why the block IPM needs more iterations on larger walls, and what a weighted central path changes.

Issue 14's 100,000-block target needs fewer interior-point iterations: 82 factorisations of ``K`` at
1.8-2.2 s each already exceed two minutes.  The iterations grow with the wall (1,010 blocks: 21, 10,050: 53,
100,014: 82).  Nearly all the growth is one phase, the *crawl*.  It starts once the residuals are
small and only the relative gap, a few units, is left.  After that, steps are 0.1-0.7 and ``mu`` falls about
0.75x per iteration.  This study measures:

* ``--diagnose CxB``: every iteration's spread of the complementarity products ``s_i y_i / mu`` and
  the products of the two *blocking* rows (the rows whose ratio test sets the primal and the dual
  step: the smallest ``s_{k+1} / s_k`` and ``y_{k+1} / y_k``).  If the blocking rows are centred
  (products near ``mu``), the short steps come from the central path's curvature and not from
  lost centrality.  Better centring (more correctors, ``sigma_min``, neighbourhoods) cannot fix that.
* ``--oracle CxB``: the same LP on a *weighted* central path ``s_i y_i = w_i mu``
  (:attr:`BlockIPM.path_weights`).  The weights come from the plain run's own solution
  (:func:`solution_weights`), which a real solve does not have.  The measurement asks whether any
  weights shorten the crawl, and by how much.  It also measures two rules that a solve does have:
  weights from the current iterate's products (``current``), and the oracle's formula with the current
  iterate in place of the solution, switched on at the crawl start (``running``).
* ``--transfer CxB --mu A --to B,C``: weights from the solution at friction coefficient ``A``,
  used for the same wall at ``B``, ``C`` (a parameter study's next LP).
* ``--roundoff CxB``: the same LP twice, the second time with the per-block products of the block solves
  formed by ``einsum`` instead of ``matmul`` (:func:`einsum_block_product`: the same sums in another order, so
  equally accurate, only the round-off differs): how far an iteration count is a property of the LP and how
  far of the floating-point path to it.
* ``--polish CxB``: whether the crawl could be cut short by a *finish* onto the optimal face (the
  finite-termination idea of Mehrotra & Ye: guess which rows end active, project the iterate onto the face
  where those rows hold with equality, done if the projection is feasible).  At every iteration of a second
  run the primal iterate is projected onto ``{A v = b, s_i = 0 on the rows taken as active}`` in the norm
  ``sum (ds_i / s_i)^2`` over the other rows (:func:`face_projection`), for several guesses of the active rows:
  the final iterate's own (``y_i > s_i`` there: an oracle) and the current iterate's ``s_i < kappa y_i`` for each
  ``kappa`` of ``--kappas``.  The summary counts, per guess and tolerance (1e-8, the verifier's; 1e-9, the
  engine's), the iterations after which every projection is feasible and its objective within the tolerance of
  the optimum: an upper bound on what a finish could save (a real finish also needs the dual projection).
* ``--ties CxB,... --eps A,B``: the same LP with every interface's friction coefficient lowered at random (seed 1)
  by up to the fraction ``A``, ``B`` (0: the wall itself).  A running-bond wall is periodic, so several
  mechanisms may tie for the optimum, and an interior point converges to the centre of all of them.  If ties
  made the crawl, breaking them would shorten it.
* ``--arc CxB,...``: Yang's arc-search steps (:func:`arc_search`), which follow the central path's curvature
  along an ellipse, against Mehrotra's line steps without and with Gondzio's correctors.
* ``--oracle CxB --coarse DxE``: also weights from a coarser wall's solution, each row taking the
  weight of the same row (same orientation and row of its interface) of the nearest coarse interface,
  positions scaled to the unit square (:func:`mapped_weights`).

:func:`solution_weights`: a row that ends active (its ``s`` fell by more than its ``y``, relative to
the crawl start) leaves the crawl once ``mu`` reaches about ``y*_i s_c,i``; a row that ends inactive
leaves it at ``s*_i y_c,i`` (``c``: the crawl start, ``*``: the solution).  Weights proportional to
that level (geometric mean 1, clipped to ``[1/clip, clip]``) make every row leave at the same ``mu``.

Usage::

    python studies/lab/ipm_crawl.py --diagnose 100x100
    python studies/lab/ipm_crawl.py --oracle 20x50,100x100
    python studies/lab/ipm_crawl.py --oracle 316x316 --clips 10 --rules ""
    python studies/lab/ipm_crawl.py --oracle 100x100 --clips "" --rules "" --coarse 50x50
    python studies/lab/ipm_crawl.py --transfer 100x100 --mu 0.65 --to 0.5,0.6,0.7
    python studies/lab/ipm_crawl.py --roundoff 20x50,100x100
    python studies/lab/ipm_crawl.py --ties 20x50,100x100 --eps 0,1e-6,1e-4,1e-2 --ipm-settings default
    python studies/lab/ipm_crawl.py --polish 20x50,100x100 --kappas 100,1e4 --ipm-settings default
    python studies/lab/ipm_crawl.py --arc 20x50,100x100 --ipm-settings default
    python studies/lab/ipm_crawl.py --smoke  # every part on small walls, its claims checked (CI)

Every run uses the block IPM with every inner direction corrected to the absolute target
(``--ipm-settings exact_inner``, :data:`blockmpec.solvers.linalg.block_ipm.EXACT_INNER_SETTINGS`): the settings
all of this study's tables were measured with, the LP default before ``inner_tolerance`` 1e-6.  The question here,
how many iterations the central path takes, does not depend on it; ``--ipm-settings default`` runs the present
default (1,010 / 10,050 / 100,014 blocks: 21 / 49 / 79 iterations against 21 / 53 / 82, ``studies/lab/lp_timing.py``).

Writes ``studies/output/ipm_crawl/{diagnose,oracle,transfer,roundoff,polish,polish_summary,ties,arc}.csv``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.formulations import compile_linear, static_lp
from blockmpec.solvers.engines.lp_engine import cold_lp_engine
from blockmpec.solvers.engines.scaling import LoadUnits
from blockmpec.solvers.linalg import block_ipm
from blockmpec.solvers.linalg.block_ipm import BlockIPM, IPMIterate

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from _ipm_settings import named_settings  # noqa: E402
from _tables import write_csv  # noqa: E402
from _walls import lowered_friction, named_wall, wall_shape, wall_shapes  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "ipm_crawl"
#: the crawl starts at the first iterate whose relative duality gap is at most this (the residuals
#: are 1e-6 or below there on every wall measured; the gap is ``p mu`` over ``|lam|``, p ~ 4 rows per interface)
CRAWL_GAP = 3.0


def wall_lp(spec: str, mu: float | None = None):
    """``(lp, ops)``: the static LP (1) of the running-bond wall ``"CxB"`` (courses x blocks per course)."""
    ops = bm.assemble(named_wall(spec) if mu is None else named_wall(spec, mu=mu))
    return compile_linear(static_lp(ops)), ops


class Recorder:
    """Keeps the iterate at the crawl start and the last one, and (``diagnose``) one row of statistics per
    iteration, through the engine's :meth:`~BlockIPM.before_iteration` hook."""

    def __init__(self, engine: BlockIPM, diagnose: bool = False, rule: str = "none", clip: float = 10.0) -> None:
        self.engine, self.diagnose, self.rule, self.clip = engine, diagnose, rule, clip
        self.start: IPMIterate | None = None
        self.previous: IPMIterate | None = None
        self.rows: list[dict] = []
        engine.before_iteration = self

    def __call__(self, it: IPMIterate) -> None:
        engine = self.engine
        if self.start is None and engine.gap(it) <= CRAWL_GAP:
            self.start = it.copy()
        if self.diagnose:
            self._statistics(it)
        if self.start is not None and self.rule == "current":
            mu = float(it.s @ it.y) / it.s.size
            engine.path_weights = np.clip(it.s * it.y / mu, 1 / self.clip, self.clip)
        elif self.start is not None and self.rule == "running":
            engine.path_weights = solution_weights(self.start, it, self.clip)
        self.previous = it.copy()

    def _statistics(self, it: IPMIterate) -> None:
        primal, dual, gap = self.engine.measures(it)
        row = {"k": len(self.rows), "mu": float(it.s @ it.y) / it.s.size, "primal": primal, "dual": dual, "gap": gap}
        if self.previous is not None:
            prev = self.previous
            products = prev.s * prev.y / self.rows[-1]["mu"]
            quantiles = np.quantile(products, [0.01, 0.5, 0.99])
            blocking_s = int(np.argmin(it.s / prev.s))
            blocking_y = int(np.argmin(it.y / prev.y))
            step = self.engine.trace[-1]
            self.rows[-1].update({
                "step_primal": step["step_primal"], "step_dual": step["step_dual"], "sigma": step["sigma"],
                "products_q01": quantiles[0], "products_median": quantiles[1], "products_q99": quantiles[2],
                "outside_0.1_10": float(np.mean((products < 0.1) | (products > 10))),
                "blocking_primal_product": products[blocking_s], "blocking_dual_product": products[blocking_y]})
        self.rows.append(row)


def solution_weights(start: IPMIterate, end: IPMIterate, clip: float = 10.0) -> np.ndarray:
    """Weights that make every row leave the crawl at the same ``mu`` (module docstring).

    ``start``: the iterate at the crawl start, ``end``: the solution (or an estimate of it).
    ``w_i = y_i^end s_i^start`` where ``s`` fell by more than ``y`` from start to end (active),
    ``s_i^end y_i^start`` elsewhere; normalised to geometric mean 1 and clipped to ``[1/clip, clip]``.
    """
    active = end.s / start.s < end.y / start.y
    level = np.where(active, end.y * start.s, end.s * start.y)
    level = np.maximum(level, np.finfo(float).tiny)
    return np.clip(level / np.exp(np.mean(np.log(level))), 1.0 / clip, clip)


def interface_rows(engine: BlockIPM, structure: bm.Structure) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each inequality row's interface, its row within the interface, the interface's midpoint scaled to the
    unit square and whether it is a bed joint (normal within 45 degrees of vertical)."""
    # each row's place in the (interface, row) block layout: the map the engine keeps for its block solves
    position = engine.dy_of_solution
    interface, local = position // engine.rows_per_block, position % engine.rows_per_block
    midpoint = structure.interfaces.midpoint
    low, span = midpoint.min(axis=0), np.ptp(midpoint, axis=0)
    unit = (midpoint - low) / np.where(span > 0, span, 1.0)
    bed = np.abs(structure.interfaces.normal[:, 1]) > np.sqrt(0.5)
    return interface, local, unit[interface], bed[interface]


def mapped_weights(coarse: tuple[BlockIPM, bm.Structure, np.ndarray], fine: tuple[BlockIPM, bm.Structure]) -> np.ndarray:
    """Weights of the fine wall's rows: the coarse wall's weight (``coarse[2]``) of the same row of the nearest
    coarse interface with the same orientation, positions in the unit square."""
    from scipy.spatial import cKDTree

    _, local_c, unit_c, bed_c = interface_rows(coarse[0], coarse[1])
    _, local_f, unit_f, bed_f = interface_rows(fine[0], fine[1])
    weights = np.ones(local_f.size)
    for bed in (True, False):
        for row in np.unique(local_f):
            source = (bed_c == bed) & (local_c == row)
            target = (bed_f == bed) & (local_f == row)
            if source.any() and target.any():
                _, nearest = cKDTree(unit_c[source]).query(unit_f[target])
                weights[target] = coarse[2][source][nearest]
    return weights


#: the block IPM's settings in every run (a name of ``_ipm_settings.<NAME>_SETTINGS``; ``--ipm-settings``)
IPM_SETTINGS = "exact_inner"


def run(lp, ops, weights: np.ndarray | None = None, diagnose: bool = False, rule: str = "none",
        clip: float = 10.0, block_product=None, settings: dict | None = None) -> tuple[dict, Recorder]:
    """One cold block-IPM solve with :data:`IPM_SETTINGS` (and ``settings`` over them); returns its summary row
    and the recorder.  ``block_product``: replaces the engine's :meth:`~BlockIPM.block_product` (None: the
    engine's own)."""
    engine = _engine(lp, ops, settings)
    engine.path_weights = weights
    if block_product is not None:
        engine.block_product = block_product
        engine.settings(kernels="numpy")  # the compiled kernels (numba installed) would bypass the override
    recorder = Recorder(engine, diagnose=diagnose, rule=rule, clip=clip)
    cpu = time.process_time()
    out = engine.solve()
    cpu = time.process_time() - cpu
    lam = float(lp.values("lam", out.v)[0]) if out.status.is_success else float("nan")
    return {"status": out.status.value, "iterations": out.iterations, "cpu_s": round(cpu, 2), "lam": lam}, recorder


def _engine(lp, ops, settings: dict | None = None) -> BlockIPM:
    """The LP's cold block IPM with :data:`IPM_SETTINGS` (and ``settings`` over them), ``K`` factorised in this
    process alone unless ``settings`` say otherwise: every table of this study was measured so, and a worker process
    (``factor_processes``) moves iteration counts by round-off."""
    engine = cold_lp_engine(lp, "block-ipm", LoadUnits.of(ops))
    if not isinstance(engine, BlockIPM):
        raise RuntimeError("ipm_crawl: the wall's LP did not get the block IPM")
    engine.settings(**{**named_settings(IPM_SETTINGS), "factor_processes": 1, **(settings or {})})
    return engine


def arc_point(z: np.ndarray, first: np.ndarray, second: np.ndarray, a: float) -> np.ndarray:
    """``z + sin(a) first + (1 - cos a) second``: the point at ``a`` on the arc through ``z``."""
    return z + np.sin(a) * first + (1.0 - np.cos(a)) * second


def arc_step(z: np.ndarray, first: np.ndarray, second: np.ndarray, grid: int = 64) -> float:
    """The largest ``a`` in ``[0, pi/2]`` with ``z + sin(t) first + (1 - cos t) second > 0`` for every ``t`` in
    ``[0, a]`` (``z > 0``): the first grid point where a component is not positive, then bisection below it."""
    def positive(t: float) -> bool:
        return bool(np.all(arc_point(z, first, second, t) > 0))

    low = 0.0
    for t in np.linspace(0.0, np.pi / 2, grid + 1)[1:]:
        if not positive(t):
            high = t
            break
        low = t
    else:
        return np.pi / 2
    for _ in range(40):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if positive(middle) else (low, middle)
    return low


def arc_search(lp, ops, max_iterations: int = 300) -> dict:
    r"""Yang's arc-search interior-point method on the LP, with the block IPM's factorisation and directions.

    Each iteration follows an ellipse through the iterate instead of a line:
    ``x(a) = x + sin(a) d + (1 - cos a) x''`` for ``a`` in ``[0, pi/2]``.  ``d`` is the affine-scaling direction
    (the path's tangent, full residuals, target ``-s o y``).  ``x''`` is its second derivative
    (zero residuals, target ``-2 ds o dy``) plus the centring direction (target ``sigma mu``).  ``sigma =
    (mu_a / mu)^3``, with ``mu_a`` at the end of the arc without centring.  The primal and dual ``a`` are each the
    largest that keeps ``s`` (``y``) positive (:func:`arc_step`), times the engine's step fraction.  Mehrotra's
    step, ``x + a (d + x''/2 + centring)``, adds the whole second-order term even to a short step, where the
    arc adds ``(1 - cos a) x'' ~ a^2 x''/2``.  The crawl's steps are short, so this asks whether a step that
    follows the path's curvature shortens it.  No Gondzio correctors; stops as the engine does (every relative
    measure at most its ``tol``)."""
    engine = _engine(lp, ops)
    cpu = time.process_time()
    with block_ipm.single_blas_thread():
        it = engine.initial_point()
        p = engine.h.size
        status, k = "iteration_limit", 0
        for k in range(max_iterations + 1):
            r_b, r_h, r_c = engine.residuals(it)
            if max(engine.measures(it, (r_b, r_h, r_c))) <= engine.tol:
                status = "optimal"
                break
            if k == max_iterations:
                break
            mu = float(it.s @ it.y) / p
            factors = engine.factorise(it)
            dv, ds, dw, dy = engine.refined_direction(it, factors, r_b, r_h, r_c, -it.s * it.y)
            zero = (np.zeros_like(r_b), np.zeros_like(r_h), np.zeros_like(r_c))
            curvature = engine.refined_direction(it, factors, *zero, -2.0 * ds * dy)
            a_p, a_d = arc_step(it.s, ds, curvature[1]), arc_step(it.y, dy, curvature[3])
            s_a, y_a = arc_point(it.s, ds, curvature[1], a_p), arc_point(it.y, dy, curvature[3], a_d)
            sigma = min(1.0, (float(s_a @ y_a) / p / mu) ** 3)
            centring = engine.refined_direction(it, factors, *zero, np.full(p, sigma * mu))
            vv, ss, ww, yy = (c + e for c, e in zip(curvature, centring))
            a_p = engine.step_fraction * arc_step(it.s, ds, ss)
            a_d = engine.step_fraction * arc_step(it.y, dy, yy)
            it.v += np.sin(a_p) * dv + (1.0 - np.cos(a_p)) * vv
            it.s += np.sin(a_p) * ds + (1.0 - np.cos(a_p)) * ss
            it.w += np.sin(a_d) * dw + (1.0 - np.cos(a_d)) * ww
            it.y += np.sin(a_d) * dy + (1.0 - np.cos(a_d)) * yy
    lam = float(lp.values("lam", engine.column_scale * it.v)[0]) if status == "optimal" else float("nan")
    return {"status": status, "iterations": k, "cpu_s": round(time.process_time() - cpu, 2), "lam": lam,
            "solves": engine.factoriser.solves}


def arc(spec: str) -> list[dict]:
    """The wall's LP by :func:`arc_search`, by Mehrotra's method without Gondzio's correctors (the closest
    line-search counterpart) and by the engine as set (:data:`IPM_SETTINGS`, with its correctors)."""
    lp, ops = wall_lp(spec)
    rows = [{"wall": spec, "method": "arc search", **arc_search(lp, ops)}]
    for method, settings in (("Mehrotra, no correctors", {"correctors": 0}), ("the engine as set", {})):
        summary, recorder = run(lp, ops, settings=settings)
        rows.append({"wall": spec, "method": method, **summary, "solves": recorder.engine.factoriser.solves})
    return rows


def _emit(rows: list[dict], name: str) -> None:
    for row in rows:
        print(json.dumps(row), flush=True)
    write_csv(OUT / f"{name}.csv", rows)


def diagnose(spec: str) -> tuple[list[dict], dict]:
    """Per-iteration rows, and a summary of the crawl (iterations from the first gap <= :data:`CRAWL_GAP`)."""
    lp, ops = wall_lp(spec)
    summary, recorder = run(lp, ops, diagnose=True)
    rows = [{"wall": spec, **{k: (float(f"{v:.3g}") if isinstance(v, float) else v) for k, v in row.items()}}
            for row in recorder.rows]
    crawl = [row for row in rows if row["gap"] <= CRAWL_GAP and "step_primal" in row]
    blocking = np.array([[row["blocking_primal_product"], row["blocking_dual_product"]] for row in crawl]).ravel()
    steps = np.array([min(row["step_primal"], row["step_dual"]) for row in crawl])
    summary = {"wall": spec, **summary, "crawl_start": crawl[0]["k"] if crawl else None, "crawl_iterations": len(crawl),
               "median_shorter_step": float(np.median(steps)) if crawl else None,
               "blocking_rows_centred": float(np.mean((blocking >= 0.1) & (blocking <= 10))) if crawl else None,
               "median_rows_outside_0.1_10": float(np.median([row["outside_0.1_10"] for row in crawl])) if crawl else None}
    return rows, summary


def oracle(spec: str, clips: tuple[float, ...] = (10.0, 100.0), rules: tuple[str, ...] = ("current", "running"),
           coarse: str = "") -> list[dict]:
    lp, ops = wall_lp(spec)
    plain, recorder = run(lp, ops)
    rows = [{"wall": spec, "weights": "none (central path)", **plain}]
    if recorder.start is None:
        return rows
    if coarse:
        lp_c, ops_c = wall_lp(coarse)
        _, recorder_c = run(lp_c, ops_c)
        weights_c = solution_weights(recorder_c.start, recorder_c.previous, 10.0)
        weights = mapped_weights((recorder_c.engine, named_wall(coarse), weights_c), (recorder.engine, named_wall(spec)))
        own = solution_weights(recorder.start, recorder.previous, 10.0)
        row, _ = run(lp, ops, weights=weights)
        rows.append({"wall": spec, "weights": f"from the {coarse} wall's solution (clip 10), mapped by position", **row,
                     "log10_correlation_with_own": round(float(np.corrcoef(np.log10(weights), np.log10(own))[0, 1]), 3)})
    for clip in clips:
        weights = solution_weights(recorder.start, recorder.previous, clip)
        row, _ = run(lp, ops, weights=weights)
        rows.append({"wall": spec, "weights": f"from its own solution, clip {clip:g}", **row})
    for rule in rules:
        row, _ = run(lp, ops, rule=rule)
        rows.append({"wall": spec, "weights": f"{rule} (from the crawl start)", **row})
    return rows


def transfer(spec: str, mu: float, targets: list[float], clip: float = 10.0) -> list[dict]:
    lp, ops = wall_lp(spec, mu)
    _, recorder = run(lp, ops)
    weights = solution_weights(recorder.start, recorder.previous, clip)
    rows = []
    for target in targets:
        lp_t, ops_t = wall_lp(spec, target)
        plain, _ = run(lp_t, ops_t)
        weighted, _ = run(lp_t, ops_t, weights=weights)
        rows.append({"wall": spec, "mu_source": mu, "mu": target, **{f"plain_{k}": v for k, v in plain.items()},
                     **{f"weighted_{k}": v for k, v in weighted.items()}})
    return rows


def einsum_block_product(M_inv: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """:meth:`BlockIPM.block_product` by ``einsum`` instead of ``matmul``: the same sums in another order."""
    return np.einsum("bij,bj->bi", M_inv, rhs)


def roundoff(spec: str) -> list[dict]:
    """The wall's LP with the engine's block products, then with :func:`einsum_block_product`."""
    lp, ops = wall_lp(spec)
    return [{"wall": spec, "block products": name, **run(lp, ops, block_product=product)[0]}
            for name, product in (("matmul (the engine's)", None), ("einsum", einsum_block_product))]


def ties(spec: str, fractions: list[float]) -> list[dict]:
    """The wall's LP with every interface's friction lowered at random (seed 1) by up to each fraction."""
    wall = named_wall(spec)
    rows = []
    for fraction in fractions:
        ops = bm.assemble(lowered_friction(wall, fraction))
        summary, _ = run(compile_linear(static_lp(ops)), ops)
        rows.append({"wall": spec, "friction_lowered_by_up_to": fraction, **summary})
    return rows


def face_projection(engine: BlockIPM, it: IPMIterate, active: np.ndarray, ratio: float = 1e8) -> tuple[float, float]:
    r"""Project the primal iterate onto the face where the ``active`` rows hold with equality.

    ``min sum_{i not active} (ds_i / s_i)^2`` subject to ``A (v + dv) = b``, ``G (v + dv) + s + ds = h`` with
    ``s_i + ds_i = 0`` on the active rows: one Newton solve of the block IPM's linear equations with the scaling
    ``d = 1/s^2`` on the other rows and ``d = ratio * max of those`` on the active rows (so they move by a
    ``1/ratio`` fraction of the rest), refined on the whole system.  Returns the projection's worst violation of
    ``G v <= h`` or ``A v = b``, relative to ``1 + ||h||`` or ``1 + ||b||`` (the engine's primal measure), and
    its objective ``c^T v``.
    """
    s_hat = np.where(active, 0.0, it.s)
    d_kept = 1.0 / it.s[~active] ** 2
    big = ratio * float(d_kept.max(initial=1.0))
    scaling = IPMIterate(it.v, np.where(active, 1.0, it.s), it.w, np.where(active, big, 1.0 / it.s))  # y/s = d
    r_b, r_h, _ = engine.residuals(IPMIterate(it.v, s_hat, it.w, it.y))
    factors = engine.factorise(scaling)
    dv, _, _, _ = engine.refined_direction(scaling, factors, r_b, r_h, np.zeros(engine.c.size),
                                            np.zeros_like(it.s), sweeps=4)
    v = it.v + dv
    violation = max(float(np.max(engine.G @ v - engine.h, initial=0.0)) / (1 + float(np.max(np.abs(engine.h)))),
                    float(np.max(np.abs(engine.A @ v - engine.b))) / (1 + float(np.max(np.abs(engine.b)))))
    return max(violation, 0.0), float(engine.c @ v)


def polish(spec: str, kappas: tuple[float, ...] = (1.0, 100.0)) -> tuple[list[dict], dict]:
    """Per iteration: projections (:func:`face_projection`) onto the final partition's face (the oracle) and onto
    the guessed faces ``{s_i < kappa y_i}``, each with its violation and its objective's relative error against
    the plain run's optimum.  A finish from that iterate could succeed only where both are within the tolerance."""
    lp, ops = wall_lp(spec)
    plain, recorder = run(lp, ops)
    final = recorder.previous
    optimum = float(recorder.engine.c @ final.v)
    guesses = {"oracle": lambda it: final.y > final.s,
               **{f"s<{kappa:g}y": (lambda it, kappa=kappa: it.s < kappa * it.y) for kappa in kappas}}
    rows: list[dict] = []

    def probe(engine: BlockIPM, it: IPMIterate) -> None:
        row = {"wall": spec, "k": len(rows), "gap": float(f"{engine.gap(it):.3g}")}
        for name, guess in guesses.items():
            active = guess(it)
            violation, objective = face_projection(engine, it, active)
            row.update({f"{name}_rows": int(active.sum()), f"{name}_violation": float(f"{violation:.3g}"),
                        f"{name}_objective_error": float(f"{abs(objective - optimum) / (1 + abs(optimum)):.3g}")})
        rows.append(row)

    engine = _engine(lp, ops)
    engine.before_iteration = lambda it: probe(engine, it)
    engine.solve()
    summary = {"wall": spec, **plain, "rows": int(final.s.size), "probe_iterations": len(rows)}
    # the verifier's tolerance 1e-8 and the engine's 1e-9 (the projection's own accuracy at its extreme scaling,
    # at the last iterate of 10,050 blocks, is 2.3e-9)
    for tol in (1e-8, engine.tol):
        for name in guesses:
            good = [row[f"{name}_violation"] <= tol and row[f"{name}_objective_error"] <= tol for row in rows]
            first = next((k for k in range(len(rows)) if all(good[k:])), None)
            summary[f"{name}_saves_at_{tol:g}"] = (len(rows) - 1 - first) if first is not None else 0
            summary[f"{name}_gap_there_at_{tol:g}"] = rows[first]["gap"] if first is not None else None
    return rows, summary


def smoke() -> None:
    """The smallest run of every part, each checked against what the study claims (CI); exits 1 naming the failures.

    On a 20x50 wall: weights from the solution shorten the path to the same optimum (verified at 1e-8), and the
    crawl's blocking rows are centred.  On an 8x10 wall: a wall mapped onto itself keeps every weight; ``einsum``
    block products agree with the engine's to round-off and reach the same lambda; the optimal iterate projected on
    its own face stays feasible at the optimum, the start does not; the polish summary counts within the run;
    lowered friction never raises lambda; the arc search ends at the engine's lambda, and its step meets the closed
    forms.  Wall names are read once (``_walls``), a malformed one is one clear error."""
    failures = []

    def check(ok: bool, what: str) -> None:
        if not ok:
            failures.append(what)

    lp, ops = wall_lp("20x50")
    plain, recorder = run(lp, ops)
    weights = solution_weights(recorder.start, recorder.previous, clip=10.0)
    check(weights.min() >= 0.1 and weights.max() <= 10.0 and weights.min() < 1 < weights.max(),
          "oracle: the solution's weights are not clipped to [0.1, 10] around 1")
    weighted = _engine(lp, ops)
    weighted.path_weights = weights
    out = weighted.solve()
    check(out.status.is_success and out.iterations < plain["iterations"],
          f"oracle: the weighted path took {out.iterations} iterations against {plain['iterations']}")
    lam = float(lp.values("lam", out.v)[0])
    from blockmpec.solvers.engines.highs import static_lp_solution

    worst = max(bm.verify.residuals(ops, static_lp_solution(lp, out), associative=True).values())
    check(abs(lam - plain["lam"]) <= 1e-8 * abs(plain["lam"]) and worst <= 1e-8,
          f"oracle: the weighted path ends at lam {lam} (plain {plain['lam']}), residual {worst:.1e}")
    _, summary = diagnose("20x50")
    check(summary["status"] == "optimal" and summary["crawl_iterations"] >= 5
          and summary["blocking_rows_centred"] >= 0.8 and summary["median_shorter_step"] < 0.9,
          f"diagnose: the crawl's blocking rows are not centred ({summary})")

    lp, ops = wall_lp("8x10")
    _, recorder = run(lp, ops)
    weights = solution_weights(recorder.start, recorder.previous)
    wall = named_wall("8x10")
    check(np.array_equal(mapped_weights((recorder.engine, wall, weights), (_engine(lp, ops), wall)), weights),
          "mapped weights: a wall mapped onto itself does not keep its weights")
    engine = _engine(lp, ops)
    blocks, *_ = engine.factorise(engine.initial_point())
    rhs = np.random.default_rng(0).standard_normal(blocks[0].shape[:2])
    ours, theirs = engine.block_product(blocks[0], rhs), einsum_block_product(blocks[0], rhs)
    check(np.allclose(ours, theirs, rtol=1e-12, atol=1e-12 * np.abs(ours).max()),
          "roundoff: einsum's block products differ from the engine's beyond round-off")
    rows = roundoff("8x10")
    check([row["status"] for row in rows] == ["optimal", "optimal"]
          and abs(rows[1]["lam"] - rows[0]["lam"]) <= 1e-8 * abs(rows[0]["lam"]),
          f"roundoff: {[(row['status'], row['lam']) for row in rows]}")
    final = recorder.previous
    active = final.y > final.s
    optimum = float(recorder.engine.c @ final.v)
    violation, objective = face_projection(recorder.engine, final, active)
    start_violation, _ = face_projection(recorder.engine, recorder.engine.initial_point(), active)
    check(0 < active.sum() < active.size and violation <= 1e-9
          and abs(objective - optimum) <= 1e-9 * (1 + abs(optimum)) and start_violation > 1e-3,
          f"face projection: final {violation:.1e} (objective {objective} vs {optimum}), start {start_violation:.1e}")
    rows, summary = polish("8x10", kappas=(100.0,))
    check(summary["status"] == "optimal" and summary["probe_iterations"] == len(rows) == summary["iterations"] + 1
          and all(0 <= summary[f"{name}_saves_at_{tol}"] < len(rows) for tol in ("1e-08", "1e-09")
                  for name in ("oracle", "s<100y"))
          and rows[-1]["oracle_violation"] <= 1e-8 and rows[-1]["oracle_objective_error"] <= 1e-8,
          f"polish: summary {summary}")
    rows = ties("8x10", [0.0, 1e-2])
    check([row["status"] for row in rows] == ["optimal", "optimal"] and rows[1]["lam"] <= rows[0]["lam"] + 1e-9,
          f"ties: lowered friction gave {[(row['status'], row['lam']) for row in rows]}")
    ones = np.ones(1)
    check(abs(arc_step(ones, -2 * ones, 0 * ones) - np.pi / 6) <= 1e-9
          and abs(arc_step(ones, 0 * ones, -1.5 * ones) - np.arccos(1 / 3)) <= 1e-9
          and arc_step(ones, 0.5 * ones, 0.3 * ones) == np.pi / 2, "arc_step: not the closed forms")
    rows = {row["method"]: row for row in arc("8x10")}
    reference = rows["the engine as set"]
    check(rows["arc search"]["status"] == "optimal" and reference["status"] == "optimal"
          and abs(rows["arc search"]["lam"] - reference["lam"]) <= 1e-8
          and abs(rows["Mehrotra, no correctors"]["lam"] - reference["lam"]) <= 1e-8,
          f"arc: {[(name, row['status'], row['lam']) for name, row in rows.items()]}")
    check(wall_shape(" 3X4 ") == (3, 4) and wall_shapes("2x5,,10x20") == [(2, 5), (10, 20)], "wall names misread")
    for bad in ("3by4", "3x", "3x4x5"):
        try:
            wall_shape(bad)
            failures.append(f"wall name {bad!r} accepted")
        except ValueError as error:
            check(f"wall '{bad}': expected CxB" in str(error), f"wall name {bad!r}: {error}")
    for line in failures:
        print(f"smoke check failed: {line}")
    if failures:
        raise SystemExit(1)
    print("smoke: every part of the study runs and its claims hold on the small walls")


def main(argv: list[str] | None = None) -> list[dict]:
    global IPM_SETTINGS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--diagnose", default="", help="a wall CxB: per-iteration products and blocking rows")
    parser.add_argument("--oracle", default="", help="comma-separated walls CxB: weighted paths side by side")
    parser.add_argument("--transfer", default="", help="a wall CxB: weights from --mu used at --to")
    parser.add_argument("--roundoff", default="", help="comma-separated walls CxB: block products by matmul and einsum")
    parser.add_argument("--polish", default="", help="comma-separated walls CxB: projections onto the optimal face per iteration")
    parser.add_argument("--ties", default="", help="comma-separated walls CxB: friction lowered at random by up to --eps")
    parser.add_argument("--eps", default="0,1e-6,1e-4,1e-2", help="--ties: largest fractions of the friction removed")
    parser.add_argument("--arc", default="", help="comma-separated walls CxB: arc-search steps against Mehrotra's")
    parser.add_argument("--kappas", default="1,100", help="--polish: guesses s_i < kappa y_i of the active rows")
    parser.add_argument("--clips", default="10,100", help="--oracle: clips of the weights from the solution")
    parser.add_argument("--rules", default="current,running", help="--oracle: rules without the solution ('' for none)")
    parser.add_argument("--coarse", default="", help="--oracle: also weights from this coarser wall CxB's solution")
    parser.add_argument("--mu", type=float, default=0.65)
    parser.add_argument("--to", default="0.5,0.6,0.7")
    parser.add_argument("--ipm-settings", default=IPM_SETTINGS,
                        help="block IPM settings of every run: exact_inner (this study's tables), default, ... "
                             "(studies/lab/_ipm_settings.py)")
    parser.add_argument("--smoke", action="store_true",
                        help="the smallest run of every part (8x10 and 20x50 walls), with the checks of its claims (CI)")
    args = parser.parse_args(argv)
    try:
        named_settings(args.ipm_settings)
    except ValueError as error:
        parser.error(str(error))
    if args.smoke:
        smoke()
        return []
    IPM_SETTINGS = args.ipm_settings
    rows: list[dict] = []
    if args.diagnose:
        rows, summary = diagnose(args.diagnose)
        _emit(rows, "diagnose")
        print(json.dumps(summary), flush=True)
    if args.oracle:
        clips = tuple(float(v) for v in args.clips.split(",") if v)
        rules = tuple(v for v in args.rules.split(",") if v)
        rows = [row for spec in args.oracle.split(",") for row in oracle(spec, clips, rules, args.coarse)]
        _emit(rows, "oracle")
    if args.transfer:
        rows = transfer(args.transfer, args.mu, [float(v) for v in args.to.split(",")])
        _emit(rows, "transfer")
    if args.roundoff:
        rows = [row for spec in args.roundoff.split(",") for row in roundoff(spec)]
        _emit(rows, "roundoff")
    if args.polish:
        rows, summaries = [], []
        for spec in args.polish.split(","):
            wall_rows, summary = polish(spec, tuple(float(v) for v in args.kappas.split(",") if v))
            rows += wall_rows
            summaries.append(summary)
        _emit(rows, "polish")
        _emit(summaries, "polish_summary")
    if args.ties:
        rows = [row for spec in args.ties.split(",") for row in ties(spec, [float(v) for v in args.eps.split(",")])]
        _emit(rows, "ties")
    if args.arc:
        rows = [row for spec in args.arc.split(",") for row in arc(spec)]
        _emit(rows, "arc")
    if not (args.diagnose or args.oracle or args.transfer or args.roundoff or args.polish or args.ties or args.arc):
        parser.error("give --diagnose, --oracle, --transfer, --roundoff, --polish, --ties or --arc")
    return rows


if __name__ == "__main__":
    main()
