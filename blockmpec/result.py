"""One result type for every solver, with an explicit status.

A solver returns a :class:`Solution` (its raw iterate).  :func:`blockmpec.solve`
times it, runs the shared verifier (:mod:`blockmpec.verify`) and wraps everything
in a :class:`Result`.  A solver's claimed success is downgraded to
``Status.NUMERICAL`` when the verifier disagrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np

from blockmpec.errors import StructureError

if TYPE_CHECKING:
    from blockmpec.report import StructureMap


class Status(str, Enum):
    """Why a solve stopped and what its point is."""

    OPTIMAL = "optimal"  #: certified optimum (LP optimal, MILP gap closed)
    LOCALLY_OPTIMAL = "locally_optimal"  #: local optimum of a non-convex problem (NLP)
    CONVERGED = "converged"  #: an iterative method met its stopping test (a solution of the MCP)
    ACCEPTABLE = "acceptable"  #: Ipopt's "solved to acceptable level"
    ITERATION_LIMIT = "iteration_limit"
    TIME_LIMIT = "time_limit"
    INFEASIBLE = "infeasible"
    UNBOUNDED = "unbounded"  #: the static LP is unbounded: the live load never causes collapse
    #: the backend proved the LP (or MILP) infeasible *or* unbounded without deciding which
    #: (HiGHS's ``kUnboundedOrInfeasible``; a kinematic LP that has no mechanism): for the static LP,
    #: the structure may be unstable under dead load, or no collapse mechanism exists
    INFEASIBLE_OR_UNBOUNDED = "infeasible_or_unbounded"
    NUMERICAL = "numerical"  #: the solver claimed success but the verifier disagrees
    ERROR = "error"
    SKIPPED = "skipped"  #: the method does not fit the case, or its backend is missing

    @property
    def is_success(self) -> bool:
        """True for the statuses that claim a valid answer."""
        return self in _SUCCESS

    def __str__(self) -> str:
        return self.value


_SUCCESS = frozenset({Status.OPTIMAL, Status.LOCALLY_OPTIMAL, Status.CONVERGED, Status.ACCEPTABLE})


@dataclass
class Solution:
    """A solver's raw iterate; any field may be ``None`` if the solver has none.

    *Internal*: the arrays are those of the canonical problem (:mod:`blockmpec.operators`):
    canonical order of blocks and interfaces, canonical frame (``x`` along the live load) and
    scaled units.  Read them in the structure's terms with :attr:`Result.forces` and
    :attr:`Result.mechanism` (:mod:`blockmpec.report`).

    Attributes
    ----------
    multiplier : float
        Collapse load multiplier ``lam``.
    x : ndarray, shape (3c,)
        Interface forces ``(t, n, m)`` per interface.
    u : ndarray, shape (3b,)
        Collapse mechanism (block velocities), normalised ``f_l^T u = 1``.
    z_u, z_f : ndarray, shape (2c,)
        Unilateral and friction flow multipliers.
    """

    multiplier: float | None = None
    x: np.ndarray | None = None
    u: np.ndarray | None = None
    z_u: np.ndarray | None = None
    z_f: np.ndarray | None = None

    def __repr__(self) -> str:
        """The multiplier and each array's shape (the arrays themselves run to thousands of numbers)."""
        parts = [f"multiplier={self.multiplier!r}"]
        for name in ("x", "u", "z_u", "z_f"):
            value = getattr(self, name)
            parts.append(f"{name}={'None' if value is None else f'<array {np.shape(value)}>'}")
        return f"Solution({', '.join(parts)})"


