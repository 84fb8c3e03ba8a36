r"""The search stage of ``milp`` (:mod:`blockmpec.solvers.milp`): its two engines and the certificate.

* :func:`bnb_search`: the branch and bound over the complementarity pairs on the lifted LP
  (:mod:`~blockmpec.solvers.engines.complementarity_bnb`), started from the run's incumbent; its points are exact
  pattern points already, its bound is in ``lam``.
* :func:`bigm_search`: HiGHS's branch and cut on the big-M model (:func:`build_mip`,
  :mod:`~blockmpec.formulations.mpec_milp`), started from the incumbent (:func:`start_vector`); the pattern of its
  point (``y_i = 1``: active) is finished by the piece LPs.  When that pattern admits no mechanism (the model's
  optimum has ``tau = f_l^T u = 0``, a point of the relaxation that is no solution of (3)), the restriction
  ``tau >= tau_restart`` is solved for a genuine point while the relaxation's bound stands.

Both end in :func:`certify`, which compares the best exact point (the engine's or the incumbent) with the bound.
"""

from __future__ import annotations

import time

import numpy as np

from blockmpec.deadline import Deadline
from blockmpec.result import RunOutput, Solution, Status

#: the engine's dual bound and the exact multiplier of the same pattern may differ by this much (times
#: ``max(1, |lam|)``) without any real gap (the engines solve to their feasibility tolerances)
CERTIFICATE_TOL = 1e-7
#: a slack within this (times the largest bound) of its big-M is "at its bound"
ACTIVE_TOL = 1e-7


def lifting_options(form, lifting: str, slack_max: np.ndarray | None) -> dict:
    """The arguments of :class:`~blockmpec.solvers.engines.complementarity_bnb.ComplementarityBnB` that ``lifting``
    (``friction``, ``mechanism``, ``all``, ``rlt``, ``rlt-full``) sets: which copies of the static field, the
    products ``lam u``, the forces tied to ``u`` (``x u^T``: normal and tangential ones for ``"rlt"``, all for
    ``"rlt-full"``), and the LP-proven slack bounds (``slack_max``, when every one is finite), which the ``rlt``
    liftings do without."""
    usable = slack_max is not None and np.all(np.isfinite(slack_max))
    return dict(slack_max=None if lifting.startswith("rlt") or not usable else slack_max,
                all_copies=lifting in ("all", "rlt", "rlt-full"), lam_mechanism=lifting != "friction",
                force_mechanism={"rlt": np.sort(np.r_[form.n, form.t]), "rlt-full": True}.get(lifting))


# ---------------------------------------------------------------------------------------------- the lifted-LP search
def branch_and_bound(solver, bd, **overrides):
    """The branch and bound of :mod:`~blockmpec.solvers.engines.complementarity_bnb` on ``solver``'s structure.

    Parameters
    ----------
    solver : MILPSolver
        After :meth:`~blockmpec.solvers.milp.MILPSolver.setup`.
    bd : MPECBounds
        The LP bounds: ``lam_lower <= lam <= lam_upper``, pairs with ``slack_max_i = 0`` fixed active and pairs
        with ``z_max_i = 0`` fixed idle.
    **overrides
        Replace any keyword argument of :class:`~.complementarity_bnb.ComplementarityBnB` (studies and tests).

    Returns
    -------
    ComplementarityBnB
        Not yet run; the settings' ``lifting``, ``root_lp`` and ``lam_branching``, its leaves finished by
        :meth:`~blockmpec.solvers.milp.MILPSolver.polish`.
    """
    from blockmpec.solvers.engines.complementarity_bnb import ComplementarityBnB

    slack_max = bd.slack_max if bd.slack_max is not None else np.full(solver.form.n_pairs, np.inf)
    z_max = bd.z_max if bd.z_max is not None else np.ones(solver.form.n_pairs)
    kwargs = dict(fixed_active=slack_max == 0.0, fixed_idle=z_max == 0.0,
                  lam_branching=solver.settings.lam_branching, root_lp=solver.root_lp,
                  **lifting_options(solver.form, solver.lifting, slack_max))
    kwargs.update(overrides)
    return ComplementarityBnB(solver.form, solver.work, bd.lam_lower, bd.lam_upper,
                              lambda active: solver.polish(active)[0], **kwargs)


