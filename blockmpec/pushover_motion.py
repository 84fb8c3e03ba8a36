r"""The configuration update of :func:`blockmpec.pushover`: block poses and their rigid motion along a mechanism.

A configuration is the pose of every block (:class:`Poses`): a rotation ``angle`` about its undeformed centroid
``c0`` and a ``shift``, so that a point ``X`` of the undeformed structure is at ``R(angle) (X - c0) + c0 + shift``.

Free block ``i`` has the twist ``(v_i, omega_i)`` of the mechanism (centroid velocity and angular velocity, in the
structure's axes and units: :func:`mechanism_twists`).  It moves rigidly by the exact motion of that twist over a
parameter ``s``, a rotation by ``a_i = s omega_i`` about its instantaneous centre (so rotations are exact, not first
order):

.. math:: c_i \leftarrow c_i + s\,V(a_i)\,v_i, \qquad
          V(a) = \frac{1}{a}\begin{pmatrix} \sin a & -(1-\cos a)\\ 1-\cos a & \sin a\end{pmatrix},
          \qquad \varphi_i \leftarrow \varphi_i + a_i,

(:func:`motion`, :func:`moved`), one ``s`` for all blocks, solved (Brent, :func:`parameter_for`) so that the control
point reaches the next step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from blockmpec.geometry import Structure


@dataclass
class Poses:
    """Rigid placement of every block: ``x = R(angle) (X - c0) + c0 + shift`` for a point ``X`` of the
    undeformed structure (``c0`` its block's undeformed centroid)."""

    angle: np.ndarray  # (n,)
    shift: np.ndarray  # (n, 2)

    def copy(self) -> Poses:
        return Poses(self.angle.copy(), self.shift.copy())


def rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` (..., 2) by ``angle`` (broadcast to ``v[..., 0]``)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def place(points: np.ndarray, block: np.ndarray, poses: Poses, c0: np.ndarray) -> np.ndarray:
    """Current position of undeformed points ``points`` (m, 2) of blocks ``block`` (m,)."""
    return rotate(points - c0[block], poses.angle[block]) + c0[block] + poses.shift[block]


def unplace(points: np.ndarray, block: np.ndarray, poses: Poses, c0: np.ndarray) -> np.ndarray:
    """Undeformed position of current points (inverse of :func:`place`)."""
    return rotate(points - c0[block] - poses.shift[block], -poses.angle[block]) + c0[block]


def vertices_at(structure: Structure, poses: Poses, c0: np.ndarray) -> np.ndarray:
    """Every block's vertices at ``poses``, shape (n, k, 2)."""
    v = structure.vertices
    return rotate(v - c0[:, None, :], poses.angle[:, None]) + (c0 + poses.shift)[:, None, :]


def motion(twist: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``a`` (n,) and centroid displacement (n, 2) of the exact rigid motion of the twists
    ``(v_x, v_y, omega)`` (n, 3) over the parameter ``s`` (module docstring)."""
    a = twist[:, 2] * s
    small = np.abs(a) < 1e-4
    safe = np.where(small, 1.0, a)
    sinc = np.where(small, 1 - a * a / 6, np.sin(safe) / safe)
    cosc = np.where(small, a / 2 - a**3 / 24, (1 - np.cos(safe)) / safe)
    v = twist[:, :2] * s
    return a, np.column_stack([sinc * v[:, 0] - cosc * v[:, 1], cosc * v[:, 0] + sinc * v[:, 1]])


def moved(poses: Poses, twist: np.ndarray, s: float) -> Poses:
    """``poses`` moved by the twists over the parameter ``s`` (:func:`motion`)."""
    a, dc = motion(twist, s)
    return Poses(poses.angle + a, poses.shift + dc)


def mechanism_twists(ops, u: np.ndarray, n_blocks: int) -> np.ndarray:
    """The mechanism ``u`` (canonical frame, ``ops.free_blocks`` order) as twists ``(v_x, v_y, omega)``
    per structure block (n_blocks, 3), in the structure's axes and length unit (zero for fixed blocks): the
    rows of :func:`blockmpec.report.mechanism_frame` (a positive multiple of the twists; a step rescales them)."""
    from blockmpec.report import mechanism_frame

    frame = mechanism_frame(ops, np.asarray(u, float))
    out = np.zeros((n_blocks, 3))
    out[frame["block"].to_numpy()] = frame[["u_x", "u_y", "rotation"]].to_numpy()
    return out


def velocity(twist: np.ndarray, centre: np.ndarray, block: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Velocity of points ``p`` (m, 2) of blocks ``block`` under the twists about their current centroids."""
    w = twist[block]
    r = p - centre[block]
    return np.column_stack([w[:, 0] - w[:, 2] * r[:, 1], w[:, 1] + w[:, 2] * r[:, 0]])


def vertex_speed(twist: np.ndarray, vertices: np.ndarray, centre: np.ndarray) -> float:
    """Largest speed of a block vertex (current ``vertices`` (n, k, 2), centroids ``centre``) under the
    twists (the mechanism's velocity scale)."""
    r = vertices - centre[:, None, :]
    w = twist[:, None, :]
    vel = np.stack([w[..., 0] - w[..., 2] * r[..., 1], w[..., 1] + w[..., 2] * r[..., 0]], axis=-1)
    return float(np.max(np.linalg.norm(vel, axis=-1)))


def parameter_for(f, guess: float) -> float | None:
    """The root ``s > 0`` of ``f`` (``f(0) < 0``), bracketed from ``guess`` by doubling (Brent)."""
    from scipy.optimize import brentq

    hi = guess
    for _ in range(40):
        if f(hi) >= 0:
            return float(brentq(f, 0.0, hi, xtol=1e-14 * hi, rtol=1e-14, maxiter=200))
        hi *= 2.0
        if not math.isfinite(hi):
            break
    return None
