r"""The units of a structure's problem: one object for every method.

Limit analysis is scale-free: ``lam`` does not change when every length is
multiplied by ``a`` and every force by ``b``.  Floating point is not: a block
of width ``1e-108`` has an area below ``1e-216`` and moments of inertia-like
products below ``1e-300``, which underflow; lengths of ``1e140`` overflow the
same products; an offset of ``1e15`` from the origin cancels the digits of the
moment arms.  So everything is computed in *units* chosen from the structure:

Lengths (:class:`Frame`, :class:`CanonicalFrame`)
    Validation and interface detection take ``p^ = (p - origin) / length_scale``
    in a :class:`Frame`: ``origin`` the centre of the bounding box of the blocks
    (rounded to a coarse power-of-two grid, so that the subtraction is exact),
    ``length_scale`` the median block size (bounding-box diagonal).  Of each
    polygon, shape data are computed from its vertices relative to its first
    vertex in units of its own size, so that no product of two lengths is ever
    formed in the structure's units.

    The operators are assembled in the :class:`CanonicalFrame`: ``origin`` the
    centre of the bounding box of all blocks (not rounded: it moves with a
    translation), ``length_scale`` the median over the free blocks of the shorter
    side of their bounding boxes (not a power of two: it scales with the
    structure; the shorter side, so that the coordinates of a structure of
    rectangles on a regular grid, such as the built-in walls and two blocks, are
    dyadic fractions of it, which the snapping leaves exact), the ``x`` axis along the total horizontal live load (a mirror
    image with its live load mirrored has the same canonical coordinates), and
    the coordinates *snapped* to multiples of ``grid = 2**-SNAP_BITS * S_min``
    (``S_min`` the power of two nearest the shortest bounding-box side of any
    block, in length units).  A translation, a mirror image or a change of length
    unit (by any factor, 10**k included) changes the unsnapped coordinates by
    round-off only, a few units of 1e-16 times the structure's extent, far below
    the grid (about 1e-12 of the smallest block): the snapped coordinates, hence
    every operator and load built from them, are the same bits, and any
    deterministic method returns the same ``lam``.  The exception is a coordinate
    within round-off of a midpoint between two grid points (probability about
    ``1e-15 * extent / grid`` per distinct coordinate; never for inputs on a
    dyadic grid of the length unit, such as the built-in walls).

    Snapping moves each vertex by at most ``grid / sqrt(2)`` (half a grid step
    per coordinate), less than ``2**-40 S_min`` (9.1e-13 of the smallest block
    side): the problem solved is a structure whose blocks are moved by less than
    that, and ``lam``, Lipschitz in the vertices where the LPs are
    non-degenerate, changes by ``O(1e-12) lam`` (measured on the built-in suite:
    1.7e-13 on the round arch, 3.5e-14 on the arch on buttresses, below 1e-15 on
    two blocks and the walls, whose coordinates the snapping leaves exact).  The
    grid is a trade-off: 2**-40 gave bit-identical operators for 120 of 120 random
    translations and changes of unit of each built-in arch and wall, 2**-44 for
    only 10 of 40 translations of the round arch, with ``lam`` 16 times closer.

Forces
    Weights are ``density / rho_ref * area`` with the area from the canonical
    coordinates, in units of ``length_scale**2`` (``rho_ref`` the power of two
    nearest the median density of the free blocks, so that this scaling is exact);
    point loads are turned into the canonical frame and divided by ``rho_ref``,
    ``length_scale`` and ``length_scale`` again (one factor at a time: the product
    is never formed); then every force by ``force_unit``, the mean over the free
    blocks of the *live* force, point loads included (:func:`force_unit`).  For
    the built-in cases (no point loads, live factor 1) this is the mean block
    weight.  The loads are then snapped like the coordinates, to ``2**-SNAP_BITS``
    times the power of two nearest the smallest block load (:func:`block_load`),
    so that a change of force unit (densities and point loads times any factor)
    gives the same bits too.  ``force_scale = rho_ref * length_scale**2 *
    force_unit`` converts back (it may over- or underflow at extreme magnitudes;
    it is used only to report forces).

Per block and per interface (:class:`Units`)
    Block ``i`` carries the load ``l_i = ||f_d,i|| + ||f_l,i||`` (its three
    components each, moments in length units), but at least half the median
    load times its area over the mean area (a near-massless block next to a point
    load carries that load; with uniform density the floor is never active);
    interface ``k`` the force unit ``l_k = min(l_i)`` over its free
    blocks (a tiny block on a big one loads their interface with its own
    weight).  A solver that divides block ``i``'s equilibrium rows by ``l_i`` and
    measures interface ``k``'s ``(t, n, m)`` in ``(l_k, l_k, l_k L_k)`` has its
    absolute tolerances hold block by block (:mod:`blockmpec.solvers.engines.scaling`
    does this for the LPs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockmpec.errors import StructureError


def power_of_two(x: float | np.ndarray):
    """The power of two nearest ``x`` (> 0) in the log scale; 1 where ``x`` is not > 0 or not finite."""
    x = np.asarray(x, float)
    ok = (x > 0) & np.isfinite(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(ok, np.round(np.log2(np.where(ok, x, 1.0))), 0.0)
    out = np.ldexp(1.0, k.astype(int))
    return float(out) if out.ndim == 0 else out


#: Canonical coordinates are snapped to multiples of ``2**-SNAP_BITS`` times the (power of two nearest
#: the) shortest bounding-box side of any block, in length units (see the module docstring).
SNAP_BITS = 40


def snap(values: np.ndarray, grid: float) -> np.ndarray:
    """``values`` rounded to the nearest multiple of ``grid``, a power of two (so the scaling is exact).

    Ties go to even, so ``snap(-v) == -snap(v)`` bit for bit; values of more than 2**52 grid steps
    are already multiples of ``grid`` and come back unchanged."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.round(np.asarray(values, float) / grid) * grid