def bnb_search(solver, bd, stop, deadline: Deadline, extra: dict) -> RunOutput:
    """Stages 3-4 with engine="bnb", within ``deadline``."""
    tb = time.perf_counter()
    bnb = branch_and_bound(solver, bd)
    t_build = time.perf_counter() - tb
    run, best = bnb.solve(deadline, stop.best, t0=stop.t_start)
    stop.trace += [dict(r, iteration=len(stop.trace) + k, stage="search") for k, r in enumerate(run.trace)]
    stop.offer(best, "bnb")
    stop.raise_bound(run.dual_bound if np.isfinite(run.dual_bound) else None)
    extra.update({"build_time_s": t_build, "search_time_s": run.time_s, "nodes": run.nodes,
                  "lp_solves_search": bnb.n_lps, "root_interior_time_s": bnb.ipm_time,
                  "root_crossover_runs": bnb.crossover_runs,
                  "engine_multiplier": None if best is None else best.multiplier})
    if stop.best is None:
        return _bnb_without_point(solver, stop, run, bnb, extra)
    return certify(solver, stop, run, bd, extra)


def _bnb_without_point(solver, stop, run, bnb, extra: dict) -> RunOutput:
    """engine="bnb" ended without a point of (3).  An infinite bound with every node closed on a proof (each
    infeasible node LP pruned on a checked Farkas certificate of the lifted relaxation, which holds every solution
    of (3); no leaf closed by a pattern LP that HiGHS alone called infeasible) proves that (3) has no solution."""
    if run.status is Status.TIME_LIMIT:
        return solver._finish(stop, Status.TIME_LIMIT, extra, "time limit: no point of (3) found", run.raw_status,
                              run.nodes)
    if np.isinf(run.dual_bound) and run.dual_bound > 0 and run.status in (Status.OPTIMAL, Status.INFEASIBLE):
        extra["infeasibility_proofs"] = bnb.farkas_proofs
        if bnb.unproven_closures == 0:
            return solver._finish(stop, Status.INFEASIBLE, extra,
                                  f"(3) has no solution: the lifted relaxation, which holds every solution of (3), is "
                                  f"infeasible in every branch ({run.nodes} node(s); {bnb.farkas_proofs} node LP(s) "
                                  "pruned on a checked Farkas certificate)", "infeasible", run.nodes)
        return solver._finish(stop, Status.ERROR, extra,
                              f"no point of (3) found: every branch closed, {bnb.unproven_closures} of them by a "
                              "pattern LP that HiGHS called infeasible without a checked certificate, so this is not a "
                              "proof that (3) has no solution", run.raw_status, run.nodes)
    return solver._finish(stop, Status.ERROR, extra, f"no point of (3) found ({run.message})", run.raw_status,
                          run.nodes)


# ---------------------------------------------------------------------------------------------- the big-M model
def build_mip(solver, bd, tau_min: float = 0.0):
    """The big-M MILP of (4) (:func:`~blockmpec.formulations.mpec_milp.mpec_milp`) with ``M_i = bigm_scale
    slack_max_i``; a pair whose ``slack_max_i = 0`` is fixed active (``y_i = 1``) and one whose ``z_max_i = 0``
    fixed idle.  ``tau_min``: lower bound of ``tau = f_l^T u`` (the restart after a point with ``tau = 0``)."""
    from blockmpec.formulations import mpec_milp as fm

    M = solver.settings.bigm_scale * bd.slack_max
    mip = fm.mpec_milp(solver.form, bd, sense=solver.options.sense, bigm=M, envelope=solver.settings.envelope,
                       tau_min=tau_min)
    fixed_active = bd.slack_max == 0.0  # the pair row is active on all of S
    fixed_idle = (bd.z_max == 0.0) & ~fixed_active  # z_i = 0 in every normalised mechanism
    y = mip.columns["y"]
    mip.col_lower[y[fixed_active]] = 1.0
    mip.col_upper[y[fixed_idle]] = 0.0
    return mip


def start_vector(solver, mip, sol: Solution | None) -> np.ndarray | None:
    """The MILP's column values at a solution ``sol`` of (3) (in the MILP's units): its start for the engine.

    ``(u, z)`` divided by ``1^T z`` (the model's normalisation), ``tau = f_l^T u``, ``y_i = [z_i > 0]`` and the
    products ``p = x_r z_i``, ``q = lam tau`` where the model has those columns; None if ``sol`` is None."""
    if sol is None:
        return None
    form = solver.form
    w = form.pack(sol)
    zsum = float(w[form.z].sum())
    w[form.u] /= zsum
    w[form.z] /= zsum
    v = np.zeros(mip.n_columns)
    v[: w.size] = w
    tau = float(form.f_l @ w[form.u])
    v[mip.columns["tau"]] = tau
    v[mip.columns["y"]] = (w[form.pair_column] > 0).astype(float)
    if "p" in mip.columns:
        xr, zi, _ = mip.work_products
        v[mip.columns["p"]] = w[xr] * w[zi]
        v[mip.columns["q"]] = sol.multiplier * tau
    return v


