r"""An interior-point fixed point: one block-IPM run whose friction cohesion is the iterate's own.

The fixed point's step LP (5) at normal forces ``n*`` (:func:`blockmpec.formulations.modified_lp`)::

    min  -lam   s.t.  E x + f_d + lam f_l = 0,   N_u^T x <= 0,
                      +-t_k + tan(psi_k) n_k <= -(tan(phi_k) - tan(psi_k)) n*_k

differs between steps only in the right-hand side of its friction rows.  Its KKT
conditions at ``n* = n`` are exactly the MCP (3): the primal friction rows read
``+-t_k + tan(phi_k) n_k <= 0`` (Coulomb: ``N_f``), the dual rows
``E^T u + N_u z_u + V_f z_f = 0`` (flow with ``tan(psi)``), and complementarity holds
row by row.  In the block IPM's form (``v`` free, slacks ``s``, multipliers ``y``)::

    A v = b,   G_phi v + s = h,   c - A^T w + G_psi^T y = 0,   s o y = 0,   s, y >= 0,

where ``G_phi`` and ``G_psi`` differ only in the ``n`` entries of the friction rows.

The engine's ``coupling="lagged"`` (``n* := n`` reset at each interior-point iteration, ``G_psi`` on both
sides) is kept for measurement; it stalls (CHANGELOG.md).

**Newton on (3) itself** (the default, ``coupling="exact"``): the same Mehrotra
predictor-corrector iteration, with ``G_phi`` in the primal rows and ``G_psi`` in the
dual rows.  The per-block matrix becomes ``[[0, B_psi^T], [B_phi, -I]]``
(``B = D^{1/2} G``), ``H^{-1}`` its top-left block of the inverse (no longer
symmetric), and ``K = A_B H^{-1} A_B^T`` has the same sparsity but is not symmetric;
it is factorised by the same ordering and SuperLU with diagonal pivots (an ``LU``
without pivoting, as for the LP).  The "gap" of the stopping test is the
complementarity ``s^T y / (1 + |c^T v|)`` (the LP's duality gap identity needs
``G_phi = G_psi``).  At convergence the point solves (3) up to ``tol``; the shared
verifier checks it.

Aim (which solution of (3)).  (3) often has a continuum of solutions, and the plain
run stops inside it (two blocks, eta = 3, mu = 0.65: 0.3965, between the minimum 1/3
and the associative 0.41973).  ``fold_weight > 0`` adds ``-fold_weight * sum_k w_k n_k``
to the objective (``w_k = (tan(phi_k) - tan(psi_k)) / max``: less compression, as the
fixed point's ``"least-compressed"`` rule) with weight ``fold_weight`` while
``mu > fold_knee * mu_0``, ``fold_weight * mu / (fold_knee * mu_0)`` below, and exactly 0
once ``mu <= fold_off * mu_0`` (:data:`FOLD_KNEE`, :data:`FOLD_OFF`), so the point
returned solves (3) with the plain objective (1/3 on that case).  A run with the aim
term that fails is repeated without it (:func:`run_interior`).

Closing stage (:func:`continue_central_path`).  Where Mehrotra's iterates leave the strongly curved central path of
(3) and stall (complementarity stuck while the primal and dual residuals are at round-off), :func:`run_interior`
continues the weighted central path through the run's best iterate by pseudo-arclength continuation
(``fixed-point``'s setting ``interior_continuation``): groups of friction rows switch between stick and slip along
it, and once they have settled long steps reach a solution of (3).  The continuation gives up once ``mu`` has risen
1e3-fold (the path turned back).  What was measured for these stages, and the routes that failed, are in
CHANGELOG.md and docs/methods/fixed-point.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.deadline import NEVER, Deadline
from blockmpec.solvers.engines.block_lp import BlockLP, interface_blocks
from blockmpec.solvers.linalg.block_ipm import EXACT_INNER_SETTINGS, IPMIterate

__all__ = ["ContactLayout", "InteriorFixedPoint", "continue_central_path", "recentred_start", "sequence_then_newton",
           "run_interior", "COUPLINGS"]

COUPLINGS = ("exact", "lagged", "fixed")
#: the aim term's weight is constant down to mu = FOLD_KNEE * mu_0, then falls with mu, and is
#: exactly zero once mu <= FOLD_OFF * mu_0 (module docstring)
FOLD_KNEE = 1e-3
FOLD_OFF = 1e-9
#: continuation of a stalled run (:func:`continue_central_path`): most steps, the corrector's
#: tolerance on the weighted products ``max |s o y - mu w| / (mu w)``, and the rise of ``mu`` above its
#: start at which the path counts as turned back for good (on the 10,050-block wall the path through the
#: stalled point turned after ~30 steps and ran to ``mu`` ~ 4e9 in 110; with later round-off it crawls there instead:
#: docs/performance.md, *Fixed point against one cold LP*)
CONTINUATION_STEPS = 3000
CORRECTOR_TOL = 0.3
CONTINUATION_MU_RISE = 1e3
#: the continuation also stops when ``mu`` has not fallen tenfold in this many steps (it crawls).  Where it converged
#: it took about 40 steps per decade (2,420-block wall); on a 516-stone wall (seed 1) it crawled from ``mu`` 1.6e-6 to
#: 1.1e-6 in 2,500 steps, which left no iterations for the last stage (:func:`sequence_then_newton`)
CONTINUATION_DECADE_STEPS = 200
#: the damped sequence of interior-point step LPs (:func:`sequence_then_newton`): its relaxation ``omega``, the first
#: and the last checkpoint of ``||n - n*|| / ||n||`` (halved after each) at which Newton on (3) is tried, and the
#: recentring factors ``f`` of those Newton runs, in the order tried (``studies/lab/fixed_point_irregular.py``)
SEQUENCE_RELAXATION = 0.3
SEQUENCE_FIRST_CHECKPOINT = 1e-2
SEQUENCE_LAST_CHECKPOINT = 1e-4
SEQUENCE_RECENTRING = (10.0, 30.0, 100.0)
#: most iterations of each of those Newton runs (they took 20-30 where they converged)
SEQUENCE_NEWTON_ITERATIONS = 300


@dataclass(frozen=True)
class ContactLayout:
    """Where a contact's normal force sits in ``x`` and which contact each friction row belongs to.

    ``normal_index`` (shape (c,)) and ``friction_contact`` (shape (friction rows,)) as
    :class:`~blockmpec.formulations.StepLPs` (and the operators) give them: in 2D ``x = (t, n, m)`` per
    interface with two friction rows each, in 3D ``x = (t1, t2, n)`` per contact point with one friction row per
    side of the pyramid.  Each friction row's cohesion is ``-(tan(phi) - tan(psi)) n*`` of its contact.
    """

    normal_index: np.ndarray
    friction_contact: np.ndarray

    @classmethod
    def of(cls, lp, layout=None) -> "ContactLayout":
        """``layout``'s (any object with the two attributes, e.g. a ``StepLPs``), else the planar layout of ``lp``
        (checked against its number of friction rows)."""
        if layout is not None:
            return cls(np.asarray(layout.normal_index), np.asarray(layout.friction_contact))
        contacts = lp.columns["x"].size // 3
        if lp.rows["friction"].size != 2 * contacts:
            raise ValueError("interior fixed point: the LP is not planar (two friction rows per interface); pass "
                             "layout= (its StepLPs)")
        return cls(np.arange(1, 3 * contacts, 3), np.repeat(np.arange(contacts), 2))


class InteriorFixedPoint(BlockLP):
    """:class:`BlockIPM` for the MCP (3) written as the step LP (5) with ``n* = n``.

    Parameters
    ----------
    lp : LinearProgram
        The compiled step LP (5) (:func:`blockmpec.formulations.modified_lp` with slope
        ``tan(psi)``, any ``n*``: its cohesion is overwritten): its friction rows, ``tan(psi)``, are the dual's.
    coulomb_lp : LinearProgram
        The compiled static LP (1) (:func:`blockmpec.formulations.static_lp`): the same rows and columns, its
        friction rows with ``tan(phi)``; ``coulomb_lp - lp`` on the friction rows is the cohesion factor
        ``tan(phi) - tan(psi)`` that moves to the primal rows (``n* = n``).  Both come from
        :func:`blockmpec.formulations.step_lps`, the one statement of these LPs.
    units : LoadUnits
        The problem's load units (:class:`~blockmpec.solvers.engines.scaling.LoadUnits`).
    coupling : ``"exact"`` (Newton on (3)), ``"lagged"`` (``n* := n`` before each LP iteration) or
        ``"fixed"`` (the LP (5) at the ``n*`` of :meth:`set_n_star`: one fixed-point step)
    fold_weight, fold_knee, fold_off : float
        The least-compressed objective term, where its weight starts to fall with ``mu`` and
        where it is switched off (module docstring); it is also switched off once the
        residuals are within ``1e3 tol``, so a run never stops on the aimed problem.
    layout : ContactLayout or StepLPs, optional
        Where the normal forces sit in ``x`` and which contact each friction row belongs to (2D or 3D); by
        default the planar layout ``(t, n, m)`` with two friction rows per interface.
    **ipm : options of :class:`BlockIPM` (``tol``, ``max_iterations``, ``deadline``, ``ordering``).
    """

    #: Newton on (3) was measured (and its stall studied) with every inner direction corrected to the absolute
    #: target.  With the LP default's inner_tolerance 1e-6 instead (bm.solve(wall, "fixed-point", ...), CPU s, one
    #: run each): 1,010 blocks the same iterations and lam; 2,032 blocks default 48 instead of 54 iterations (lam
    #: 0.426318 instead of 0.426330), no aim 57 instead of 81 (3.4 s against 9.2 s, same lam); but 2,420 blocks
    #: (with the continuation) default 316 instead of 258 iterations (42.4 s against 37.8 s), no aim 242 instead
    #: of 208: mixed, so the engine keeps the setting it was measured with
    default_settings = EXACT_INNER_SETTINGS

    def __init__(self, lp, coulomb_lp, units, coupling: str = "exact", fold_weight: float = 0.0,
                 fold_off: float = FOLD_OFF, fold_knee: float = FOLD_KNEE, layout=None, **ipm) -> None:
        from blockmpec.solvers.plan import INTERIOR_FIXED_POINT_RULES

        if coupling not in COUPLINGS:
            raise ValueError(f"interior fixed point: unknown coupling {coupling!r}; use one of {', '.join(COUPLINGS)}")
        row_scale, column_scale = units.static(lp)
        ipm.setdefault("rules", INTERIOR_FIXED_POINT_RULES)
        super().__init__(lp, interface_blocks(lp), row_scale=row_scale, column_scale=column_scale, **ipm)
        self.coupling = coupling
        self.friction_position = self._in_position[lp.rows["friction"]]
        layout = ContactLayout.of(lp, layout)
        self.friction_contact = layout.friction_contact
        self.normal_columns = lp.columns["x"][layout.normal_index]
        # the cohesion factor tan(phi) - tan(psi) of each friction row's normal force, read off the two compiled LPs
        difference = _friction_difference(lp, coulomb_lp, layout.normal_index)
        row_columns = self.normal_columns[self.friction_contact]  # the normal force of each friction row's contact
        self.row_factor = np.asarray(difference[lp.rows["friction"], row_columns]).ravel()
        factor = np.zeros(self.normal_columns.size)
        np.maximum.at(factor, self.friction_contact, self.row_factor)
        self.cohesion_factor = factor
        self.fold_weight = float(fold_weight)
        self.fold_off = float(fold_off)
        self.fold_knee = float(fold_knee)
        top = float(np.max(factor, initial=0.0))
        self.fold_costs = factor / top if top > 0 else np.zeros_like(factor)
        self.base_c = self.c.copy()
        self.current_fold = 0.0
        #: keep the aim term to the end: the run then solves the aimed problem, not (3)
        #: (a measurement recorded in the changelog, 2026-11-28)
        self.keep_aim = False
        self.mu0: float | None = None
        self.n_star = np.zeros(factor.size)
        self.set_n_star(self.n_star)  # exact coupling: h = 0 on the friction rows, for good
        #: the dual rows' inequality matrix (tan(psi)); self.G becomes the primal one (tan(phi))
        self.G_dual = self.G
        self.g_dual_blocks = self.g_blocks
        if coupling == "exact":
            # the primal rows are the static LP's (Coulomb, tan(phi)): the step LP's plus the difference, scaled as
            # the step LP's rows are (the same numbers as the rows of the static LP itself, scaled alike)
            rows, cols = self.friction_position, row_columns
            extra = sp.csr_array((self.in_scale[rows] * self.row_factor * self.column_scale[cols], (rows, cols)),
                                 shape=self.G.shape)
            self.G = (self.G + extra).tocsr()
            self.g_blocks = self.dense_blocks(self.G)
            self.symmetric = False
        self.set_fold(self.fold_weight)
        self.lam_column = int(lp.columns["lam"][0])
        #: a StoppingCriterion that records every iteration (set by :func:`run_interior`), or None
        self.criterion = None
        #: max relative residual of (3) at the last iterate seen, and the best so far
        self.last_error = self.best_error = np.inf
        #: the iterate with the smallest residuals so far (internal units), and a start iterate (None: Mehrotra's)
        self.best_iterate: IPMIterate | None = None
        self.start_iterate: IPMIterate | None = None

    def initial_point(self) -> IPMIterate:
        """:attr:`start_iterate` when set (a warm start), else Mehrotra's starting point."""
        if self.start_iterate is not None:
            return self.start_iterate.copy()
        return super().initial_point()

    # ------------------------------------------------------------------ the moving data
    def set_n_star(self, n_star: np.ndarray) -> None:
        """Friction rows' right-hand side ``-(tan(phi) - tan(psi)) n*`` (every row of each contact)."""
        self.n_star = n_star
        upper = -self.row_factor * n_star[self.friction_contact]
        self.h[self.friction_position] = self.in_scale[self.friction_position] * upper

    def set_fold(self, weight: float) -> None:
        """Objective ``-lam - weight * sum_k w_k n_k`` (internal scaling)."""
        self.c = self.base_c.copy()
        self.c[self.normal_columns] -= weight * self.fold_costs * self.column_scale[self.normal_columns]
        self.current_fold = weight

    def normal_forces(self, it: IPMIterate) -> np.ndarray:
        """Interface normal forces ``n`` of an iterate (the compiled LP's units)."""
        return self.column_scale[self.normal_columns] * it.v[self.normal_columns]

    def before_iteration(self, it: IPMIterate) -> None:
        """Reset ``n* := min(n, 0)`` (lagged coupling), set the aim term's weight, record the iterate
        (and keep it in :attr:`best_iterate` when its residuals are the smallest so far)."""
        mu = float(it.s @ it.y) / it.s.size
        if self.mu0 is None:
            self.mu0 = mu
        n = self.normal_forces(it)
        norm = float(np.linalg.norm(n))
        change = float(np.linalg.norm(n - self.n_star)) / (norm if norm > 0 else 1.0)
        if self.coupling == "lagged":
            self.set_n_star(np.minimum(n, 0.0))
        if self.fold_weight > 0:
            ratio = mu / self.mu0
            self.set_fold(0.0 if ratio <= self.fold_off else self.fold_weight * min(1.0, ratio / self.fold_knee))
        primal, dual, complementarity = self.measures(it)
        if self.current_fold > 0 and not self.keep_aim and max(primal, dual, complementarity) <= 1e3 * self.tol:
            # never stop on the aimed problem: the point returned must solve (3) itself
            self.set_fold(0.0)
            primal, dual, complementarity = self.measures(it)
        self.last_error = max(primal, dual, complementarity)
        if self.last_error < self.best_error:
            self.best_error = self.last_error
            self.best_iterate = it.copy()
        if self.criterion is not None:
            lam = float(self.column_scale[self.lam_column] * it.v[self.lam_column])
            self.criterion.iterations += 1
            self.criterion.record(kkt_residual=max(primal, dual, complementarity), primal=primal, dual=dual,
                                  complementarity=complementarity, mu=mu, multiplier=lam,
                                  fold_weight=self.current_fold, n_change=change if self.coupling == "lagged" else 0.0)

    # ------------------------------------------------------------------ Newton on (3)
    def gap(self, it: IPMIterate) -> float:
        """The relative complementarity ``s^T y / (1 + |c^T v|)`` (the LP's duality-gap identity
        needs ``G_phi = G_psi``)."""
        return float(it.s @ it.y) / (1 + abs(float(self.c @ it.v)))

    def outcome_at(self, it: IPMIterate):
        """The outcome (HiGHS's conventions) of a given iterate: a run of 0 iterations started there
        (``OPTIMAL`` when its residuals of (3) are at most ``tol``); nothing is recorded."""
        saved = self.max_iterations, self.start_iterate, self.criterion
        self.max_iterations, self.start_iterate, self.criterion = 0, it, None
        try:
            return self.solve()
        finally:
            self.max_iterations, self.start_iterate, self.criterion = saved