def block_extent(vertices: np.ndarray) -> np.ndarray:
    """Bounding-box diagonal of each padded polygon (n, k, 2) -> (n,), without overflow of squares."""
    with np.errstate(over="ignore", invalid="ignore"):
        span = vertices.max(axis=1) - vertices.min(axis=1)
        return np.hypot(span[:, 0], span[:, 1])


def _bounding_boxes(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(lo, hi, centre, span)``: the structure's bounding box, its centre and each block's box sides
    (n, 2), of padded polygons ``vertices`` (n, k, 2).

    Raises
    ------
    StructureError
        Naming the first block whose extent overflows the floating-point range.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        lo, hi = vertices.min(axis=(0, 1)), vertices.max(axis=(0, 1))
        centre = 0.5 * lo + 0.5 * hi
        span = vertices.max(axis=1) - vertices.min(axis=1)
    if not (np.all(np.isfinite(span)) and np.all(np.isfinite(hi - lo))):
        bad = np.flatnonzero(~np.isfinite(span).all(axis=1))
        i = int(bad[0]) if bad.size else 0
        raise StructureError(f"block {i}: its extent overflows the floating-point range (coordinates too large)")
    return lo, hi, centre, span


@dataclass(frozen=True)
class Frame:
    """Origin and length unit: ``p^ = (p - origin) / length_scale``."""

    origin: np.ndarray
    length_scale: float

    @classmethod
    def of(cls, vertices: np.ndarray, blocks: np.ndarray | None = None, exact: bool = False) -> Frame:
        """The frame of padded polygons ``vertices`` (n, k, 2), sized from all blocks (or ``blocks``).

        ``length_scale`` is the median block size (with ``exact``, the power of two nearest it,
        so that ``back(frame(p)) == p`` bit for bit); ``origin`` the centre of the bounding box of
        *all* blocks rounded to a
        multiple of ``G``, the power of two above the structure's extent.  Then ``p - origin``
        is exact (a structure offset by 1e15 loses no digit), a structure near the origin keeps
        its coordinates bit for bit (origin 0), and a mirror image gets exactly the mirrored
        origin.

        Raises
        ------
        StructureError
            When the coordinates span more than the floating-point range.
        """
        lo, hi, centre, _ = _bounding_boxes(vertices)
        extent = float(np.max(hi - lo))
        size = block_extent(vertices)
        chosen = size if blocks is None or len(blocks) == 0 else size[blocks]
        scale = float(np.median(chosen))
        if not scale > 0:
            raise StructureError("blocks: every block has zero size")
        grid = power_of_two(extent) * 2.0 if extent > 0 else 1.0
        origin = np.round(centre / grid) * grid
        return cls(origin=np.asarray(origin, float), length_scale=power_of_two(scale) if exact else scale)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2) in this frame."""
        return (np.asarray(points, float) - self.origin) / self.length_scale

    def back(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2) of this frame in the structure's coordinates."""
        return np.asarray(points, float) * self.length_scale + self.origin