def _highs(solver, mip, deadline: Deadline, start, t0: float):
    from blockmpec.solvers.engines.mip import solve_highs

    opt, st = solver.options, solver.settings
    return solve_highs(mip, deadline, rel_gap=opt.mip_rel_gap, abs_gap=st.mip_abs_gap,
                       feasibility_tol=st.feasibility_tol, threads=opt.threads, start=start, t0=t0)


def bigm_search(solver, bd, stop, deadline: Deadline, extra: dict) -> RunOutput:
    """Stages 3-4 with engine="highs", within ``deadline``; without every big-M proven there is no model to
    solve, and the run stops with its best point and bound."""
    if not bd.models_complete:
        out_of_time = deadline.expired()
        return solver._finish(stop, Status.TIME_LIMIT if out_of_time else Status.ERROR, extra,
                              "the big-M model needs every slack bound proven, and the bound LPs did not prove them "
                              + ("within the time limit" if out_of_time else "all (an LP failed)"))
    tb = time.perf_counter()
    mip = build_mip(solver, bd)
    extra.update({"build_time_s": time.perf_counter() - tb, "bigm": mip.bigm.tolist(),
                  "bigm_scale": solver.settings.bigm_scale, "n_binaries": int(mip.integer.sum())})
    run = _highs(solver, mip, deadline, start_vector(solver, mip, stop.best), stop.t_start)
    stop.trace += [dict(r, iteration=len(stop.trace) + k, stage="search") for k, r in enumerate(run.trace)]
    if solver.settings.bigm_scale >= 1:  # a restriction's bound is no bound of (3)
        stop.raise_bound(mip.objective_sign * run.dual_bound)
    extra.update({"search_time_s": run.time_s, "nodes": run.nodes})
    if not run.has_point:
        return _without_point(solver, stop, run, extra)
    active = mip_pattern(mip, run.point)
    if solver.pattern_mechanism(active) is None and not deadline.expired():
        run, active = _restart(solver, bd, stop, deadline, extra, run)
        if run is None:
            return solver._finish(stop, Status.NUMERICAL if stop.best is None else Status.LOCALLY_OPTIMAL, extra,
                                  "the relaxation's optimum has tau = 0 and the restriction found no point",
                                  "tau_restart")
    slack = solver.form.slack(run.point[: solver.form.n_columns])
    scale = float(max(bd.slack_max.max(initial=0.0), 1e-300))
    at_bound = ~active & (slack >= mip.bigm - ACTIVE_TOL * solver.settings.bigm_scale * scale) & (mip.bigm > 0)
    extra.update({"bigm_active": np.flatnonzero(at_bound).tolist(), "engine_multiplier": float(run.point[solver.form.lam]),
                  "n_active_pairs": int(active.sum())})
    solver.plan.start("polish")
    sol, why = solver.polish(active)
    if sol is None:
        extra["polish"] = why
    stop.offer(sol, "highs")
    return certify(solver, stop, run, bd, extra)



def mip_pattern(mip, v: np.ndarray) -> np.ndarray:
    """The active pairs of a point of the big-M model: ``y_i = 1``."""
    return v[mip.columns["y"]] >= 0.5


def _restart(solver, bd, stop, deadline: Deadline, extra: dict, run):
    """The relaxation's optimum has ``tau = 0`` (its pattern admits no mechanism with ``f_l^T u > 0``): the
    restriction ``tau >= tau_restart`` has only points of (3); ``(its run, its pattern)`` or ``(None, None)``."""
    tau_restart = 1e-6 * (bd.tau_max if np.isfinite(bd.tau_max) else 1.0)
    extra["tau_restart"] = tau_restart
    mip = build_mip(solver, bd, tau_min=tau_restart)
    rerun = _highs(solver, mip, deadline, None, stop.t_start)
    extra["restart_nodes"] = rerun.nodes
    if not rerun.has_point:
        return None, None
    # the restriction's status decides, the relaxation's bound (kept in stop) stands
    return rerun, mip_pattern(mip, rerun.point)


