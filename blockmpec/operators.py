r"""Sparse operators of the rigid-block limit-analysis problems.

Unknowns
--------
* interface forces ``x``, shape ``(3c,)``: ``x[3k:3k+3] = (t_k, n_k, m_k)``
  (shear, normal, moment about the interface midpoint; see :mod:`blockmpec.geometry`
  for the sign conventions);
* block velocities ``u``, shape ``(3b,)`` over the *free* blocks:
  ``u[3i:3i+3] = (u_x, u_y, theta)`` at the block centroid;
* flow multipliers ``z_u >= 0``, shape ``(2c,)`` (rocking about either end) and
  ``z_f >= 0``, shape ``(2c,)`` (sliding either way).

Operators (scipy.sparse CSR)
----------------------------
``E`` (3b x 3c)
    equilibrium: ``E x + f_d + lam f_l = 0``.  ``E = -B^T`` where ``B u`` is the
    velocity jump (plus block relative to minus block) at each interface, in the
    interface frame ``(tau, nu, rotation)``.
``N_u`` (3c x 2c)
    unilateral (no-tension) constraints ``N_u^T x <= 0``:
    ``m + n L/2 <= 0`` and ``-m + n L/2 <= 0``, i.e. ``|m| <= -n L/2``.  The row
    ``n <= 0`` of the paper is their half-sum, so it is redundant and left out
    (the cone of admissible jumps ``N_u z_u`` is unchanged).
``N_f`` (3c x 2c)
    friction constraints ``N_f^T x <= 0``: ``t + mu n <= 0`` and ``-t + mu n <= 0``,
    with ``mu = tan(phi)``.
``V_f`` (3c x 2c)
    friction flow directions: ``N_f`` with ``tan(psi)`` in place of ``tan(phi)``.

Scaling
-------
The solvers see a nondimensional problem: lengths are divided by
``length_scale`` (median size of the free blocks) and forces by ``force_scale``
(mean weight of the free blocks).  ``lam`` is unchanged; ``x`` holds ``t, n`` in
units of ``force_scale`` and ``m`` in units of ``force_scale * length_scale``
(:meth:`Operators.forces_to_physical` converts back).  Without this, a wall of
1 km blocks (weights ~1e6, moments ~1e9) defeats the solvers' absolute
tolerances.

Compatibility (flow rule) reads ``E^T u + N_u z_u + V_f z_f = 0`` and the
normalisation ``f_l^T u = 1``.  Interfaces between two fixed blocks carry no
unknown that matters and are dropped at assembly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from blockmpec.geometry import Structure, block_sizes


@dataclass(frozen=True, eq=False)
class Operators:
    """The assembled problem data; see the module docstring for the maths.

    Attributes
    ----------
    E : csr_array, shape (3b, 3c)
    N_u, N_f, V_f : csr_array, shape (3c, 2c)
    f_d, f_l : ndarray, shape (3b,)
    free_blocks : ndarray of int, shape (b,)
        Structure block index of each free block (row block ``i`` of ``E``).
    interface_ids : ndarray of int, shape (c,)
        Structure interface index of each kept interface.
    length : ndarray, shape (c,)
        Interface lengths ``L`` (in units of ``length_scale``).
    length_scale, force_scale : float
        The units of the nondimensional problem (see the module docstring).
    minus_dof, plus_dof : ndarray of int, shape (c,)
        Free-block index (row block of ``E``) of each interface's minus and plus
        block, -1 for a fixed block.
    friction, dilatancy : ndarray, shape (c,)
        ``tan(phi)`` and ``tan(psi)`` per interface.
    """

    E: sp.csr_array
    N_u: sp.csr_array
    N_f: sp.csr_array
    V_f: sp.csr_array
    f_d: np.ndarray
    f_l: np.ndarray
    free_blocks: np.ndarray
    interface_ids: np.ndarray
    length: np.ndarray
    friction: np.ndarray
    dilatancy: np.ndarray
    length_scale: float = 1.0
    force_scale: float = 1.0
    minus_dof: np.ndarray | None = None
    plus_dof: np.ndarray | None = None

    def forces_to_physical(self, x: np.ndarray) -> np.ndarray:
        """Interface forces ``x`` in the structure's units (``t, n`` x force_scale, ``m`` x force*length)."""
        out = np.asarray(x, float) * self.force_scale
        out[2::3] *= self.length_scale
        return out

    @property
    def n_interfaces(self) -> int:
        """Number of interfaces ``c``."""
        return int(self.length.shape[0])

    @property
    def n_free_blocks(self) -> int:
        """Number of free blocks ``b``."""
        return int(self.free_blocks.shape[0])

    @property
    def is_associative(self) -> bool:
        """True when ``tan(psi) == tan(phi)`` on every interface (then ``V_f == N_f``)."""
        return bool(np.all(self.friction == self.dilatancy))

    def friction_operator(self, coefficient: np.ndarray | float) -> sp.csr_array:
        """``N_f`` built with another friction coefficient per interface (e.g. ``tan(psi)``)."""
        c = self.n_interfaces
        coef = np.broadcast_to(np.asarray(coefficient, float), (c,))
        return _friction_matrix(coef)