def continue_central_path(engine: InteriorFixedPoint, start: IPMIterate, *, tol: float, deadline: Deadline = NEVER,
                          max_steps: int = CONTINUATION_STEPS, corrector_tol: float = CORRECTOR_TOL,
                          record=None) -> tuple[IPMIterate, dict]:
    r"""Pseudo-arclength continuation of the weighted central path of (3) through ``start``.

    The path: ``r(z) = (mu / mu_0) r(z_0)`` for the linear rows (``r`` = :meth:`InteriorFixedPoint.residuals`),
    ``s o y = mu w`` with ``w = s_0 o y_0 / mu_0``; it passes through ``start`` at ``mu_0``, so a
    stalled, badly centred iterate is on its own path.  Arclength is measured in
    ``(ds / s, dy / y, dmu / mu)``.  Each step: a tangent predictor of length ``h`` (halved until
    ``s, y, mu > 0`` and the corrector converges), then at most 4 Newton corrections of the
    bordered system ``[J, -dF/dmu; t^T]`` (two solves with the same factors of ``K``: the
    residual and the path's slope), accepted when a full step keeps ``s, y > 0`` and
    ``max |s o y - mu w| / (mu w) <= corrector_tol``; ``h`` doubles after a one-correction step.
    The tangent keeps the previous one's orientation, so a turning point (``dmu/ds`` changing
    sign) would be followed.  Stops when the relative residuals of (3) are at most ``tol``,
    after ``max_steps`` steps, at ``deadline``, when no step of
    length ``h > 1e-8`` is accepted, when ``mu`` has risen to :data:`CONTINUATION_MU_RISE`
    times its start (the path has turned back towards ``mu = inf``), when ``mu`` has not fallen tenfold in
    :data:`CONTINUATION_DECADE_STEPS` steps (it crawls), or when ``K`` is singular in floating point
    (at the last accepted point).

    Why: Mehrotra's long steps leave this path where it curves (groups of friction rows
    switching between stick and slip, one after another) and stall; the path itself goes on
    (module docstring).  ``record(step=..., mu=..., primal=..., dual=..., complementarity=...,
    multiplier=..., factorisations=...)`` is called after every step.

    Returns the last iterate and ``{"steps", "factorisations", "mu"}``.
    """

    from blockmpec.solvers.linalg.block_ipm import single_blas_thread
    from blockmpec.solvers.linalg.cholesky import SingularMatrixError

    mu0 = float(start.s @ start.y) / start.s.size
    weights = start.s * start.y / mu0
    r0 = engine.residuals(start)
    slope = (-r0[0] / mu0, -r0[1] / mu0, -r0[2] / mu0)  # the linear rows' right-hand side per unit mu

    def metric(a, b, z, mu):
        return float(np.sum(a[1] * b[1] / z.s ** 2) + np.sum(a[3] * b[3] / z.y ** 2) + a[4] * b[4] / mu ** 2)

    def moved(z, d, step):
        return IPMIterate(z.v + step * d[0], z.s + step * d[1], z.w + step * d[2], z.y + step * d[3])

    def tangent(z, mu, factors, previous=None):
        t = [*engine.refined_direction(z, factors, *slope, weights), 1.0]
        norm = np.sqrt(metric(t, t, z, mu))
        t = [x / norm for x in t]
        if previous is None:
            return [-x for x in t]  # towards smaller mu
        return t if metric(t, previous, z, mu) > 0 else [-x for x in t]

    z, mu, steps, factorisations = start, mu0, 0, 1
    decade_mu, decade_step = mu0, 0  # the last mu at which mu had fallen tenfold, and its step
    with single_blas_thread():
        try:
            factors = engine.factorise(z)
            t = tangent(z, mu, factors)
            h = 0.1
            while (steps < max_steps and not deadline.expired() and max(engine.measures(z)) > tol
                   and mu < CONTINUATION_MU_RISE * mu0 and steps - decade_step < CONTINUATION_DECADE_STEPS):
                accepted, corrections = False, 0
                while h > 1e-8 and not accepted:
                    zp, mp = moved(z, t, h), mu + h * t[4]
                    if zp.s.min() <= 0 or zp.y.min() <= 0 or mp <= 0:
                        h *= 0.5
                        continue
                    zc, mc = zp, mp
                    for corrections in range(1, 5):
                        factors = engine.factorise(zc)
                        factorisations += 1
                        r_b, r_h, r_c = engine.residuals(zc)
                        theta = mc / mu0
                        a = [*engine.refined_direction(zc, factors, r_b - theta * r0[0], r_h - theta * r0[1],
                                                        r_c - theta * r0[2], mc * weights - zc.s * zc.y), 0.0]
                        b = [*engine.refined_direction(zc, factors, *slope, weights), 1.0]
                        offset = metric(t, [zc.v - zp.v, zc.s - zp.s, zc.w - zp.w, zc.y - zp.y, mc - mp], z, mu)
                        dmu = (-offset - metric(t, a, z, mu)) / metric(t, b, z, mu)
                        d = [a[i] + dmu * b[i] for i in range(4)] + [dmu]
                        longest = min(engine.max_step(zc.s, d[1]), engine.max_step(zc.y, d[3]))
                        full = longest >= 1.0 and (zc.s + d[1]).min() > 0 and (zc.y + d[3]).min() > 0
                        step = 1.0 if full else 0.9 * longest
                        zc, mc = moved(zc, d, step), mc + step * dmu
                        off_path = float(np.max(np.abs(zc.s * zc.y - mc * weights) / (mc * weights))) if mc > 0 else np.inf
                        if full and off_path <= corrector_tol:
                            accepted = True
                            break
                    if not accepted:
                        h *= 0.5
                if not accepted:
                    break
                t = tangent(zc, mc, factors, t)
                z, mu = zc, mc
                steps += 1
                if mu <= 0.1 * decade_mu:
                    decade_mu, decade_step = mu, steps
                h *= 2.0 if corrections == 1 else 1.3 if corrections == 2 else 1.0
                if record is not None:
                    primal, dual, complementarity = engine.measures(z)
                    lam = float(engine.column_scale[engine.lam_column] * z.v[engine.lam_column])
                    record(step=steps, mu=mu, primal=primal, dual=dual, complementarity=complementarity,
                           multiplier=lam, factorisations=factorisations)
        except SingularMatrixError:
            pass  # K singular in floating point: the continuation ends at its last accepted point

    return z, {"steps": steps, "factorisations": factorisations, "mu": mu}


