r"""The lifted LP of :mod:`~blockmpec.solvers.engines.complementarity_bnb` in null-space coordinates.

The lifted LP (``lifting="rlt-full"``) carries, besides the static field ``x`` and the mechanism
``(u, z)``, a copy ``x^(i) = z_i x`` of the static field per pair, ``v = lam u`` and ``W = x u^T``.
Most of its rows only say that these products are static or kinematic fields: the equilibrium of
``x`` and of every copy, compatibility of ``u``, of ``v`` and of every row of ``W``.  Here those rows
are solved once, exactly, and the LP is written in the coordinates that remain.

Static side.  With ``E`` (3 rows per block) of full row rank, a spanning tree of the contact graph
(blocks and the supports as one node; :func:`static_null_space`) gives a basis of its columns: the
three forces of each block's tree interface, ``B = E[:, tree]``, block triangular and invertible.  Then::

    E x + f_d + lam f_l = 0   <=>   x = x_d + lam x_l + N sigma,

``x_d``, ``x_l`` the tree solutions (zero on the other interfaces) and ``N`` a sparse basis of self-stresses,
one per force of a non-tree interface: unit on that force, the tree forces of its fundamental cycle elsewhere.
(``basis="cycles"``: three per cycle of a short cycle basis of the contact graph, Horton's, unit on the forces of
one interface of the cycle: sparser pair rows ``G N``, not faster.)  Kinematic side: ``u = L z`` with
``L = -B^{-T} F_tree`` solves the tree rows of compatibility ``E^T u + F z = 0``; the others hold exactly when
``C z = 0`` with ``C = (F + E^T L)[non-tree rows] = N^T F``.  With ``c^T = f_l^T L`` (each multiplier's live
work) the normalisation ``f_l^T u = 1`` is ``c^T z = 1``.

The lifted LP in the coordinates ``xi = (lam, sigma, z, zeta, sigma^(i) per copy)``::

    x = x_d + lam x_l + N sigma,   u = L z,   x^(i) = z_i x_d + zeta_i x_l + N sigma^(i),   v = L zeta,

(rows of equilibrium and of the tree part of compatibility vanish identically; the unilateral and friction
rows of ``x`` and of every copy, the work identity and the ``zeta`` rows keep their bounds), and the rows (X)
of every force ``r`` (``E^T W_r + F X_r = 0``, ``f_l^T W_r = x_r``, ``X_r = (x^(i)_r)_i``) become, with
``W_r = L X_r`` and ``X_r = x_d,r z + x_l,r zeta + sum_k N_rk Sigma^(k)`` (``Sigma^(k) = (sigma^(i)_k)_i``),
``sum_k N_rk C Sigma^(k) = 0`` and ``sum_k N_rk (c^T Sigma^(k) - sigma_k) = 0`` for every ``r`` (using
``C z = 0``, ``C zeta = 0``, ``c^T z = 1``, ``c^T zeta = lam``); ``N`` has full column rank, so this is::

    C Sigma^(k) = 0,   c^T Sigma^(k) = sigma_k     (k = 1..q, q = columns of N).

Every point of the lifted LP maps to exactly one point of this LP with the same ``lam`` and back (``W``, ``u``,
``v`` and the copies are functions of ``xi``): the two LPs have the same minimum, and the dual bound of one is a
bound for the other.  The reformulation needs every force tied (``rlt-full``) and every copy's statics
(``static_copies="all"``).  It drops the ``3 (blocks)`` equilibrium rows and columns of every copy and all of
``W``: on the 2x15 running-bond wall 166,078 rows x 87,359 columns become 105,535 x 38,906.

Round-off: ``N``, ``x_d``, ``x_l`` and ``L`` come from one sparse LU of ``B``; their residuals are checked to
``NULL_SPACE_TOL`` relative (:func:`static_null_space` returns None otherwise, and the lifted LP is used).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

#: largest relative residual of the null-space basis and tree solutions (``|E N|``, ``|E x_d + f_d|``, ...)
NULL_SPACE_TOL = 1e-11
#: a vanished row (equilibrium, tree compatibility) must hold within this (relative to its bounds' size)
VANISHED_ROW_TOL = 1e-9


@dataclass
class StaticNullSpace:
    """``x = x_d + lam x_l + N sigma`` solves equilibrium for every ``sigma``; ``u = L z`` solves compatibility
    for every ``z`` with ``C z = 0``; ``live_work = f_l^T L`` (module docstring)."""

    N: sp.csr_array
    x_d: np.ndarray
    x_l: np.ndarray
    L: sp.csr_array
    C: sp.csr_array
    live_work: np.ndarray


def _interface_ends(E: sp.csc_array, groups: np.ndarray, n_blocks: int) -> list[tuple[int, int]] | None:
    """The two nodes each interface joins (a block, or ``n_blocks`` for the supports); None if one touches
    no block or more than two."""
    ends = []
    for cols in groups:
        rows = np.concatenate([E.indices[E.indptr[j]:E.indptr[j + 1]] for j in cols])
        blocks = np.unique(rows // 3)
        if blocks.size == 1:
            ends.append((int(blocks[0]), n_blocks))
        elif blocks.size == 2:
            ends.append((int(blocks[0]), int(blocks[1])))
        else:
            return None
    return ends


def _spanning_tree(ends: list[tuple[int, int]], n_blocks: int):
    """Breadth-first spanning tree from the supports: ``(parent, parent interface, depth)`` per node (the
    supports are node ``n_blocks``); None if a block has no path to the supports."""
    neighbours = [[] for _ in range(n_blocks + 1)]
    for k, (a, b) in enumerate(ends):
        neighbours[a].append((b, k))
        neighbours[b].append((a, k))
    parent = np.full(n_blocks + 1, -2)
    parent_interface = np.full(n_blocks + 1, -1)
    depth = np.zeros(n_blocks + 1, dtype=int)
    parent[n_blocks] = -1
    queue = deque([n_blocks])
    while queue:
        a = queue.popleft()
        for b, k in neighbours[a]:
            if parent[b] == -2:
                parent[b], parent_interface[b], depth[b] = a, k, depth[a] + 1
                queue.append(b)
    if np.any(parent[:n_blocks] == -2):
        return None
    return parent, parent_interface, depth


def _tree_path(a: int, b: int, parent, parent_interface, depth) -> list[int]:
    """The tree interfaces on the path between nodes ``a`` and ``b``."""
    path = []
    while a != b:
        if depth[a] >= depth[b]:
            path.append(int(parent_interface[a]))
            a = parent[a]
        else:
            path.append(int(parent_interface[b]))
            b = parent[b]
    return path


def _short_cycles(ends: list[tuple[int, int]], n_nodes: int) -> list[list[int]] | None:
    """A short cycle basis of the contact graph (Horton): the candidate cycles ``P(v, a) + k + P(b, v)`` of every node
    ``v`` (shortest paths of its breadth-first tree) and interface ``k = (a, b)`` off that tree whose two paths
    meet only at ``v``, shortest first, each kept when it is independent of those kept (Gaussian elimination
    over GF(2) on their interface sets).  Lists of interfaces; None if they do not span the cycle space."""
    neighbours = [[] for _ in range(n_nodes)]
    for k, (a, b) in enumerate(ends):
        neighbours[a].append((b, k))
        neighbours[b].append((a, k))
    rank = len(ends) - n_nodes + 1
    candidates = []
    for v in range(n_nodes):
        parent, via = np.full(n_nodes, -1), np.full(n_nodes, -1)
        seen = np.zeros(n_nodes, dtype=bool)
        seen[v] = True
        queue = deque([v])
        while queue:
            a = queue.popleft()
            for b, k in neighbours[a]:
                if not seen[b]:
                    seen[b], parent[b], via[b] = True, a, k
                    queue.append(b)

        def path(a, _parent=parent, _via=via):
            nodes, edges = [a], []
            while _parent[a] >= 0:
                edges.append(int(_via[a]))
                a = _parent[a]
                nodes.append(a)
            return nodes, edges

        for k, (a, b) in enumerate(ends):
            if via[a] == k or via[b] == k:
                continue
            (nodes_a, edges_a), (nodes_b, edges_b) = path(a), path(b)
            if set(nodes_a) & set(nodes_b) != {v}:
                continue
            candidates.append((len(edges_a) + len(edges_b) + 1, edges_a + [k] + edges_b))
    candidates.sort(key=lambda item: item[0])
    basis, pivots = [], {}  # GF(2) elimination: reduced bit set -> its leading bit
    for _, edges in candidates:
        bits = 0
        for e in edges:
            bits ^= 1 << e
        reduced = bits
        while reduced:
            lead = reduced.bit_length() - 1
            if lead not in pivots:
                pivots[lead] = reduced
                basis.append(edges)
                break
            reduced ^= pivots[lead]
        if len(basis) == rank:
            return basis
    return None


def _cycle_self_stresses(Ed: np.ndarray, groups: np.ndarray, cycles: list[list[int]]) -> sp.csr_array | None:
    """Three self-stresses per cycle (the null space of ``E`` on the cycle's forces, by SVD), as the columns of a
    sparse ``N``; None if a cycle does not carry exactly three."""
    from scipy.linalg import null_space

    rows, cols, vals = [], [], []
    for j, cycle in enumerate(cycles):
        forces = groups[cycle].ravel()
        local = null_space(Ed[:, forces])
        if local.shape[1] != 3:
            return None
        # in force units, as the tree's: unit on the three forces of the cycle's interface whose block of the
        # basis is best conditioned (an orthonormal basis mixes forces and moments)
        blocks = [local[3 * i:3 * i + 3] for i in range(len(cycle))]
        best = max(range(len(cycle)), key=lambda i: abs(np.linalg.det(blocks[i])) / max(np.abs(blocks[i]).max(), 1e-300) ** 3)
        try:
            local = local @ np.linalg.inv(blocks[best])
        except np.linalg.LinAlgError:
            return None
        local[np.abs(local) <= 1e-14 * np.abs(local).max()] = 0.0
        r, c = np.nonzero(local)
        rows += forces[r].tolist()
        cols += (3 * j + c).tolist()
        vals += local[r, c].tolist()
    return sp.csr_array((vals, (rows, cols)), shape=(Ed.shape[1], 3 * len(cycles)))


#: self-stress bases of :func:`static_null_space`
BASES = ("tree", "cycles")


def static_null_space(form, basis: str = "tree") -> StaticNullSpace | None:
    """The spanning-tree null space of ``form``'s equilibrium (module docstring); None when the structure does not
    allow it (an interface without three forces, a block with no path to the supports, a singular tree block) or
    the residuals exceed :data:`NULL_SPACE_TOL`.  ``basis``: the self-stresses of the tree's fundamental cycles
    (``"tree"``) or of a short cycle basis (``"cycles"``; the tree's where it fails)."""
    if basis not in BASES:
        raise ValueError(f"null space: unknown basis {basis!r}; use one of {', '.join(BASES)}")
    from scipy.sparse.linalg import splu

    nx = form.x.stop - form.x.start
    n_blocks = int(form.n_blocks)
    t, n, m = (np.asarray(a, dtype=int) for a in (form.t, form.n, form.m))
    if not (t.size == n.size == m.size) or 3 * t.size != nx:
        return None
    E = sp.csc_array(form.block(form.equilibrium, form.x))
    if E.shape[0] != 3 * n_blocks:
        return None
    groups = np.stack([t, n, m], axis=1)
    ends = _interface_ends(E, groups, n_blocks)
    tree = None if ends is None else _spanning_tree(ends, n_blocks)
    if tree is None:
        return None
    parent, parent_interface, depth = tree
    tree_interfaces = parent_interface[:n_blocks]
    tree_columns = groups[tree_interfaces].ravel()
    on_tree = np.zeros(len(ends), dtype=bool)
    on_tree[tree_interfaces] = True
    others = np.flatnonzero(~on_tree)
    try:
        lu = splu(sp.csc_array(E[:, tree_columns]))
    except RuntimeError:  # a tree interface whose forces do not span its block's equilibrium
        return None
    f_d, f_l = np.asarray(form.f_d, float), np.asarray(form.f_l, float)
    x_d, x_l = np.zeros(nx), np.zeros(nx)
    x_d[tree_columns], x_l[tree_columns] = lu.solve(-f_d), lu.solve(-f_l)
    # one self-stress per force of a non-tree interface, kept on its fundamental cycle
    q = 3 * others.size
    Ed = E.toarray()
    tree_forces = lu.solve(-Ed[:, groups[others].ravel()]) if q else np.zeros((tree_columns.size, 0))
    position = np.full(nx, -1)
    position[tree_columns] = np.arange(tree_columns.size)
    rows, cols, vals = [], [], []
    leak = 0.0
    for j, k in enumerate(others):
        a, b = ends[k]
        cycle = groups[_tree_path(a, b, parent, parent_interface, depth)].ravel()
        for axis in range(3):
            column = 3 * j + axis
            values = tree_forces[:, column]
            kept = values[position[cycle]]
            leak = max(leak, float(np.abs(values).sum() - np.abs(kept).sum()))
            rows += [groups[k, axis], *cycle.tolist()]
            cols += [column] * (1 + cycle.size)
            vals += [1.0, *kept.tolist()]
    N = sp.csr_array((vals, (rows, cols)), shape=(nx, q))
    N.eliminate_zeros()
    # basis="cycles": sparser pair rows G N (8x4 wall: 3.9 against 10.2 entries per row), measured no faster
    if basis == "cycles":
        cycles = _short_cycles(ends, n_blocks + 1)
        N_cycles = None if cycles is None else _cycle_self_stresses(Ed, groups, cycles)
        if N_cycles is not None and np.linalg.matrix_rank(N_cycles.toarray()) == q:
            N = N_cycles
    Fz = sp.csr_array(form.block(form.compatibility, form.z))
    Et = sp.csr_array(form.block(form.compatibility, form.u))
    # compatibility row r is force r's: E^T, up to the round-off of the per-block scaling (r E C against C E^T r:
    # 2.2e-16 on Ferris & Tin-Loi's wall, where the exact test left its 33 blocks without null-space coordinates)
    if Et.shape != (nx, E.shape[0]) or abs(Et - E.T).max() > NULL_SPACE_TOL * max(_largest(E), 1e-300):
        return None
    L = -lu.solve(Fz[tree_columns].toarray(), trans="T")
    L[np.abs(L) <= 1e-15 * max(np.abs(L).max(initial=0.0), 1e-300)] = 0.0
    L = sp.csr_array(L)
    residual = (Fz + Et @ L).toarray()
    non_tree_rows = np.ones(nx, dtype=bool)
    non_tree_rows[tree_columns] = False
    C = sp.csr_array(residual[non_tree_rows])
    scale = max(np.abs(Ed).max(initial=0.0), 1e-300)
    checks = (
        _largest(E @ N) / (scale * max(1.0, _largest(N))),
        _largest(E @ x_d + f_d) / (scale * max(1.0, _largest(x_d))),
        _largest(E @ x_l + f_l) / (scale * max(1.0, _largest(x_l))),
        _largest(residual[~non_tree_rows]) / max(1.0, _largest(residual)),
        leak / max(1.0, _largest(tree_forces)),
    )
    if max(checks) > NULL_SPACE_TOL:
        return None
    return StaticNullSpace(N, x_d, x_l, L, C, np.asarray(f_l @ L, float).ravel())


def _largest(M) -> float:
    """The largest absolute entry of a sparse or dense matrix (0 for an empty one)."""
    data = M.data if sp.issparse(M) else np.asarray(M)
    return float(np.abs(data).max(initial=0.0))


@dataclass
class NullSpaceLP:
    """The lifted LP in null-space coordinates (module docstring): ``min c^T xi`` s.t. ``row_lower <= A xi <=
    row_upper``, ``col_lower <= xi <= col_upper``.  A lifted point is ``offset + T xi`` (its ``W`` left at zero);
    ``lifted_row[r]`` is the lifted LP's row that row ``r`` comes from (-1 for the rows (X))."""

    A: sp.csc_array
    c: np.ndarray
    row_lower: np.ndarray
    row_upper: np.ndarray
    col_lower: np.ndarray
    col_upper: np.ndarray
    T: sp.csr_array
    offset: np.ndarray
    lifted_row: np.ndarray

    @property
    def arrays(self) -> tuple:
        """``(A, c, row_lower, row_upper, col_lower, col_upper)``, the order of the interior-point helpers."""
        return self.A, self.c, self.row_lower, self.row_upper, self.col_lower, self.col_upper

    def coordinates(self, lifted: np.ndarray, space: StaticNullSpace, layout) -> np.ndarray:
        """``xi`` of a lifted point (least squares on ``N``: exact for a point of the lifted LP); for tests."""
        q = space.N.shape[1]
        copies = layout.copies
        P = len(copies)
        N = space.N.toarray()
        xi = np.zeros(self.A.shape[1])
        lam = lifted[layout.lam]
        z = lifted[layout.z]
        xi[0] = lam
        xi[1:1 + q] = np.linalg.lstsq(N, lifted[layout.x] - space.x_d - lam * space.x_l, rcond=None)[0]
        xi[1 + q:1 + q + P] = z
        for position, (i, x_slice, zeta) in enumerate(copies):
            xi[1 + q + P + i] = lifted[zeta]
            start = 1 + q + 2 * P + position * q
            xi[start:start + q] = np.linalg.lstsq(
                N, lifted[x_slice] - z[i] * space.x_d - lifted[zeta] * space.x_l, rcond=None)[0]
        return xi


def layout_allows(layout, n_pairs: int) -> bool:
    """Whether a lifted LP's ``layout`` has what the null-space coordinates need: every force tied to ``u`` (the
    rows (X) of ``lifting="rlt-full"``), the products ``v = lam u`` and a copy of the static field for each of the
    ``n_pairs`` pairs.  (That each copy also carries its statics, ``static_copies="all"``, is the caller's to say.)"""
    nx = layout.x.stop - layout.x.start
    return (layout.tied is not None and layout.tied.size == nx and layout.v is not None
            and len(layout.copies) == n_pairs and all(x_slice is not None for _, x_slice, _ in layout.copies))


def null_space_lp(A, c, row_lower, row_upper, col_lower, col_upper, layout, space: StaticNullSpace) -> NullSpaceLP:
    """The lifted LP ``(A, c, bounds)`` of ``layout`` (``lifting="rlt-full"``: every force tied, a copy with its
    statics for every pair) written in the null-space coordinates of ``space`` (module docstring)."""
    nx = layout.x.stop - layout.x.start
    P = space.L.shape[1]
    q = space.N.shape[1]
    copies = layout.copies
    if not layout_allows(layout, P):
        raise ValueError("null-space LP: needs the rlt-full lifting (every force tied, a static copy per pair)")
    lam_col, sigma0, z0, zeta0, copy0 = 0, 1, 1 + q, 1 + q + P, 1 + q + 2 * P
    n_reduced = copy0 + P * q
    N, L = sp.coo_array(space.N), sp.coo_array(space.L)
    x_cols = np.arange(layout.x.start, layout.x.stop)
    u_cols = np.arange(layout.u.start, layout.u.stop)
    v_cols = np.arange(layout.v.start, layout.v.stop)
    offset = np.zeros(A.shape[1])
    offset[x_cols] = space.x_d
    rows = [np.array([layout.lam]), x_cols, x_cols[N.row], u_cols[L.row], np.arange(layout.z.start, layout.z.stop),
            v_cols[L.row]]
    cols = [np.array([lam_col]), np.full(nx, lam_col), sigma0 + N.col, z0 + L.col, z0 + np.arange(P), zeta0 + L.col]
    vals = [np.ones(1), space.x_l, N.data, L.data, np.ones(P), L.data]
    for position, (i, x_slice, zeta) in enumerate(copies):
        copy_cols = np.arange(x_slice.start, x_slice.stop)
        rows += [copy_cols, copy_cols, copy_cols[N.row], np.array([zeta])]
        cols += [np.full(nx, z0 + i), np.full(nx, zeta0 + i), copy0 + position * q + N.col, np.array([zeta0 + i])]
        vals += [space.x_d, space.x_l, N.data, np.ones(1)]
    T = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                     shape=(A.shape[1], n_reduced))
    # every row but the rows (X), substituted; equilibrium and tree compatibility rows vanish
    A = sp.csr_array(A)
    kept = np.ones(A.shape[0], dtype=bool)
    kept[layout.tied_rows.ravel()] = False
    kept_rows = np.flatnonzero(kept)
    A_kept = A[kept_rows]
    reduced = sp.csr_array(A_kept @ T)
    shift = A_kept @ offset
    lower, upper = row_lower[kept_rows] - shift, row_upper[kept_rows] - shift
    size = np.zeros(reduced.shape[0])
    np.maximum.at(size, np.repeat(np.arange(reduced.shape[0]), np.diff(reduced.indptr)), np.abs(reduced.data))
    row_scale = np.asarray(abs(A_kept).max(axis=1).todense()).ravel()
    vanished = size <= 1e-12 * np.maximum(row_scale, 1e-300)
    bound_scale = 1.0 + np.abs(shift[vanished])
    if np.any(lower[vanished] > VANISHED_ROW_TOL * bound_scale) or np.any(upper[vanished] < -VANISHED_ROW_TOL * bound_scale):
        raise ValueError("null-space LP: a row of equilibrium or compatibility does not hold on the null space")
    live = ~vanished
    reduced = reduced[np.flatnonzero(live)]
    # the rows (X): C Sigma^(k) = 0 and live_work^T Sigma^(k) - sigma_k = 0 for every k
    C = sp.coo_array(space.C)
    work = np.flatnonzero(space.live_work)
    blocks = []
    for k in range(q):
        blocks.append(sp.csr_array((C.data, (C.row, copy0 + C.col * q + k)), shape=(C.shape[0], n_reduced)))
        blocks.append(sp.csr_array((np.r_[space.live_work[work], -1.0],
                                    (np.zeros(work.size + 1, dtype=int), np.r_[copy0 + work * q + k, sigma0 + k])),
                                   shape=(1, n_reduced)))
    X = sp.vstack(blocks, format="csr") if blocks else sp.csr_array((0, n_reduced))
    zeros = np.zeros(X.shape[0])
    c_reduced = np.asarray(T.T @ c, float)
    col_lo, col_up = np.full(n_reduced, -np.inf), np.full(n_reduced, np.inf)
    col_lo[lam_col], col_up[lam_col] = col_lower[layout.lam], col_upper[layout.lam]
    col_lo[z0:z0 + P], col_up[z0:z0 + P] = col_lower[layout.z], col_upper[layout.z]
    return NullSpaceLP(sp.csc_array(sp.vstack([reduced, X], format="csr")), c_reduced,
                       np.r_[lower[live], zeros], np.r_[upper[live], zeros], col_lo, col_up, T, offset,
                       np.r_[kept_rows[live], np.full(X.shape[0], -1)])
