"""The built-in cases with their reference multipliers, each with its source.

A :class:`ReferenceCase` is a built-in case at fixed parameters.  Its references, for the two problems:

* ``associative``: the associative collapse multiplier, the optimum of the static LP (1).  Its source, by rank: the
  closed form (:func:`blockmpec.cases.closed_form`: the paper's Sect. 3 for the two blocks, ``min(mu, b/h)`` for
  one block, ``tan(slope + min(phi, atan(b/h)))`` for the 3D block), else the static LP solved by ``static-lp`` (HiGHS, verified; ``kinematic-lp``, the dual LP (2), when
  the method under test is ``static-lp`` itself);
* ``minimum``: the least multiplier over the solutions of the non-associative problem (3), the optimum of the MPEC
  (4).  By rank: the closed form (Sect. 3: ``mu`` if ``mu <= 1/eta``, else ``1/eta``), else the certificate of
  ``milp`` (a closed branch-and-bound gap) within :data:`REFERENCE_TIME_LIMIT_S`, else only a lower bound (``milp``'s
  dual bound when its gap stays open), else none;
* ``published``: values printed in a paper, to the digits printed (the round arch of the paper's Table 1).

Every verified multiplier of the associative problem equals ``associative``; every verified multiplier of (3) lies
in ``[minimum, associative]`` (the forces of a solution of (3) are admissible for the LP (1)).  References that need
a solve are computed on first use and kept for the process (about 0.1 s per case for the LP, 0.2-2 s for a
certificate of the quick cases).
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from blockmpec.cases import build_case, closed_form
from blockmpec.geometry import Structure

#: seconds a reference solve (the LP, the certificate) may take; a certificate not found by then leaves a bound
REFERENCE_TIME_LIMIT_S = 60.0
#: the problems, as :attr:`blockmpec.SolverBase.problem` names them
ASSOCIATIVE, NON_ASSOCIATIVE = "associative", "non-associative"


@dataclass(frozen=True)
class Reference:
    """A reference multiplier and where it comes from.

    Attributes
    ----------
    value : float or None
        None when there is none.
    source : str
        Where the value comes from (a closed form, a paper's table, a method's verified solve or certificate).
    exact : bool
        False for a bound only (a certificate whose gap stayed open) or a value rounded as published.
    method : str or None
        The registered method that computed it (None for a closed form or a published value).
    """

    value: float | None
    source: str
    exact: bool = True
    method: str | None = None


@dataclass(frozen=True)
class ReferenceCase:
    """A built-in case at fixed parameters and its reference multipliers (see the module docstring).

    Attributes
    ----------
    label : str
        ``name[k=v,...]`` (or a short label of its own).
    case : str
        The built-in case (:data:`blockmpec.cases.CASES`).
    params : mapping
        Its parameters (the others at their defaults).
    published : mapping
        Problem -> ``(value, decimals, source)`` of a published multiplier (empty for most cases).
    quick : bool
        In the quick set (small; :func:`reference_cases` with ``quick=True``).
    kind : str
        ``"closed-form"`` for the cases with a closed form for both problems, else ``"case"``.
    """

    label: str
    case: str
    params: Mapping[str, Any] = field(default_factory=dict)
    published: Mapping[str, tuple[float, int, str]] = field(default_factory=dict)
    quick: bool = True

    @property
    def kind(self) -> str:
        return "closed-form" if all(self.closed_form(p) is not None for p in (ASSOCIATIVE, NON_ASSOCIATIVE)) \
            else "case"

    @property
    def structure(self) -> Structure:
        """The structure (built once per process)."""
        return _structure(self.case, _key(self.params))

    def closed_form(self, problem: str) -> float | None:
        """The closed-form multiplier of ``problem`` (for the non-associative one, the minimum), or None."""
        return closed_form(self.case, problem, **self.params)

    @property
    def associative(self) -> Reference:
        """The associative multiplier (closed form, else the static LP)."""
        return self.associative_for(None)

    def associative_for(self, method: str | None) -> Reference:
        """The associative multiplier, computed by another method than ``method`` (a method is not its own
        reference): ``static-lp``, or ``kinematic-lp`` when ``method`` is ``static-lp``."""
        value = self.closed_form(ASSOCIATIVE)
        if value is not None:
            return Reference(value, f"closed form ({_closed_form_source(self.case, ASSOCIATIVE)})")
        lp = "kinematic-lp" if method == "static-lp" else "static-lp"
        return _lp_reference(self.case, _key(self.params), lp)

    @property
    def minimum(self) -> Reference:
        """The least multiplier of the non-associative problem (closed form, else a certificate of ``milp``; when
        its gap stays open, ``exact`` is False and ``value`` is only a lower bound)."""
        return self.minimum_for(None)

    def minimum_for(self, method: str | None) -> Reference:
        """The minimum, computed by another method than ``method`` (no certificate when ``method`` is ``milp``)."""
        value = self.closed_form(NON_ASSOCIATIVE)
        if value is not None:
            return Reference(value, f"closed form ({_closed_form_source(self.case, NON_ASSOCIATIVE)})")
        if method == "milp":
            return Reference(None, "none (the certificate would be milp's own)", exact=False)
        return _certified_minimum(self.case, _key(self.params))

    def bounds(self, problem: str, method: str | None = None) -> tuple[Reference, Reference]:
        """``(lower, upper)`` references of a verified multiplier of ``problem`` (both the associative one for the
        associative problem), computed by other methods than ``method``."""
        upper = self.associative_for(method)
        return (upper, upper) if problem == ASSOCIATIVE else (self.minimum_for(method), upper)

    def solution_known(self, problem: str, method: str | None = None) -> Reference | None:
        """A verified solution of ``problem`` on this case, by another method than ``method`` where one is needed (so
        a claim that the case has none is false), or None when none is known."""
        upper = self.associative_for(method)
        if problem == ASSOCIATIVE:
            return upper if upper.value is not None else None
        value = self.closed_form(NON_ASSOCIATIVE)
        if value is not None:
            return Reference(value, f"closed form ({_closed_form_source(self.case, NON_ASSOCIATIVE)})")
        res = _milp_run(self.case, _key(self.params))
        return Reference(float(res.multiplier), "a verified solution of (3) by milp", method="milp") \
            if res.verified and res.multiplier is not None else None


def _key(params: Mapping[str, Any]) -> str:
    return json.dumps(dict(params), sort_keys=True)


def _closed_form_source(case: str, problem: str) -> str:
    if case == "two-blocks":
        return "paper Sect. 3, " + ("mechanisms A1-A3" if problem == ASSOCIATIVE else "mechanisms NA1-NA2, minimum")
    if case == "block-3d":
        return "one 3D block on a fixed base: lam = tan(slope + min(phi, atan(b/h))), min(mu, d/h) out of plane"
    return "one block on a fixed base, statically determinate: lam = min(mu, b/h)"


@functools.lru_cache(maxsize=None)
def _structure(case: str, key: str) -> Structure:
    return build_case(case, **json.loads(key))


@functools.lru_cache(maxsize=None)
def _lp_reference(case: str, key: str, method: str) -> Reference:
    from blockmpec.solver import solve

    res = solve(_structure(case, key), method, time_limit=REFERENCE_TIME_LIMIT_S)
    if not res.success:
        return Reference(None, f"none ({method}: {res.status.value})", exact=False, method=method)
    what = "static LP (1)" if method == "static-lp" else "kinematic LP (2)"
    return Reference(float(res.multiplier), f"{what} by {method}, verified", method=method)


@functools.lru_cache(maxsize=None)
def _milp_run(case: str, key: str):
    from blockmpec.solver import solve

    return solve(_structure(case, key), "milp", time_limit=REFERENCE_TIME_LIMIT_S)


def _certified_minimum(case: str, key: str) -> Reference:
    from blockmpec.result import Status

    res = _milp_run(case, key)
    if res.status is Status.OPTIMAL and res.verified:
        return Reference(float(res.multiplier), "certified minimum of (4) by milp (gap closed)", method="milp")
    bound = res.extra.get("bound")
    if bound is not None and math.isfinite(bound):
        return Reference(float(bound), f"lower bound of milp ({res.status.value}, gap open)", exact=False,
                         method="milp")
    return Reference(None, f"none (milp: {res.status.value})", exact=False, method="milp")


#: the round arch of the paper's Table 1 (its geometry: 10 voussoirs, radius 1, thickness 0.15, mu = 0.65)
_TABLE_1 = "Nodargi, Intrigila, Bisegna, Table 1 (all methods)"


def _label(case: str, params: Mapping[str, Any]) -> str:
    return f"{case}[{','.join(f'{k}={v:g}' if isinstance(v, float) else f'{k}={v}' for k, v in params.items())}]" \
        if params else case


def _cases() -> list[ReferenceCase]:
    quick = [
        # the paper's two-block problem (Sect. 3) at points of each associative mechanism: (3, 0.65) A2-1 (the
        # paper's example: 0.41973 and the minimum 1/3), (2, 0.3) A1 (sliding; minimum mu), (5, 1.2) A2-2 and
        # (3, 2) A3 (minimum 1/eta at both)
        ReferenceCase(_label("two-blocks", p), "two-blocks", p)
        for p in ({"eta": 3.0, "mu": 0.65}, {"eta": 2.0, "mu": 0.3}, {"eta": 5.0, "mu": 1.2}, {"eta": 3.0, "mu": 2.0})
    ] + [
        ReferenceCase("single-block[rocking]", "single-block", {"width": 1.0, "height": 2.0, "mu": 0.65}),
        ReferenceCase("single-block[sliding]", "single-block", {"width": 1.0, "height": 1.0, "mu": 0.3}),
        # 3D: one block overturning out of plane (about its long bottom edge: depth/height = 0.25) and sliding up a
        # base inclined by 10 degrees (tan(10 deg + atan(0.3)) = 0.50293...)
        ReferenceCase("block-3d[out-of-plane]", "block-3d", {"live_direction": [0.0, 1.0, 0.0]}),
        ReferenceCase("block-3d[inclined]", "block-3d", {"slope": 10.0, "mu": 0.3, "height": 1.0}),
        ReferenceCase("round-arch", "round-arch", {},
                      {ASSOCIATIVE: (0.16034, 5, _TABLE_1), NON_ASSOCIATIVE: (0.16034, 5, _TABLE_1)}),
    ] + [
        ReferenceCase(_label(case, p), case, p) for case, p in (
            ("arch-on-buttresses", {"n_voussoirs": 6, "buttress_courses": 4}),
            ("wall", {"courses": 4, "blocks_per_course": 2, "bond": "stack"}),  # minimum below the associative
            ("stone-wall", {"width": 1.0, "height": 0.6, "stone_size": 0.4}),  # 5 stones
        )
    ]
    larger = [
        ReferenceCase(_label(case, p), case, p, quick=False) for case, p in (
            ("ferris-tinloi", {}),
            ("arch-on-buttresses", {}),
            ("wall", {}),
            ("stone-wall", {}),
        )
    ] + [ReferenceCase("wall[courses=3,blocks_per_course=2,opening]", "wall",
                       {"courses": 3, "blocks_per_course": 2, "openings": [[0.5, 0.5, 1.5, 1.0]]}, quick=False)]
    return quick + larger


_CASES = _cases()


def reference_cases(quick: bool = True) -> dict[str, ReferenceCase]:
    """The reference cases by label: the quick set (every 2D built-in case but ``ferris-tinloi``, and the 3D block;
    small), or with ``quick=False`` also the larger ones (``ferris-tinloi``, the default sizes)."""
    return {c.label: c for c in _CASES if c.quick or not quick}