def recentred_start(newton: InteriorFixedPoint, iterate: IPMIterate, factor: float) -> IPMIterate:
    """Newton on (3)'s start from an iterate of the step LP (5) (the same internal units): ``v, w`` kept, the slacks
    of (3) ``s = max(h - G_phi v, 0)``, and ``s, y`` both raised by ``sqrt(factor mu)`` (``mu`` the iterate's mean
    complementarity product; at least 1e-12)."""
    mu = float(iterate.s @ iterate.y) / iterate.s.size
    shift = max(float(np.sqrt(factor * mu)), 1e-12)
    start = iterate.copy()
    start.s = np.maximum(newton.h - newton.G @ start.v, 0.0) + shift
    start.y = start.y + shift
    return start


def sequence_then_newton(lp, coulomb_lp, units, *, tol: float, max_steps: int, deadline: Deadline = NEVER,
                         ordering: str = "auto", record=None, layout=None):
    r"""The paper's iteration with interior-point step LPs, damped, then Newton on (3) from near its fixed point.

    1. ``n*`` starts at the associative forces (the static LP (1) by the block IPM).  Each step solves the step
       LP (5) at ``n*`` by the block IPM (:class:`InteriorFixedPoint` with ``coupling="fixed"``: an optimal point
       near the analytic centre of the optimal face, not a vertex), giving ``n``; then
       ``n* <- min(n* + omega (n - n*), 0)`` (:data:`SEQUENCE_RELAXATION`).  A fixed point of this map solves (3),
       as one of the simplex steps does.
    2. When ``||n - n*|| / ||n||`` first falls to a checkpoint (:data:`SEQUENCE_FIRST_CHECKPOINT`, then half of it
       ..., down to :data:`SEQUENCE_LAST_CHECKPOINT`), Newton on (3) (``coupling="exact"``) starts from the step
       LP's iterate: its slacks ``s = h - G_phi v`` of (3), and ``s, y`` both raised by ``sqrt(f mu)`` for each
       ``f`` of :data:`SEQUENCE_RECENTRING` in turn (``mu`` the LP iterate's).  The first run whose residuals of
       (3) reach ``tol`` ends the stage.

    Why: on irregular stone walls from ~500 stones, Newton on (3) from Mehrotra's start stalls (relative
    complementarity 0.01-1) and the central path through the stalled point does not lead to a solution;
    the simplex steps jump between optimal vertices (``||n - n*|| / ||n||`` ~ 0.2 step after step).  The damped
    interior-point steps converge, slowly (linearly); close to their fixed point Newton converges in 20-30
    iterations (``studies/lab/fixed_point_irregular.py``; 516 stones: 38 LPs; 1,005 stones: 125 LPs).

    The steps stop when their smallest ``||n - n*|| / ||n||`` has not halved in
    :data:`~blockmpec.solvers.plan.FIXED_POINT_STALL_STEPS` steps (the simplex steps' rule; on the 2,042-stone wall
    they hovered at 0.07-0.12 from step 40 to 90).

    ``record(stage=..., ...)`` is called after every LP step and every Newton run.  Returns
    ``(engine, outcome, facts)``: the Newton engine and its outcome on success, else ``(None, None, facts)``;
    facts: ``sequence_lps``, ``sequence_newton_runs``, ``sequence_n_change`` (the last), ``sequence_stalled``.
    """
    from blockmpec.result import Status
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.lp_engine import cold_lp_engine
    from blockmpec.solvers.plan import FIXED_POINT_STALL_STEPS

    facts = {"sequence_lps": 0, "sequence_newton_runs": 0, "sequence_n_change": float("nan"),
             "sequence_stalled": False}
    start = cold_lp_engine(coulomb_lp, "block-ipm", units).solve(deadline)
    if not start.status.is_success:
        return None, None, facts
    layout = ContactLayout.of(lp, layout)
    n_star = np.minimum(static_lp_solution(coulomb_lp, start).x[layout.normal_index], 0.0)
    steps = InteriorFixedPoint(lp, coulomb_lp, units, coupling="fixed", tol=tol, deadline=deadline.end, layout=layout,
                               ordering=ordering)
    checkpoint = SEQUENCE_FIRST_CHECKPOINT
    smallest, smallest_at = np.inf, 0  # the stall rule: the smallest change must halve within FIXED_POINT_STALL_STEPS
    while facts["sequence_lps"] < max_steps and checkpoint >= SEQUENCE_LAST_CHECKPOINT and not deadline.expired():
        if facts["sequence_lps"] - smallest_at >= FIXED_POINT_STALL_STEPS:
            facts["sequence_stalled"] = True
            break
        steps.set_n_star(n_star)
        steps.best_error, steps.best_iterate = np.inf, None
        out = steps.solve()
        facts["sequence_lps"] += 1
        if not out.status.is_success:
            break
        n = steps.normal_forces(steps.best_iterate)
        change = float(np.linalg.norm(n - n_star)) / max(float(np.linalg.norm(n)), 1e-300)
        facts["sequence_n_change"] = change
        if change <= 0.5 * smallest:
            smallest, smallest_at = change, facts["sequence_lps"]
        if record is not None:
            record(stage="sequence", n_change=change, multiplier=float(static_lp_solution(lp, out).multiplier))
        iterate, n_star = steps.best_iterate, np.minimum(n_star + SEQUENCE_RELAXATION * (n - n_star), 0.0)
        if change > checkpoint:
            continue
        checkpoint /= 2.0
        for factor in SEQUENCE_RECENTRING:
            if deadline.expired():
                break
            newton = InteriorFixedPoint(lp, coulomb_lp, units, tol=tol, max_iterations=SEQUENCE_NEWTON_ITERATIONS,
                                        deadline=deadline.end, ordering=ordering, layout=layout)
            newton.start_iterate = recentred_start(newton, iterate, factor)
            ended = newton.solve()
            facts["sequence_newton_runs"] += 1
            if record is not None:
                record(stage="sequence newton", recentring=factor, newton_iterations=ended.iterations,
                       kkt_residual=newton.best_error)
            if ended.status is Status.OPTIMAL:
                return newton, ended, facts
    return None, None, facts


