r"""The one verifier: residuals of problem (3) for any solver's iterate.

This module is a deliberate second, independent statement of (3), written
directly on the operators ``E, N_u, N_f, V_f, f_d, f_l``.  The one statement of (3)
as a model is :mod:`blockmpec.formulations.mcp` (the Pyomo model), compiled once
per structure by :func:`blockmpec.formulations.compile_mcp`, and that compiled
object is what the solvers read.  The verifier shares nothing with them but the
operators, so a slip in the model or its compilation shows up as a residual here
instead of being checked against itself.  Keep it that way: do not rewrite this
module on top of :class:`~blockmpec.formulations.CompiledMCP`.

Given ``(lam, x, u, z_u, z_f)`` every residual is relative (scale-free):

=============================  =================================================================
``equilibrium``                ``max_i ||r_i|| / (|| |E_i| |x| || + ||f_d,i|| + |lam| ||f_l,i||)``, r = E x + f_d + lam f_l
``compatibility``              ``||g|| / (||E^T u|| + ||N_u z_u|| + ||V z_f||)``, g = E^T u + N_u z_u + V z_f
``normalisation``              ``|1 - f_l^T u|``
``unilateral_admissibility``   ``||(N_u^T x)_+|| / ||N_u^T x||``
``friction_admissibility``     ``||(N_f^T x)_+|| / ||N_f^T x||`` (the paper's Table 2 measure)
``local_admissibility``        ``max_k v_k / (|t_k| + |n_k| + 2|m_k|/L_k + w_k)``, see below
``multiplier_sign``            ``||(z)_-|| / ||z||`` over ``z = (z_u, z_f)``
``unilateral_complementarity`` ``|z_u|^T |N_u^T x| / min(||E^T u|| ||x||, max(1, |lam|))``
``friction_complementarity``   ``|z_f|^T |N_f^T x| / min(||E^T u|| ||x||, max(1, |lam|))``
=============================  =================================================================

The complementarity products are works (multiplier x constraint value); they are
measured against ``||E^T u|| ||x||``, the size of the mechanism's interface jumps
times the size of the forces, which is positive whenever ``f_l^T u = 1``.  (A
cosine such as ``|z|^T|s| / (||z|| ||s||)`` would flag a group of multipliers that
are all round-off, e.g. ``z_u ~ 1e-9`` in a pure sliding mechanism.)  Without ``u``
the denominator falls back to ``||z|| ||s||``.  The works are also read in units of
``lam``: with ``f_l^T u = 1``, equilibrium gives
``lam = -f_d^T u + z_u^T (N_u^T x) + z_f^T (V^T x)``, so a work ``W`` moves ``lam`` by
``W`` and ``W / max(1, |lam|)`` is a relative error of ``lam``.  That reading wins
when ``||E^T u|| ||x||`` is large, e.g. a tiny block on a huge one (a rocking slack
of 2.5e-9 on the tiny block against ``z_u ~ 1.8e5`` is a work of ~5e-4 in ``lam``,
which the product of norms, dominated by the huge block's forces, hid as 2e-9).

Equilibrium is measured block by block (``i`` runs over free blocks, three rows
each), relative to the absolute size of that block's own terms, and the worst
block is reported: a global norm would let a solver neglect a block a million
times lighter than the rest (its whole load is round-off in a global norm), and
the block's loads are data, so its reference scale is never noise.
Compatibility is measured globally: its scale is the mechanism itself, and
blocks at rest carry velocities that are round-off of the moving ones, which a
block-wise ratio would read as O(1) errors.

The two admissibility measures of the paper are global norms; a violation at
one light block disappears in them.  ``local_admissibility`` looks at each
interface: ``v_k = max((+-2m/L + n)_+, (+-t + mu n)_+ / (1 + mu))`` (force units)
against the interface's own forces plus ``w_k``, the smaller load
``||f_d,i|| + |lam| ||f_l,i||`` of its adjacent free blocks (a floor that keeps an
unloaded interface's round-off from raising an alarm).

``V`` is ``N_f`` for the associative problem and ``V_f`` (dilatancy ``tan(psi)``)
for the non-associative one.  Norms are Euclidean; a residual whose denominator
vanishes is 0 when its numerator does too.  The duality gap of the associative
problem, ``lam - (-f_d^T u)``, vanishes when these all do.
"""

from __future__ import annotations

import numpy as np

from blockmpec.operators import Operators
from blockmpec.result import Solution

RESIDUAL_NAMES = (
    "equilibrium",
    "compatibility",
    "normalisation",
    "unilateral_admissibility",
    "friction_admissibility",
    "local_admissibility",
    "multiplier_sign",
    "unilateral_complementarity",
    "friction_complementarity",
)


def _ratio(num: float, den: float) -> float:
    if den <= 0 or not np.isfinite(den):
        return 0.0 if num == 0 else float("inf")
    return float(num / den)