def shear(x: np.ndarray) -> np.ndarray:
    """Shear forces ``t`` from ``x``, shape (c,)."""
    return x[0::3]


def normal(x: np.ndarray) -> np.ndarray:
    """Normal forces ``n`` (compression negative) from ``x``, shape (c,)."""
    return x[1::3]


def moment(x: np.ndarray) -> np.ndarray:
    """Moments ``m`` from ``x``, shape (c,)."""
    return x[2::3]


def _cross(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    return r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]


def _friction_matrix(coef: np.ndarray) -> sp.csr_array:
    c = coef.shape[0]
    k = np.arange(c)
    rows = np.concatenate([3 * k, 3 * k, 3 * k + 1, 3 * k + 1])
    cols = np.concatenate([2 * k, 2 * k + 1, 2 * k, 2 * k + 1])
    vals = np.concatenate([np.ones(c), -np.ones(c), coef, coef])
    return sp.csr_array((vals, (rows, cols)), shape=(3 * c, 2 * c))


def assemble(structure: Structure) -> Operators:
    """Assemble ``E, N_u, N_f, V_f, f_d, f_l`` for a structure (vectorised).

    Parameters
    ----------
    structure : Structure

    Returns
    -------
    Operators
    """
    s = structure
    itf = s.interfaces
    keep = ~(s.fixed[itf.minus] & s.fixed[itf.plus])
    ids = np.flatnonzero(keep)
    minus, plus = itf.minus[ids], itf.plus[ids]
    c = ids.size
    free_blocks = np.flatnonzero(~s.fixed)
    b = free_blocks.size
    dof = np.full(s.n_blocks, -1)
    dof[free_blocks] = np.arange(b)

    sizes = block_sizes(s.vertices, s.n_vertices)[free_blocks]
    length_scale = float(np.median(sizes)) if b else 1.0
    weight = s.weight[free_blocks]
    force_scale = float(weight.mean()) if b else 1.0
    mid = itf.midpoint[ids] / length_scale
    tau = itf.tangent[ids]
    nu = itf.normal[ids]
    length = itf.length[ids] / length_scale
    centroid = s.centroid / length_scale

    # E: generalised force (Fx, Fy, M about centroid) of x_k on the minus block; minus that on plus.
    rows, cols, vals = [], [], []
    k = np.arange(c)
    for side, blocks in ((1.0, minus), (-1.0, plus)):
        has = dof[blocks] >= 0
        kk = k[has]
        r0 = 3 * dof[blocks[has]]
        arm = mid[has] - centroid[blocks[has]]
        t_dir, n_dir = tau[has], nu[has]
        rows += [r0, r0 + 1, r0 + 2, r0, r0 + 1, r0 + 2, r0 + 2]
        cols += [3 * kk, 3 * kk, 3 * kk, 3 * kk + 1, 3 * kk + 1, 3 * kk + 1, 3 * kk + 2]
        vals += [
            side * t_dir[:, 0],
            side * t_dir[:, 1],
            side * _cross(arm, t_dir),
            side * n_dir[:, 0],
            side * n_dir[:, 1],
            side * _cross(arm, n_dir),
            side * np.ones(kk.size),
        ]
    E = sp.csr_array(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * b, 3 * c)
    )
    E.sum_duplicates()
    E.eliminate_zeros()

    rows_u = np.concatenate([3 * k + 1, 3 * k + 1, 3 * k + 2, 3 * k + 2])
    cols_u = np.concatenate([2 * k, 2 * k + 1, 2 * k, 2 * k + 1])
    vals_u = np.concatenate([length / 2, length / 2, np.ones(c), -np.ones(c)])
    N_u = sp.csr_array((vals_u, (rows_u, cols_u)), shape=(3 * c, 2 * c))

    friction = s.interface_friction()[ids]
    dilatancy = s.interface_dilatancy()[ids]
    N_f = _friction_matrix(friction)
    V_f = _friction_matrix(dilatancy)

    weight = weight / force_scale
    f_d = np.zeros(3 * b)
    f_l = np.zeros(3 * b)
    f_d[1::3] = -weight
    f_l[0::3] = s.live_direction * s.live_factor * weight
    for pl in s.point_loads:
        i = dof[pl.block]
        if i < 0:
            continue
        target = f_l if pl.kind == "live" else f_d
        arm = np.asarray(pl.point, float) / length_scale - centroid[pl.block]
        fx, fy = np.asarray(pl.force, float) / force_scale
        target[3 * i] += fx
        target[3 * i + 1] += fy
        target[3 * i + 2] += arm[0] * fy - arm[1] * fx
    return Operators(
        E=E,
        N_u=N_u,
        N_f=N_f,
        V_f=V_f,
        f_d=f_d,
        f_l=f_l,
        free_blocks=free_blocks,
        interface_ids=ids,
        length=length,
        friction=friction,
        dilatancy=dilatancy,
        length_scale=length_scale,
        force_scale=force_scale,
        minus_dof=dof[minus],
        plus_dof=dof[plus],
    )