@dataclass(frozen=True)
class CanonicalFrame:
    """The frame of the assembled operators: ``p^ = snap(M (p - origin) / length_scale, grid)``.

    ``M = diag(mirror, 1)`` turns the ``x`` axis along the total live load; see the module
    docstring for the choices and the bound on the change of ``lam`` from the snapping.

    Attributes
    ----------
    origin : ndarray, shape (2,)
        Centre of the bounding box of all blocks (structure coordinates).
    length_scale : float
        Median over the free blocks of the shorter side of their bounding boxes.
    grid : float
        Snapping grid in length units, ``2**-SNAP_BITS`` times a power of two.
    mirror : float
        +1, or -1 when the canonical ``x`` axis is the structure's ``-x``.
    """

    origin: np.ndarray
    length_scale: float
    grid: float
    mirror: float = 1.0

    @classmethod
    def of(cls, vertices: np.ndarray, blocks: np.ndarray | None = None) -> CanonicalFrame:
        """The canonical frame (``mirror`` +1) of padded polygons ``vertices`` (n, k, 2), sized from
        ``blocks`` (all blocks when None or empty).

        Every quantity is invariant, up to round-off, under a translation or a change of length unit,
        and exactly under a mirror image (its origin is the mirrored origin).

        Raises
        ------
        StructureError
            When the coordinates span more than the floating-point range.
        """
        _, _, centre, span = _bounding_boxes(vertices)
        shorter = span.min(axis=1)
        chosen = shorter if blocks is None or len(blocks) == 0 else shorter[blocks]
        scale = float(np.median(chosen))
        if not scale > 0:
            raise StructureError("blocks: every block has zero size")
        with np.errstate(divide="ignore", over="ignore", under="ignore"):
            smallest = float(np.min(shorter)) / scale
        grid = float(np.ldexp(power_of_two(smallest) if smallest > 0 else 1.0, -SNAP_BITS))
        return cls(origin=np.asarray(centre, float), length_scale=scale, grid=grid)

    def mirrored(self, mirror: float) -> CanonicalFrame:
        """This frame with the ``x`` axis turned by ``mirror`` (+1 or -1)."""
        return CanonicalFrame(self.origin, self.length_scale, self.grid, float(mirror))

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2) in this frame, snapped."""
        with np.errstate(over="ignore", invalid="ignore"):
            q = snap((np.asarray(points, float) - self.origin) / self.length_scale, self.grid)
        q[..., 0] *= self.mirror
        return q

    def vector(self, v: np.ndarray) -> np.ndarray:
        """Vectors (..., 2) (forces, directions) turned into this frame: ``M v`` (no scaling)."""
        out = np.array(v, float)
        out[..., 0] *= self.mirror
        return out

    def back(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2) of this frame in the structure's coordinates."""
        q = np.array(points, float)
        q[..., 0] *= self.mirror
        return q * self.length_scale + self.origin


def block_load(f_d: np.ndarray, f_l: np.ndarray) -> np.ndarray:
    """``l_i = ||f_d,i|| + ||f_l,i||`` per free block (generalised loads of length 3b), shape (b,)."""
    return np.linalg.norm(np.reshape(f_d, (-1, 3)), axis=1) + np.linalg.norm(np.reshape(f_l, (-1, 3)), axis=1)