def run_interior(lp, coulomb_lp, units, *, tol: float, max_iterations: int, deadline: Deadline = NEVER,
                 fold_weight: float, fold_off: float = FOLD_OFF, ordering: str = "auto", continuation: bool = True,
                 sequence: bool = True, layout=None):
    r"""The interior-point fixed point on the compiled step LP ``lp``: ``(RunOutput, facts)``.

    ``coulomb_lp``, ``units`` and ``layout`` as for :class:`InteriorFixedPoint`; ``deadline``: the run's.

    One :class:`InteriorFixedPoint` run with the aim term ``fold_weight``; if it does not
    end with a success (``OPTIMAL`` or ``ACCEPTABLE``) and ``fold_weight > 0``, a second
    run without the aim term in the time left.  If the last run stalls (neither ``OPTIMAL``
    nor out of time or iterations) and ``continuation``, :func:`continue_central_path` follows
    the central path from its best iterate in the time and iterations left (its steps count as
    iterations); its end is taken when its residuals of (3) are at most ``tol``.  If that fails too and
    ``sequence``, :func:`sequence_then_newton` runs in the time and iterations left (each LP step and each Newton
    run counts as one iteration).  A :class:`~blockmpec.solvers.engines.stopping.StoppingCriterion`
    records every iteration, continuation step and sequence step (``kkt_residual`` = max of the relative
    primal, dual and complementarity residuals of (3)) and the final test ``kkt_residual <= tol``.

    Returns
    -------
    RunOutput, dict
        Status ``CONVERGED`` (residuals of (3) at most ``tol``), ``ACCEPTABLE`` (at most
        1e-6 after the residuals stalled; the verifier decides), or the IPM's failure
        status; facts: ``lp_solves`` (interior runs), ``lp_time_s`` (``{"interior": s}``,
        continuation included), ``fold_weight_used``, ``continuation_steps`` and
        ``continuation_factorisations`` (0 when it was not needed), ``plan`` (what the block IPM chose).
    """
    import time

    from blockmpec import facts as fact_names
    from blockmpec.result import RunOutput, Solution, Status
    from blockmpec.solvers.engines.highs import static_lp_solution
    from blockmpec.solvers.engines.stopping import StoppingCriterion

    crit = StoppingCriterion(tol, max_iterations, deadline, measure_name="kkt_residual").start()
    runs, seconds = 0, 0.0
    weights = [fold_weight, 0.0] if fold_weight > 0 else [0.0]
    out = engine = None
    for weight in weights:
        if deadline.expired():
            break
        t0 = time.perf_counter()
        engine = InteriorFixedPoint(lp, coulomb_lp, units, fold_weight=weight, fold_off=fold_off, tol=tol,
                                    max_iterations=max_iterations, deadline=deadline.end, ordering=ordering,
                                    layout=layout)
        engine.criterion = crit
        out = engine.solve()
        seconds += time.perf_counter() - t0
        runs += 1
        if out.status.is_success or out.status is Status.TIME_LIMIT:
            break
    continued = None
    if (continuation and out is not None and out.status not in (Status.OPTIMAL, Status.TIME_LIMIT)
            and engine.best_iterate is not None and crit.remaining() > 0 and crit.iterations < max_iterations):
        t0 = time.perf_counter()
        engine.set_fold(0.0)

        def record(**values):
            crit.iterations += 1
            crit.record(kkt_residual=max(values["primal"], values["dual"], values["complementarity"]),
                        fold_weight=0.0, n_change=0.0, stage="continuation", **values)

        end, continued = continue_central_path(engine, engine.best_iterate, tol=tol, deadline=deadline,
                                               max_steps=max_iterations - crit.iterations, record=record)
        ended = engine.outcome_at(end)
        seconds += time.perf_counter() - t0
        continued["iterations"] = out.iterations  # of the stalled run
        if ended.status is Status.OPTIMAL:
            out = ended
    sequenced = None
    if (sequence and out is not None and out.status not in (Status.OPTIMAL, Status.TIME_LIMIT)
            and crit.remaining() > 0 and crit.iterations < max_iterations):
        t0 = time.perf_counter()

        def record_step(**values):
            crit.iterations += 1
            crit.record(fold_weight=0.0, **values)

        newton, ended, sequenced = sequence_then_newton(lp, coulomb_lp, units, tol=tol,
                                                        max_steps=max_iterations - crit.iterations,
                                                        deadline=deadline, ordering=ordering, record=record_step,
                                                        layout=layout)
        seconds += time.perf_counter() - t0
        if ended is not None:
            out, engine = ended, newton
    facts = {fact_names.LP_SOLVES: runs, fact_names.LP_TIME_S: {"interior": round(seconds, 6)},
             "fold_weight_used": engine.fold_weight if engine is not None else None,
             "continuation_steps": continued["steps"] if continued else 0,
             "continuation_factorisations": continued["factorisations"] if continued else 0,
             **(sequenced or {"sequence_lps": 0, "sequence_newton_runs": 0, "sequence_stalled": False})}
    if out is None:
        return RunOutput(Status.TIME_LIMIT, Solution(), crit.iterations, crit.trace,
                         "time limit reached before the interior run", extra=facts), facts
    sol = static_lp_solution(lp, out) if out.status.is_success else Solution()
    # the last iterate recorded is the one that met the tolerance (OPTIMAL); a stalled run returns its best
    error = {Status.OPTIMAL: engine.last_error, Status.ACCEPTABLE: engine.best_error}.get(out.status, np.inf)
    status = out.status
    if status is Status.OPTIMAL:
        status = Status.CONVERGED
    crit.check(error, multiplier=sol.multiplier, fold_weight=0.0)
    iterations = out.iterations if continued is None else continued["iterations"]
    message = out.message if status is not Status.CONVERGED else (
        f"interior-point fixed point: residuals of (3) {error:.1e} <= {tol:g} after {iterations} iterations")
    if sequenced is not None and status is Status.CONVERGED:
        message = (f"interior-point fixed point: residuals of (3) {error:.1e} <= {tol:g} by Newton on (3) after "
                   f"{sequenced['sequence_lps']} damped interior-point LP steps (||n - n*||/||n|| = "
                   f"{sequenced['sequence_n_change']:.1e}); the interior run from Mehrotra's start stalled")
    elif continued is not None:
        message += (f" (the interior run stalled there; continuation of its central path: {continued['steps']} "
                    f"steps to mu {continued['mu']:.1e}{'' if status is Status.CONVERGED else ', not converged'})")
    if sequenced is not None and status is not Status.CONVERGED:
        message += (f" (then {sequenced['sequence_lps']} damped interior-point LP steps to ||n - n*||/||n|| = "
                    f"{sequenced['sequence_n_change']:.1e}{' (stalled)' if sequenced['sequence_stalled'] else ''} and "
                    f"{sequenced['sequence_newton_runs']} Newton runs on (3): none reached a solution of (3))")
    if runs > 1 and not (sequenced is not None and status is Status.CONVERGED):
        message += " (second run, without the aim term: the first one failed)"
    return RunOutput(status, sol, crit.iterations, crit.trace, message, out.raw_status, extra=facts), facts


