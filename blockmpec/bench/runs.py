"""The records of a comparison and the arithmetic every part of the comparator shares (its bottom module).

:class:`CaseRun` and :class:`MethodRun` name what runs; :func:`relative_error` and the tolerances grade it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from blockmpec import Structure
from blockmpec.cases import get_case

#: absolute tolerance (times max(1, |lam_ref|)) of the anomaly checks
ANOMALY_TOL = 1e-7
#: relative tolerance of "the same multiplier as the reference": a verified run within it of its reference
#: solves the case (:func:`blockmpec.bench.profiles.solved`); a verified run below a reference of source "best"
#: by more than it is a new best
MATCH_TOL = 1e-6


def _finite(v: Any) -> bool:
    """True for a value that converts to a finite float (None, NaN, inf and text are not)."""
    try:
        return v is not None and not isinstance(v, bool) and math.isfinite(float(v))
    except (TypeError, ValueError):
        return False

def parametrised_label(name: str, params: Mapping[str, Any]) -> str:
    """``name`` or ``name[k=v,...]``: a case or method with its non-default settings."""
    if not params:
        return name
    return f"{name}[{','.join(f'{k}={_short(v)}' for k, v in params.items())}]"


def _short(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v)) if not math.isinf(v) else str(v)
    return str(v)


@dataclasses.dataclass(frozen=True)
class CaseRun:
    """One case of a comparison: its label, built-in name (None for a bare structure) and parameters."""

    label: str
    name: str | None
    params: dict[str, Any]
    structure: Structure | None = None

    def build(self) -> Structure:
        """The structure (built from the name and parameters unless given)."""
        if self.structure is not None:
            return self.structure
        return get_case(self.name).build(**self.params)


@dataclasses.dataclass(frozen=True)
class MethodRun:
    """One method of a comparison: its label, registered name, options and (optionally) engine settings.

    ``settings`` is an instance of the method's ``Settings`` dataclass (e.g.
    ``blockmpec.solvers.milp.MILPSettings(lifting="rlt")``, for experiments on the engines): the solve then runs
    as ``blockmpec.run_solver(get_solver(name)(settings=settings, **options), structure)``; None runs
    :func:`blockmpec.solve` with the options alone.
    """

    label: str
    name: str
    options: dict[str, Any]
    settings: Any = None


def relative_error(lam: float, ref: float) -> float:
    """``(lam - ref) / |ref|`` (signed); for ``ref = 0``: 0 when ``lam = 0``, else ``+-inf``."""
    if ref != 0:
        return (lam - ref) / abs(ref)
    return 0.0 if lam == ref else math.copysign(math.inf, lam - ref)


def _true(flag: Any) -> bool:
    """A true flag of a table cell (NaN and None are false)."""
    return bool(flag) and not (isinstance(flag, float) and math.isnan(flag))