def force_unit(dead_force: np.ndarray, live_force: np.ndarray) -> float:
    """The force unit: the mean over blocks of the live force ``|f_l,i|`` (force vectors (b, 2)).

    The live load must be resolved (``lam f_l`` against the dead load decides ``lam``): a dead
    point load 1e10 times the weights must not shrink the live load to 1e-10 (the LP would then
    see no live load and call the problem unbounded), and a near-massless structure loaded by
    live point loads must not have them at 1e12.  Falls back to the dead forces, then to 1."""
    for forces in (live_force, dead_force):
        if forces.shape[0] == 0:
            continue
        unit = float(np.mean(np.hypot(forces[:, 0], forces[:, 1])))
        if unit > 0 and np.isfinite(unit):
            return unit
    return 1.0


@dataclass(frozen=True, eq=False)
class Units:
    """The units of one assembled problem (see the module docstring).

    Attributes
    ----------
    origin : ndarray, shape (2,)
        Structure point taken as origin of the nondimensional lengths.
    length_scale, force_scale : float
        Structure length and force of one nondimensional unit.
    block_load : ndarray, shape (b,)
        Load ``l_i`` of each free block (row block of ``E``), nondimensional, > 0.
    interface_force : ndarray, shape (c,)
        Force unit ``l_k`` of each interface, > 0.
    interface_length : ndarray, shape (c,)
        Interface lengths ``L_k``, nondimensional.
    """

    origin: np.ndarray
    length_scale: float
    force_scale: float
    block_load: np.ndarray
    interface_force: np.ndarray
    interface_length: np.ndarray

    @classmethod
    def of(cls, ops) -> Units:
        """The units of assembled operators (:class:`blockmpec.operators.Operators`)."""
        load = block_load(ops.f_d, ops.f_l)
        if ops.block_area is not None and load.size:
            # a near-massless block is still a block: it carries at least the typical load per area
            typical = float(np.median(load))
            load = np.maximum(load, 0.5 * typical * ops.block_area / float(np.mean(ops.block_area)))
        load = np.where(load > 0, load, np.max(load, initial=1.0))
        side = np.column_stack([ops.minus_dof, ops.plus_dof])
        unit = np.where(side >= 0, load[np.maximum(side, 0)], np.inf).min(axis=1)
        origin = np.zeros(2) if ops.origin is None else np.asarray(ops.origin, float)
        return cls(origin, float(ops.length_scale), float(ops.force_scale), load, unit, np.asarray(ops.length, float))

    @property
    def load_spread(self) -> float:
        """Largest over smallest block load (1 for uniform blocks)."""
        return float(self.block_load.max() / self.block_load.min()) if self.block_load.size else 1.0

    def equilibrium_row_scale(self) -> np.ndarray:
        """``1 / l_i`` repeated over block ``i``'s three equilibrium rows, shape (3b,)."""
        return np.repeat(1.0 / self.block_load, 3)

    def force_column_scale(self) -> np.ndarray:
        """``(l_k, l_k, l_k L_k)`` per interface: the units of ``(t_k, n_k, m_k)``, shape (3c,)."""
        length = np.maximum(self.interface_length, 1e-300)
        f = self.interface_force
        return np.column_stack([f, f, f * length]).ravel()

    def multiplier_column_scale(self, friction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Units of ``z_u`` (``1/(l_k L_k)``) and ``z_f`` (``1/(l_k max(1, mu_k))``), each shape (2c,): the
        duals of the yield rows scaled to O(1) (see :func:`blockmpec.solvers.engines.scaling.kinematic_scaling`)."""
        length = np.maximum(self.interface_length, 1e-300)
        f = self.interface_force
        return (np.repeat(1.0 / (f * length), 2),
                np.repeat(1.0 / (f * np.maximum(1.0, np.asarray(friction, float))), 2))

    def forces_to_physical(self, x: np.ndarray) -> np.ndarray:
        """Interface forces ``x`` (3c,) in the structure's units (``t, n`` x force_scale, ``m`` x force*length)."""
        out = np.asarray(x, float) * self.force_scale
        out[2::3] *= self.length_scale
        return out