def _worst_triplet(residual: np.ndarray, terms: list[np.ndarray], dofs: int = 3) -> float:
    """``max_i ||residual_i|| / sum_t ||term_t,i||`` over consecutive groups ``i`` of ``dofs`` entries (a block's)."""
    if residual.size == 0:
        return 0.0
    num = np.linalg.norm(residual.reshape(-1, dofs), axis=1)
    den = sum(np.linalg.norm(t.reshape(-1, dofs), axis=1) for t in terms)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 0.0))
    return float(ratio.max())


def _local_admissibility(ops: Operators, x: np.ndarray, s_u: np.ndarray, s_f: np.ndarray, lam: float) -> float:
    """Per contact (three entries of ``x``): its worst yield row in force units over its forces plus the floor.

    The layout comes from the operators: the contact of each row (``unilateral_contact``, ``friction_contact``)
    and the arm turning a row or an entry of ``x`` into a force (``unilateral_arm``, ``force_arm``: 1 for forces,
    ``L/2`` for a 2D moment and its rows)."""
    c = ops.n_contacts
    if c == 0:
        return 0.0
    v_u = np.zeros(c)
    np.maximum.at(v_u, ops.unilateral_contact, np.maximum(s_u / ops.unilateral_arm, 0.0))
    v_f = np.zeros(c)
    np.maximum.at(v_f, ops.friction_contact, np.maximum(s_f, 0.0))
    v_f = v_f / (1 + ops.friction)
    dofs = ops.block_dofs
    load = (np.linalg.norm(ops.f_d.reshape(-1, dofs), axis=1)
            + abs(lam) * np.linalg.norm(ops.f_l.reshape(-1, dofs), axis=1))
    load = np.append(load, np.inf)  # index -1 (a fixed block) -> no floor from that side
    floor = np.minimum(load[ops.minus_dof], load[ops.plus_dof])
    size = np.abs(x) / ops.force_arm
    den = size[0::3] + size[1::3] + size[2::3] + floor
    return float((np.maximum(v_u, v_f) / den).max())


def positive_part_ratio(v: np.ndarray) -> float:
    """``||(v)_+|| / ||v||``: the share of ``v`` that violates ``v <= 0``."""
    return _ratio(np.linalg.norm(np.maximum(v, 0.0)), np.linalg.norm(v))


def _complementarity(z: np.ndarray, s: np.ndarray, scale: float | None) -> float:
    work = float(np.abs(z) @ np.abs(s))
    return _ratio(work, np.linalg.norm(z) * np.linalg.norm(s) if scale is None else scale)


#: the largest residual of a verified success unless the caller says otherwise (``solve``, ``compare``, the CLI)
VERIFY_TOL = 1e-6


def residuals(ops: Operators, sol: Solution, associative: bool) -> dict[str, float]:
    """All residuals of (3) at ``sol`` (only those whose fields are present).

    Parameters
    ----------
    ops : Operators
    sol : Solution
    associative : bool
        Use ``N_f`` (True) or ``V_f`` (False) as friction flow operator.

    Returns
    -------
    dict[str, float]
        Keys from :data:`RESIDUAL_NAMES`; a missing field makes its residuals absent.
    """
    out: dict[str, float] = {}
    lam, x, u, z_u, z_f = sol.multiplier, sol.x, sol.u, sol.z_u, sol.z_f
    if lam is not None and x is not None:
        r = ops.E @ x + ops.f_d + lam * ops.f_l
        terms = [abs(ops.E) @ np.abs(x), ops.f_d, abs(lam) * ops.f_l]
        out["equilibrium"] = _worst_triplet(r, terms, getattr(ops, "block_dofs", 3))
    if u is not None and z_u is not None and z_f is not None:
        flow = ops.N_f if associative else ops.V_f
        a, b, c = ops.E.T @ u, ops.N_u @ z_u, flow @ z_f
        scale = float(np.linalg.norm(a) + np.linalg.norm(b) + np.linalg.norm(c))
        out["compatibility"] = _ratio(np.linalg.norm(a + b + c), scale)
    if u is not None:
        out["normalisation"] = float(abs(1.0 - ops.f_l @ u))
    if x is not None:
        s_u = ops.N_u.T @ x
        s_f = ops.N_f.T @ x
        out["unilateral_admissibility"] = positive_part_ratio(s_u)
        out["friction_admissibility"] = positive_part_ratio(s_f)
        if lam is not None and ops.minus_dof is not None:
            out["local_admissibility"] = _local_admissibility(ops, x, s_u, s_f, lam)
    if z_u is not None and z_f is not None:
        z = np.concatenate([z_u, z_f])
        out["multiplier_sign"] = _ratio(np.linalg.norm(np.minimum(z, 0.0)), np.linalg.norm(z))
        if x is not None:
            scale = None if u is None else float(np.linalg.norm(ops.E.T @ u) * np.linalg.norm(x))
            if scale is not None and lam is not None:
                scale = min(scale, max(1.0, abs(float(lam))))
            out["unilateral_complementarity"] = _complementarity(z_u, s_u, scale)
            out["friction_complementarity"] = _complementarity(z_f, s_f, scale)
    return out