def _without_point(solver, stop, run, extra: dict) -> RunOutput:
    """HiGHS ended without a point: infeasibility is (3)'s when the model is a relaxation with proven bounds."""
    if run.status is Status.INFEASIBLE and stop.best is None:
        if solver.settings.bigm_scale < 1:  # a restriction of (3): its infeasibility proves nothing of (3)
            return solver._finish(stop, Status.ERROR, extra,
                                  f"the MILP is infeasible with bigm_scale = {solver.settings.bigm_scale} < 1: the "
                                  "scaled slack bounds cut off every solution of (3); the proven bounds (bigm_scale = "
                                  "1) are needed", run.raw_status, run.nodes)
        return solver._finish(stop, Status.INFEASIBLE, extra,
                              "(3) has no solution: HiGHS proves the mixed-integer model infeasible, and the model "
                              "holds every solution of (3) (its big-M and multiplier bounds are LP-proven)",
                              run.raw_status, run.nodes)
    if run.status is Status.INFEASIBLE and solver.settings.bigm_scale < 1:
        return solver._finish(stop, Status.ERROR, extra,
                              f"the MILP is infeasible with bigm_scale = {solver.settings.bigm_scale} < 1 (a "
                              "restriction of (3))", run.raw_status, run.nodes)
    if run.status is Status.TIME_LIMIT:
        return solver._finish(stop, Status.TIME_LIMIT, extra, "time limit in HiGHS's branch and cut", run.raw_status,
                              run.nodes)
    return solver._finish(stop, Status.ERROR, extra, run.message, run.raw_status, run.nodes)


# ---------------------------------------------------------------------------------------------- certificate
def certify(solver, stop, run, bd, extra: dict) -> RunOutput:
    """The run's status from the engine's ``run`` and ``stop`` (best exact point, bound): ``OPTIMAL`` only when the
    engine closed its gap, the best point meets the bound within the certificate tolerance, no slack sits at its
    big-M, ``bigm_scale >= 1`` and every bound LP was optimal."""
    opt, st = solver.options, solver.settings
    lam = stop.best.multiplier
    tol = CERTIFICATE_TOL * max(1.0, abs(lam))
    gap = stop.sign * (lam - stop.bound)
    closed = gap <= max(st.mip_abs_gap, opt.mip_rel_gap * abs(lam)) + tol
    word = "maximum" if stop.sign < 0 else "minimum"
    if "engine_multiplier" in extra and extra["engine_multiplier"] is not None:
        extra["polished_minus_engine"] = lam - extra["engine_multiplier"]
    if gap < -tol:  # a point of (3) beyond the relaxation's bound is impossible
        status, msg = Status.NUMERICAL, f"the point lam {lam:.10g} lies beyond the bound {stop.bound:.10g}: certificate void"
    elif run.status is Status.OPTIMAL and closed and bd.verified:
        status, msg = Status.OPTIMAL, f"certified global {word}; {run.nodes} nodes"
    elif run.status is Status.TIME_LIMIT:
        status, msg = Status.TIME_LIMIT, "time limit"
    elif run.status is Status.OPTIMAL:
        status, msg = Status.LOCALLY_OPTIMAL, "the engine closed its gap but the exact point does not meet its bound"
        if "tau_restart" in extra:
            msg += (f" (the relaxation's optimum had tau = 0; lam is the {opt.sense}imum over tau >= "
                    f"{extra['tau_restart']:.3g}, not certified globally)")
    else:
        status, msg = Status.ERROR, run.message
    if extra.get("bigm_active"):
        status = Status.TIME_LIMIT if run.status is Status.TIME_LIMIT else Status.LOCALLY_OPTIMAL
        msg = (f"{len(extra['bigm_active'])} slack(s) at their big-M bound (bigm_scale = {st.bigm_scale}): the point "
               f"solves (3) but the certificate of global {word[:5]}ality is void. {msg}")
    elif st.bigm_scale < 1 and status is not Status.ERROR:
        status = Status.LOCALLY_OPTIMAL if status is Status.OPTIMAL else status
        msg = (f"bigm_scale = {st.bigm_scale} < 1: the slack bounds are not proven, so the certificate of global "
               f"{word[:5]}ality is void (no slack reached them). {msg}")
    return solver._finish(stop, status, extra, msg, run.raw_status, run.nodes)
