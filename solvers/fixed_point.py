r"""``fixed-point``: the fixed-point method of Nodargi, Intrigila & Bisegna for the MCP (3).

Iteration variable: the interface normal forces ``n*`` (shape (c,)).  Each step
solves the modified associative LP (5)::

    max lam  s.t.  E x + f_d + lam f_l = 0,  N_u^T x <= 0,
                   |t_k| <= -n_k tan(psi) - n*_k (tan(phi) - tan(psi))

giving normal forces ``n = F(n*)``; then ``n* <- n* + omega (n - n*)``.  The method
stops when ``||n - n*|| <= tol ||n||`` -- on the normal forces, not on ``lam``.  At
``n = n*`` the friction rows read ``N_f^T x <= 0`` (Coulomb with ``tan(phi)``), and
the LP's duals ``(u, z_u, z_f)`` satisfy compatibility with ``V_f`` (friction
``tan(psi)``), so ``(lam, x, u, z_u, z_f)`` solves (3).  Any solution of (3) has
``lam`` at most the associative multiplier, because its ``x`` is feasible for (1).

The start ``n*_0`` (``start``) and the rule that picks one of a step's optimal force fields (``tie_break``) are
described with :class:`FixedPointOptions`.

``u, z_u, z_f`` come from the duals of the step LP; ``x`` from the tie-break LP (any
optimal primal and dual of one LP are complementary).  The setting ``fold_weight > 0`` folds a
weighted rule into the step LP's objective (one LP per step) and closes with exact
``"closest"`` steps (see :mod:`blockmpec.solvers.engines.lp_sequence`).

Every rule keeps the paper's convergence test on ``n``; which solution of (3) is
found depends on the start and the rule (the MCP has many), and the plain method's on which optimal vertex HiGHS
returns.

Update: ``relaxation`` ``omega`` as above, or Anderson mixing on ``n*`` (settings
``acceleration="anderson"``, depth ``memory``).  ``multistart > 1`` runs the
configured start and then seeded random starts (seeds ``seed + 1, ...``) and
returns the converged run with the lowest verified multiplier (residuals of (3)
at most the run's ``verify_tol``); nothing unverified is preferred over a verified run.

Defaults (``start="dead-load", tie_break="least-compressed", fold_weight=1e-4``) are those measured best by
``studies/lab/fixed_point_strategies.py`` (docs/methods/fixed-point.md and the performance pages give the tables).

Statuses: a step LP (5) is the iteration's own problem, not (3), so a step LP that fails (infeasible,
unbounded, ...) proves nothing of the structure.  The run then tries the other starts (:data:`FALLBACK_STARTS`,
then one random start) and returns the first that ends without a failed step; failing all, it reports
``numerical`` with every start's failure in the message, never ``infeasible``.  Only the associative LP (1) of a
start speaks for the structure (infeasible: no statically admissible field, so (3) has no solution), as for
``static-lp``.

Safeguards: ``n*`` is kept ``<= 0`` (a round-off tension within the LP tolerance
would give a negative cohesion and an infeasible next LP), and the LPs run with
primal/dual feasibility tolerances 1e-9 (light interfaces would otherwise show
~1e-7 relative violations).

Performance: both LPs are built and compiled once in ``setup`` and kept in HiGHS;
an iteration changes only row upper bounds (friction rows' cohesion, deviation
rows, the ``lam`` floor), so each re-solve is warm (dual simplex from the last basis).

Engines (``engine``).  Everything above is the ``"simplex"`` engine.  ``"interior"``
(:mod:`blockmpec.solvers.engines.interior_fixed_point`) replaces the sequence of LPs by one
interior-point run of Newton's method on (3), written as the step LP (5) with ``n* = n``
(Coulomb rows in the primal, ``tan(psi)`` flow in the dual); its aim term
(setting ``interior_weight``) plays the part of the least-compressed tie-break, and it stops when
the residuals of (3) are at most ``tol``; ``start``, ``tie_break``, ``fold_weight``,
``relaxation``, ``acceleration`` and ``multistart`` do not apply to it.  ``"auto"`` (the
default) takes the simplex engine below :data:`~blockmpec.solvers.plan.FIXED_POINT_INTERIOR_BLOCKS` free blocks (so the
small structures' answers are those of the simplex engine), the interior one from there
up, and falls back to the simplex engine in the time left when the interior run does not
reach a solution of (3) (residuals above the run's ``verify_tol``), in 2D below
:data:`~blockmpec.solvers.plan.FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS` free blocks (above, and in 3D, the simplex engine
cannot finish in the default time limit, and the interior run's failure is returned at once).  When Mehrotra's
iterates stall on the curved central path of (3), arclength continuation of the path from there (setting
``interior_continuation``, on by default; its steps count as iterations) closes the run; a run that still fails
falls back as above.  The measurements behind the thresholds and stages are in docs/methods/fixed-point.md and the
performance pages.

Options and settings.  The options (:class:`FixedPointOptions`) are what a user chooses; the engine settings
(:class:`FixedPointSettings`: the fold weight, Anderson acceleration, the HiGHS algorithm, the interior engine's aim
weight and continuation) are the measured defaults that experiments vary (``studies/lab``,
:func:`blockmpec.run_solver`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from blockmpec import facts as fact_names
from blockmpec import options as check
from blockmpec.facts import ASSOCIATIVE_MULTIPLIER
from blockmpec.method import SolverBase
from blockmpec.options import CommonOptions
from blockmpec.registry import register_solver
from blockmpec.result import RunOutput, Status
from blockmpec.solvers import plan

#: default weight of the interior engine's aim term (studies/lab/fixed_point_strategies.py)
INTERIOR_AIM_WEIGHT = 0.1
#: the starts tried, in this order, after a run whose step LP failed (then one random start)
FALLBACK_STARTS = ("dead-load", "associative", "zero")


@dataclass
class FixedPointOptions(CommonOptions):
    """Options of the fixed-point method.

    Start (``start``): ``n*_0`` = normal forces of the associative static LP (1)
    (``"associative"``), ``0`` (``"zero"``), a statically admissible field under the
    dead load alone (``"dead-load"``; the associative start when the structure does
    not stand under its dead load, i.e. ``lam < 0``), or the associative forces scaled per interface
    by seeded uniform factors in [0, 1] (``"random"``, ``seed``).

    Tie-break (``tie_break``).  The LP's optimal forces are often not unique (e.g.
    running-bond walls): HiGHS then returns some vertex, ``n`` can keep wandering
    between optimal vertices while ``lam`` has levelled off, and the plain iteration
    (``"none"``) does not meet its test.  A second LP
    (:func:`blockmpec.formulations.tie_break_lp`) keeps ``lam >= lam* - 1e-10 max(1,
    |lam*|)`` and picks one optimal force field:

    * ``"closest"``: closest to ``n*`` in the 1-norm.  Once ``n*`` is optimal for its
      own LP, ``F(n*) = n*`` exactly and the test is met.  With the associative start,
      whenever the associative forces are optimal for their own LP (5) they are a
      fixed point and the method stops after one step with the associative multiplier:
      a genuine solution of (3), but the largest one (``start="associative", tie_break="closest"``).
    * ``"least-compressed"``: minimises the next step's total cohesion
      ``-sum_k (tan(phi_k) - tan(psi_k)) n_k`` over the optimal forces (closeness
      breaks the remaining ties).  Less cohesion can only lower the next ``lam``.
    * ``"min-lambda"``: minimises the first-order estimate of the next step's ``lam``,
      ``sum_k zeta_k (tan(phi_k) - tan(psi_k)) (-n_k)``, where ``zeta_k`` are this step's
      friction multipliers (the LP sensitivity ``d lam / d cohesion_k``).
    * ``"on-oscillation"``: the plain step until ``||n - n*||`` stops decreasing, then
      ``"closest"``.
    """

    tol: float = field(default=1e-9, metadata={"help": "stop when ||n - n*|| <= tol ||n|| (normal forces)"})
    max_iterations: int = field(default=500, metadata={"help": "most LP steps (interior engine: iterations)"})
    relaxation: float = field(default=1.0, metadata={"help": "omega in (0, 1]: n* <- n* + omega (n - n*)"})
    start: str = field(default="dead-load", metadata={
        "help": "the first n*: dead-load (forces under the dead load alone) | associative | zero | random"})
    tie_break: str = field(default="least-compressed", metadata={
        "help": "which of a step's optimal forces to take: least-compressed | closest | min-lambda | "
                "on-oscillation | none"})
    seed: int = field(default=0, metadata={"help": "seed of the random start (run i of a multistart: seed + i)"})
    multistart: int = field(default=1, metadata={
        "help": "runs: the start above, then random starts; the lowest verified answer is returned"})
    engine: str = field(default="auto", metadata={
        "help": "auto (simplex below 500 free blocks, interior above) | simplex (warm LP steps) | interior (one "
                "interior-point run on (3))"})

    def __post_init__(self) -> None:
        from blockmpec.solvers.engines.lp_sequence import STARTS, TIE_BREAKS

        super().__post_init__()
        check.positive(self, "tol")
        check.integer(self, "max_iterations", minimum=1)
        check.interval(self, "relaxation", 0, 1, closed="right")
        check.choice(self, "start", STARTS)
        check.choice(self, "tie_break", TIE_BREAKS)
        check.integer(self, "seed", minimum=0)
        check.integer(self, "multistart", minimum=1)
        check.choice(self, "engine", plan.FIXED_POINT_ENGINES)


@dataclass
class FixedPointSettings:
    """Engine settings of the fixed-point method (experiments: ``studies/lab``; see the module docstring).

    Attributes
    ----------
    fold_weight : float
        0: a weighted tie-break runs as its own LP; > 0: folded into the step LP with this weight, then exact
        closest steps close the loop (:mod:`~blockmpec.solvers.engines.lp_sequence`).
    acceleration : {"none", "anderson"}
        Update of ``n*``; ``memory`` is Anderson's depth.
    algorithm : str
        HiGHS algorithm of the step LPs (:data:`~blockmpec.solvers.plan.BASIS_ALGORITHMS`).
    interior_weight : float
        Interior engine: weight of the least-compressed aim term (0: none).
    interior_continuation : bool
        Interior engine: when the run stalls, follow its central path by arclength continuation.
    interior_sequence : bool
        Interior engine: when the run (and its continuation) still fails, the damped sequence of interior-point step
        LPs, then Newton on (3) from near its fixed point
        (:func:`~blockmpec.solvers.engines.interior_fixed_point.sequence_then_newton`).
    """

    fold_weight: float = 1e-4
    acceleration: str = "none"
    memory: int = 5
    algorithm: str = "auto"
    interior_weight: float = INTERIOR_AIM_WEIGHT
    interior_continuation: bool = True
    interior_sequence: bool = True

    def __post_init__(self) -> None:
        from blockmpec.solvers.engines.lp_sequence import ACCELERATIONS

        check.interval(self, "fold_weight", 0, 1, closed="left")
        check.choice(self, "acceleration", ACCELERATIONS)
        check.integer(self, "memory", minimum=1)
        check.choice(self, "algorithm", plan.BASIS_ALGORITHMS)
        check.interval(self, "interior_weight", 0, 10, closed="both")
        check.boolean(self, "interior_continuation")
        check.boolean(self, "interior_sequence")


@register_solver
class FixedPoint(SolverBase):
    """Non-associative limit analysis by the fixed-point iteration on normal forces."""

    name = "fixed-point"
    problem = "non-associative"
    summary = ("fixed point on interface normal forces: warm modified associative LPs (5), or (engine auto, from "
               "500 free blocks) one interior-point run on (3)")
    requires = ("highspy", "pyomo")
    Options = FixedPointOptions
    Settings = FixedPointSettings

    def setup(self, ops):
        from blockmpec.solvers.engines.scaling import LoadUnits

        self.ops = ops
        self.units = LoadUnits.of(ops)
        self.engine = plan.fixed_point_engine(self.options.engine, ops.n_free_blocks)
        self.fallback = plan.fixed_point_fallback(self.options.engine, ops.n_free_blocks, ops.dim)
        #: after unverified LP steps: the interior engine, then (3D) the relaxed "closest" steps
        self.interior_next = (self.engine == "simplex"
                              and plan.fixed_point_interior_fallback(self.options.engine, ops.n_free_blocks))
        self.relaxed = plan.fixed_point_relaxed_fallback(self.options.engine, ops.n_free_blocks, ops.dim)
        other = self.fallback if self.engine == "interior" else self.interior_next
        self.plan = plan.fixed_point_plan(self.engine, other, self.options.start, self.options.tie_break,
                                          relaxed=self.relaxed)
        self.sequence = None
        if self.engine == "interior":
            from blockmpec.formulations import step_lps

            # the step LP (5) (tan(psi) rows) and the static LP (1) (tan(phi) rows): the interior engine's dual and
            # primal rows; the HiGHS sequence of a fallback is built only when it is needed
            self.interior_lps = step_lps(ops, tie_break=False, associative=True)
            return
        self._build_sequence()

    def _build_sequence(self, needs_lp1: bool = False) -> None:
        from blockmpec.formulations import step_lps
        from blockmpec.solvers.engines.lp_sequence import LPSequence

        o, st = self.options, self.settings
        needs_lp1 = needs_lp1 or o.start in ("associative", "dead-load", "random") or o.multistart > 1
        lps = step_lps(self.ops, alpha=0.0, tie_break=o.tie_break != "none", associative=needs_lp1)
        self.sequence = LPSequence(lps, self.units, alpha=0.0, tie_break=o.tie_break, algorithm=st.algorithm,
                                   fold_weight=st.fold_weight)

    def _verified(self, out: RunOutput) -> bool:
        """A success whose residuals of (3) are at most the run's ``verify_tol`` (:meth:`SolverBase.verified`)."""
        return out.status.is_success and self.verified(out.solution)

    def _run_once(self, start: str, seed: int, deadline):
        from blockmpec.solvers.engines.lp_sequence import run_sequence

        o, st = self.options, self.settings
        stall = plan.FIXED_POINT_STALL_STEPS if o.engine == "auto" else None
        return run_sequence(self.sequence, start=start, relaxation=o.relaxation, stop_on="normal", tol=o.tol,
                            max_iterations=o.max_iterations, deadline=deadline,
                            acceleration=st.acceleration, memory=st.memory, seed=seed, stall_steps=stall)

    def _run_interior(self, deadline, fallback: bool = True) -> RunOutput:
        """The interior engine; under ``engine="auto"`` an unverified run falls back to the simplex engine (unless
        ``fallback`` is False: the interior run is itself the simplex engine's fallback)."""
        from blockmpec.solvers.engines.interior_fixed_point import run_interior

        o, st = self.options, self.settings
        if getattr(self, "interior_lps", None) is None:
            from blockmpec.formulations import step_lps

            self.interior_lps = step_lps(self.ops, tie_break=False, associative=True)
        lps = self.interior_lps
        out, facts = run_interior(lps.step, lps.associative, self.units, tol=o.tol, max_iterations=o.max_iterations,
                                  deadline=deadline, fold_weight=st.interior_weight,
                                  continuation=st.interior_continuation, sequence=st.interior_sequence, layout=lps)
        out.extra[fact_names.ENGINE] = "interior"
        if o.engine != "auto" or not fallback or self._verified(out) or deadline.expired():
            return out
        if not self.fallback:
            where = (f"from {plan.FIXED_POINT_SIMPLEX_FALLBACK_BLOCKS:,} free blocks" if self.ops.dim == 2 else
                     f"in 3D from {plan.FIXED_POINT_INTERIOR_BLOCKS:,} free blocks")
            out.message = (f"{out.message} (no simplex fallback: {where} the simplex engine does not converge within "
                           "the default time limit)")
            return out
        # the interior run did not reach a solution of (3): the simplex engine, in the time left
        self.plan.start("simplex")
        self._build_sequence()
        simplex = self._run_simplex(deadline)
        simplex.extra[fact_names.LP_SOLVES] = simplex.extra.get(fact_names.LP_SOLVES, 0) + facts[fact_names.LP_SOLVES]
        simplex.extra[fact_names.LP_TIME_S] = {**simplex.extra.get(fact_names.LP_TIME_S, {}), **facts[fact_names.LP_TIME_S]}
        simplex.extra[fact_names.ENGINE] = "interior, then simplex"
        simplex.extra["interior_status"] = out.status.value
        simplex.trace = [{**rec, fact_names.ENGINE: "interior"} for rec in out.trace] + simplex.trace
        simplex.message = f"{simplex.message} (after an interior run that ended {out.status.value}: {out.message})"
        return simplex

    def _run_relaxed(self, out: RunOutput, deadline) -> RunOutput:
        """After unverified LP steps in 3D: the relaxed "closest" sequence of the plan, in the time left."""
        from blockmpec.formulations import step_lps
        from blockmpec.solvers.engines.lp_sequence import LPSequence, run_sequence

        self.plan.start("relaxed")
        o, st = self.options, self.settings
        omega = min(o.relaxation, plan.FIXED_POINT_3D_RELAXATION)
        lps = step_lps(self.ops, alpha=0.0, tie_break=True, associative=o.start != "zero")
        sequence = LPSequence(lps, self.units, alpha=0.0, tie_break="closest", algorithm=st.algorithm)
        relaxed, facts = run_sequence(sequence, start=o.start, relaxation=omega, stop_on="normal", tol=o.tol,
                                      max_iterations=o.max_iterations, deadline=deadline, seed=o.seed)
        interior = {"interior_status": out.extra["interior_status"]} if "interior_status" in out.extra else {}
        engine = "simplex, then interior, then relaxed simplex" if interior else "simplex, then relaxed simplex"
        relaxed.extra = {**sequence.facts(), fact_names.ENGINE: engine, "first_status": out.status.value,
                         "start": facts["start_used"], **interior}
        relaxed.trace = out.trace + [{**rec, "iteration": rec["iteration"] + out.iterations} for rec in relaxed.trace]
        relaxed.iterations += out.iterations
        if relaxed.status is Status.CONVERGED:
            relaxed.message = (f"normal forces converged in {relaxed.iterations} LP steps, the last "
                               f"{relaxed.iterations - out.iterations} relaxed by {omega} with the closest tie-break "
                               f"(the first {out.iterations} ended: {out.message})")
        return relaxed

    def run(self, deadline) -> RunOutput:
        self.plan.start(self.engine)
        if self.engine == "interior":
            return self._run_interior(deadline)
        # with the interior engine planned next, the LP steps leave it its share of the time
        share = plan.FIXED_POINT_STEPS_SHARE if self.interior_next else 1.0
        out = self._run_simplex(deadline.within(share * deadline.remaining()))
        if self._verified(out) or out.status is Status.INFEASIBLE or deadline.expired():
            return out  # infeasible: proven by the associative LP (1), which no engine can change
        if self.interior_next:
            # the LP steps did not reach a solution of (3) (they wander on irregular stone walls and on the dome):
            # the interior engine, in the time left
            self.plan.start("interior")
            interior = self._run_interior(deadline, fallback=False)
            if self._verified(interior):
                return self._after_simplex(interior, out)
            out.message = f"{out.message} (the interior engine, tried next, ended {interior.status.value}: " \
                          f"{interior.message})"
            out.extra["interior_status"] = interior.status.value
        if self.relaxed and not deadline.expired():
            return self._run_relaxed(out, deadline)
        return out

    @staticmethod
    def _after_simplex(interior: RunOutput, out: RunOutput) -> RunOutput:
        """The verified interior run after unverified LP steps ``out``: both runs' LP counts, times and traces."""
        interior.extra[fact_names.ENGINE] = "simplex, then interior"
        interior.extra["simplex_status"] = out.status.value
        for kind, seconds in out.extra.get(fact_names.LP_TIME_S, {}).items():
            interior.extra[fact_names.LP_TIME_S][kind] = seconds
        interior.extra[fact_names.LP_SOLVES] += out.extra.get(fact_names.LP_SOLVES, 0)
        interior.trace = [{**rec, fact_names.ENGINE: "simplex"} for rec in out.trace] + interior.trace
        interior.message = f"{interior.message} (after LP steps that ended {out.status.value}: {out.message})"
        return interior

    def _run_other_starts(self, out: RunOutput, facts: dict, deadline) -> tuple[RunOutput, dict]:
        """After a run whose step LP failed (``facts["step_failure"]``): the other deterministic starts
        (:data:`FALLBACK_STARTS`, the one used left out), then one seeded random start, until one ends without a
        failed step.  Failing all, a ``NUMERICAL`` result whose message lists every start's failure: a failed
        iteration is no proof that (3) has no solution, so the run never says ``infeasible`` for it."""
        o = self.options
        failures = [f"{facts['start_used']} start: {out.message}"]
        tried = {facts["start_used"], o.start}
        if self.sequence.assoc_highs is None:  # the other starts need the associative LP (1)
            self._build_sequence(needs_lp1=True)
        for start, seed in [(s, o.seed) for s in FALLBACK_STARTS if s not in tried] + [("random", o.seed + 1)]:
            if deadline.expired():
                break
            other, other_facts = self._run_once(start, seed, deadline)
            if other_facts["step_failure"] is None:
                other_facts["start_used"] = other_facts["start_used"] if start != "random" else f"random (seed {seed})"
                other_facts["failed_starts"] = failures
                return other, other_facts
            failures.append(f"{other_facts['start_used']} start: {other.message}")
        out.status = Status.NUMERICAL
        out.message = ("no start reached a solution of (3) (" + "; ".join(failures) + "); a failed iteration does not "
                       "show that (3) has no solution")
        facts["failed_starts"] = failures
        return out, facts

    def _run_simplex(self, deadline) -> RunOutput:
        o = self.options
        out, facts = self._run_once(o.start, o.seed, deadline)
        if facts["step_failure"] is not None:
            out, facts = self._run_other_starts(out, facts, deadline)
        runs = [(out.solution.multiplier, facts["start_used"], o.seed, out.status.value)]
        if o.multistart > 1:
            # further runs from seeded random starts; keep the lowest verified solution of (3)
            def verified(run_out):
                return run_out.status is Status.CONVERGED and self._verified(run_out)

            best, best_facts = (out, facts) if verified(out) else (None, None)
            for i in range(1, o.multistart):
                if deadline.expired():
                    break
                other, other_facts = self._run_once("random", o.seed + i, deadline)
                runs.append((other.solution.multiplier, "random", o.seed + i, other.status.value))
                if verified(other) and (best is None or other.solution.multiplier < best.solution.multiplier):
                    best, best_facts = other, other_facts
            if best is not None:
                out, facts = best, best_facts
            out.extra = self.sequence.facts()
            out.extra["multistart_runs"] = runs
        out.extra[fact_names.ENGINE] = "simplex"
        out.extra["tie_break_failures"] = facts["tie_break_failures"]
        out.extra["start"] = facts["start_used"]
        if facts["lam_start"] is not None:
            out.extra[ASSOCIATIVE_MULTIPLIER] = facts["lam_start"]
        if out.status is Status.CONVERGED:
            last = out.trace[-1]
            out.message = (f"normal forces converged in {out.iterations} LP steps: ||n - n*||/||n|| = "
                           f"{last['n_change']:.2e} <= {o.tol:g}")
            if o.multistart > 1:
                out.message += f" (lowest verified of {len(runs)} runs)"
        if facts["tie_break_failures"]:
            out.message += (f" ({facts['tie_break_failures']} tie-break LP(s) failed; "
                            "the step LP's own forces were used there)")
        if facts.get("failed_starts"):
            out.extra["failed_starts"] = facts["failed_starts"]
            if out.status is not Status.NUMERICAL:  # (a NUMERICAL message lists them already)
                out.message += f" (from the {facts['start_used']} start, after: {'; '.join(facts['failed_starts'])})"
        return out