@dataclass
class RunOutput:
    """What a method's run (and each engine it drives) returns: its claimed status and raw iterate, before the
    shared verifier; :func:`blockmpec.solve` turns it into a :class:`Result`."""

    status: Status
    solution: Solution = field(default_factory=Solution)
    iterations: int = 0
    trace: list[dict[str, Any]] = field(default_factory=list)
    message: str = ""
    raw_status: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class Result:
    """The outcome of one solve.

    The answer in the structure's own ids, order, frame and units is in :attr:`multiplier`,
    :attr:`forces` and :attr:`mechanism` (DataFrames, see :mod:`blockmpec.report`).
    :attr:`solution` is internal: the solver's arrays in the canonical problem's order, frame
    (``x`` along the live load) and scaled units, as the verifier checks them.

    Attributes
    ----------
    method : str
        Registered method name (``static-lp``, ``fixed-point`` ...).
    status : Status
    problem : {"associative", "non-associative"}
        Which problem the result answers; it decides the flow operator used by the verifier.
    multiplier : float or None
        Collapse load multiplier ``lam``.
    solution : Solution
        Internal: the raw iterate of the canonical problem (canonical frame, scaled units,
        canonical order); read :attr:`forces` and :attr:`mechanism` instead.
    residuals : dict[str, float]
        Relative residuals from :func:`blockmpec.verify.residuals`.
    verified : bool
        True when every residual is at most ``verify_tol``.
    build_time_s, solve_time_s : float
        Set-up (model building, compiling, loading) and solve wall times, measured apart.
    iterations : int
    trace : list of dict
        Per-iteration records (method-specific keys, always ``iteration`` and ``time_s``).
    message, raw_status : str
        Human-readable explanation and the backend's native status.
    options : dict
        The options the method ran with.
    extra : dict
        Open-ended diagnostics (gap, bounds, number of LP solves...).
    structure_map : StructureMap or None
        How :attr:`solution` maps onto the structure (set by :func:`blockmpec.solve`; references
        to the structure's interface arrays and the canonical permutations, no operator).
    """

    method: str
    status: Status
    problem: str
    multiplier: float | None = None
    solution: Solution = field(default_factory=Solution)
    residuals: dict[str, float] = field(default_factory=dict)
    verified: bool = False
    verify_tol: float = 1e-6
    build_time_s: float = 0.0
    solve_time_s: float = 0.0
    iterations: int = 0
    trace: list[dict[str, Any]] = field(default_factory=list)
    message: str = ""
    raw_status: str = ""
    options: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    structure_map: StructureMap | None = field(default=None, repr=False, compare=False)

    def __repr__(self) -> str:
        """One line a REPL can show: what was solved, how well, how fast (the arrays are in :attr:`solution`,
        the full record, with the whole message, in :meth:`to_dict`)."""
        lam = "None" if self.multiplier is None else f"{self.multiplier:.10g}"
        residual = self.max_residual
        check = (f"verified={self.verified} (max residual {residual:.1e}, tolerance {self.verify_tol:g})"
                 if math.isfinite(residual) else f"verified={self.verified} (no residuals)")
        message = self.message if len(self.message) <= 200 else self.message[:199] + "…"
        return (f"Result(method={self.method!r}, problem={self.problem!r}, status={self.status.value!r}, "
                f"multiplier={lam}, {check}, iterations={self.iterations}, build_time_s={self.build_time_s:.3g}, "
                f"solve_time_s={self.solve_time_s:.3g}, message={message!r})")

    @property
    def success(self) -> bool:
        """True only when the status claims success *and* the verifier agrees."""
        return self.status.is_success and self.verified

    @property
    def forces(self):
        """Interface forces in the structure's ids, order, frame and units (built on each access).

        A :class:`pandas.DataFrame`, one row per interface of the structure (row ``k`` is its
        interface ``k``), columns ``interface, minus, plus, start_x, start_y, end_x, end_y, shear,
        normal, moment``: the force ``shear tau + normal nu`` and the moment about the midpoint that
        the plus block exerts on the minus block, ``nu = rot90(end - start) / L`` from minus into
        plus, ``tau`` = ``nu`` rotated by -90 degrees; ``normal <= 0`` in compression; forces in
        the units of ``density x area``, moments times the length unit.  An interface between two
        fixed blocks has NaN forces (it carries no unknown).  Empty (same columns) when the result
        has no forces; for a result that is not a :attr:`success`, the solver's last iterate, as
        unverified as its multiplier.  See :func:`blockmpec.report.forces_frame`.

        Raises
        ------
        StructureError
            When the result has forces but no :attr:`structure_map` (operators not assembled
            from a structure).
        """
        from blockmpec.report import forces_frame

        return forces_frame(self._structure_map_for("x"), self.solution)

    @property
    def mechanism(self):
        """The collapse mechanism in the structure's ids, order, frame and units (built on each access).

        A :class:`pandas.DataFrame`, one row per free block in the structure's block order,
        columns ``block, u_x, u_y, rotation``: the velocity of the block's centroid and its
        rotation rate (counter-clockwise positive), *normalised* so that the live load's power is
        one, ``f_l^T u = 1`` in the structure's units (one force unit times one length unit per
        unit time).  Empty (same columns) when the result has no mechanism; for a result that is
        not a :attr:`success`, the solver's last iterate.  See
        :func:`blockmpec.report.mechanism_frame`.

        Raises
        ------
        StructureError
            When the result has a mechanism but no :attr:`structure_map`.
        """
        from blockmpec.report import mechanism_frame

        return mechanism_frame(self._structure_map_for("u"), self.solution)

    def _structure_map_for(self, name: str) -> StructureMap | None:
        """:attr:`structure_map`, which the solution's array ``name`` needs when it has one."""
        if getattr(self.solution, name) is not None and self.structure_map is None:
            raise StructureError(
                f"result of {self.method!r}: no structure map (its operators were not assembled from a Structure), "
                "so its solution cannot be reported in a structure's ids and units; solve a Structure or "
                "bm.assemble(structure)")
        return self.structure_map

    @property
    def max_residual(self) -> float:
        """Largest residual (NaN when there are none)."""
        vals = [v for v in self.residuals.values() if v is not None]
        return max(vals) if vals else math.nan

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays); the keys of ``blockmpec solve --json``."""
        return {
            "method": self.method,
            "problem": self.problem,
            "status": self.status.value,
            "success": self.success,
            "verified": self.verified,
            "multiplier": _json_float(self.multiplier),
            "residuals": {k: _json_float(v) for k, v in self.residuals.items()},
            "max_residual": _json_float(self.max_residual),
            "time_s": self.solve_time_s,
            "build_time_s": self.build_time_s,
            "iterations": self.iterations,
            "message": self.message,
            "raw_status": self.raw_status,
            "options": {k: _jsonable(v) for k, v in self.options.items()},
            "extra": {k: _jsonable(v) for k, v in self.extra.items()},
        }


def is_finite_number(v: Any) -> bool:
    """True for a value that converts to a finite float (None, NaN, inf and text are not)."""
    try:
        return v is not None and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


def _json_float(v: float | None) -> float | None:
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _jsonable(v: Any) -> Any:
    if isinstance(v, (np.floating, float)):
        return _json_float(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    return v