def _friction_difference(lp, coulomb_lp, normal_index: np.ndarray) -> sp.csr_array:
    """``coulomb_lp.A - lp.A`` after checking that the two compiled LPs have the same rows and columns and differ on
    the friction rows' normal-force columns only (the static LP (1) and the step LP (5) of one structure)."""
    same = (lp.A.shape == coulomb_lp.A.shape and lp.columns.keys() == coulomb_lp.columns.keys()
            and lp.rows.keys() == coulomb_lp.rows.keys()
            and all(np.array_equal(lp.columns[k], coulomb_lp.columns[k]) for k in lp.columns)
            and all(np.array_equal(lp.rows[k], coulomb_lp.rows[k]) for k in lp.rows))
    if not same:
        raise ValueError("interior fixed point: the static LP and the step LP have different rows or columns")
    difference = sp.csr_array(coulomb_lp.A - lp.A)
    difference.eliminate_zeros()
    coo = difference.tocoo()
    friction_rows = np.zeros(lp.A.shape[0], bool)
    friction_rows[lp.rows["friction"]] = True
    normal = np.zeros(lp.A.shape[1], bool)
    normal[lp.columns["x"][normal_index]] = True
    if not (np.all(friction_rows[coo.row]) and np.all(normal[coo.col])):
        raise ValueError("interior fixed point: the static LP and the step LP differ outside the friction rows' "
                         "normal forces")
    return difference
