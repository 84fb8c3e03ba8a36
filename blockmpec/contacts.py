r"""Contacts of moved blocks: edge-to-edge interfaces and vertex-to-edge point contacts.

Once blocks have moved, two convex blocks touch along a common segment (edge to edge), at a
single point (a vertex of one on an edge of the other: a rotated block on its toe), or not at
all.  :func:`find_contacts` finds every such contact of a configuration and writes it as an
interface of the ordinary kind (:class:`~blockmpec.geometry.Interfaces`), so that every solver,
the operators' ``(t, n, m)`` per interface and the verifier apply unchanged.

Finding a contact (per pair of blocks, vectorised)
--------------------------------------------------
For convex polygons ``A`` and ``B`` the separation along the outward normal ``nu_e`` of an
edge ``e`` of ``A`` (start ``a_e``) is ``sep_e = min_{v in B} nu_e . (v - a_e)``; the largest
over the edges of both blocks is the signed distance of the separating-axis test (the
penetration depth with a minus sign when they overlap).  Blocks whose separation is at most the
contact tolerance ``g`` are in contact.  The edge that gives the largest separation is the
*reference* edge (ties within ``g/2``: the fixed block's, else the lower block index's), its
block the minus block of the interface, the normal ``nu`` its outward normal; on the other
(*incident*) block the edge whose outward normal is most opposed to ``nu`` is the incident edge;
it is clipped to the reference edge's extent ``0 <= tau . (p - a) <= L`` and the separation
``nu . (p - a)`` of its two clipped ends decides:

* both ends within ``g``: an *edge* contact, the interface the clipped segment projected on the
  reference edge (for blocks that have not moved, exactly the interfaces of
  :func:`blockmpec.geometry.detect_interfaces`);
* one end within ``g``: a *point* contact at that end (the block's vertex, or where its edge
  crosses the end of the reference edge);
* a clipped segment shorter than ``g`` (two corners meeting, no common edge) is no contact: its
  normal is undefined.  A corner that moves onto an edge becomes a point contact.

Open contacts (separation above ``g``) are not interfaces: they carry no force.  Overlaps deeper
than ``g`` are interpenetration, reported by :func:`max_penetration` for the caller to cut its
step (:mod:`blockmpec.pushover`).

Point contacts as short interfaces
----------------------------------
The operators bound an interface's moment by ``|m| <= -n L/2`` and let it open by rocking about
either end (the flow ``N_u z_u`` opens the interface by ``L/2 (z_1 + z_2)``).  At a point
(``L = 0``) the statics would be right (``m = 0``; friction ``|t| <= -mu n`` forces ``n <= 0``),
but the flow rule could not open the contact without dilatancy, so a block could not leave its
toe under the non-associative flow rule with ``psi = 0``.  So a point contact at ``p`` is the
interface from ``p`` along the reference edge, of length

.. math:: \varepsilon = \min(c\,s, \ell_{clip}),

towards the incident edge's other clipped end (under the incident block), with ``c`` the
relative ``contact_length`` (default 1e-2), ``s`` the shorter side of the smaller block's
bounding box and ``l_clip`` the clipped length.  Its end at ``p`` is exact: rocking about the
vertex is rocking about that end, and the resultant may sit at ``p``.  What the segment adds is
a moment capacity ``|n| eps`` in the one sense in which the block would rotate *into* the
reference edge (closing the gap under its incident edge).

Error bound (associative problem).  Every admissible force field of true point contacts is
admissible with the segments (the resultant at ``p``), so ``lam_seg >= lam_point``.  Conversely,
with the point model's mechanism ``u`` (``f_l^T u = 1``) and the segment model's forces ``x``,
the virtual work of each segment about ``p`` is its moment about ``p``, at most
``eps_k |n_k|`` times the relative rotation ``|dtheta_k|``, so

.. math:: \lambda_{point} \le \lambda_{seg} \le \lambda_{point}
          + \sum_{k\ \mathrm{point}} \varepsilon_k\,|n_k|\,|\Delta\theta_k| ,

and the excess vanishes whenever the mechanism turns each point contact about its contact point
in the opening sense -- a block rocking on its toe, a hinge of an arch: there ``lam`` is exact
(``tests/test_pushover.py`` checks ``tan(alpha - theta)`` to 1e-6).  ``studies/lab/pushover_benchmark.py``
reports the change of ``lam`` when ``contact_length`` is divided by ten.

No validation
-------------
A point contact's interface lies on the reference block's edge and touches the incident block
only at ``p``; :func:`blockmpec.geometry.validate` (every interface end on the boundary of both
blocks) would reject it.  Deformed configurations are therefore built by
:func:`contact_structure` with :func:`dataclasses.replace` and never re-validated: its checks are
this module's invariants (each interface on its reference edge, one end at the contact point, no
overlap deeper than ``g``), and the global geometric tolerance is left as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from blockmpec.geometry import Interfaces, Structure, candidate_pairs

#: Default contact tolerance ``g``, relative to the shorter side of the smaller block of a pair:
#: blocks closer than this touch, overlaps deeper than this are interpenetration.  Larger than the
#: second-order opening of a sliding contact over one step of a capacity curve (a step turning blocks
#: by 0.01 rad opens a joint that turns about a hinge 1 away by 5e-5), so that such a joint still touches.
CONTACT_TOLERANCE = 1e-3

#: Default length of a point contact's interface, relative to the shorter side of the smaller block.
#: (1e-3 left the fixed point's simplex LPs failing on moved walls; lam moved by 1e-11 between the two.)
CONTACT_LENGTH = 1e-2

_CHUNK = 20000


@dataclass(frozen=True, eq=False)
class Contacts:
    """The contacts of one configuration, ``c`` of them, as interfaces plus what made them.

    Attributes
    ----------
    interfaces : Interfaces
        One interface per contact; ``minus`` is the reference block (whose edge carries the
        contact), ``plus`` the incident block; the normal points from minus into plus.
    is_point : ndarray of bool, shape (c,)
        True for a point contact (a short interface ending at the contact point, see the module
        docstring), False for an edge contact.
    points : ndarray, shape (c, 2, 2)
        The contact's two ends on the *incident* block (its material points): ``points[k, 0]`` at
        the interface's ``start``, ``points[k, 1]`` at its ``end``.
    feet : ndarray, shape (c, 2, 2)
        The same two ends projected on the reference edge (the interface's ``start`` and ``end``
        for an edge contact; for a point contact, ``feet[k, j]`` at the contact point and the
        other foot at the interface's far end).
    touching : ndarray of bool, shape (c, 2)
        Which of the two ends are real contact points: both for an edge contact, the one at the
        contact point for a point contact.
    gap : ndarray, shape (c, 2)
        Separation of each end from the reference edge (negative: overlap), lengths.
    """

    interfaces: Interfaces
    is_point: np.ndarray
    points: np.ndarray
    feet: np.ndarray
    touching: np.ndarray
    gap: np.ndarray

    def __len__(self) -> int:
        return len(self.interfaces)

    @property
    def n_points(self) -> int:
        """Number of point contacts."""
        return int(self.is_point.sum())


def shorter_sides(vertices: np.ndarray) -> np.ndarray:
    """Shorter side of each padded polygon's bounding box (n, k, 2) -> (n,)."""
    span = vertices.max(axis=1) - vertices.min(axis=1)
    return span.min(axis=1)


def _edges(vertices: np.ndarray, n_vertices: np.ndarray):
    """Per padded polygon (n, k, 2): edge starts, ends, unit directions, outward unit normals
    (counter-clockwise polygons: the direction turned by -90 degrees), lengths and a validity mask
    (real edges of positive length)."""
    k = vertices.shape[1]
    i = np.arange(k)[None, :]
    nxt = np.where(i + 1 < n_vertices[:, None], i + 1, 0)
    end = np.take_along_axis(vertices, nxt[..., None], axis=1)
    e = end - vertices
    length = np.hypot(e[..., 0], e[..., 1])
    valid = (i < n_vertices[:, None]) & (length > 0)
    d = e / np.where(length > 0, length, 1.0)[..., None]
    normal = np.stack([d[..., 1], -d[..., 0]], axis=-1)
    return vertices, end, d, normal, length, valid


def _separation(start, normal, valid, other):
    """Largest over the valid edges of one polygon per pair of ``min_v normal . (v - start)`` over
    the vertices ``other`` of the other polygon (padding repeats a real vertex): shapes (P, k, 2),
    (P, k, 2), (P, k), (P, k, 2) -> (sep (P,), edge index (P,))."""
    proj = np.einsum("pid,pjd->pij", normal, other) - np.einsum("pid,pid->pi", normal, start)[..., None]
    sep = np.where(valid, proj.min(axis=2), -np.inf)
    edge = sep.argmax(axis=1)
    return sep[np.arange(sep.shape[0]), edge], edge


def _pairs(vertices: np.ndarray, fixed: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs ``a < b`` (not both fixed) whose bounding boxes come within the tolerance
    (:func:`blockmpec.geometry.candidate_pairs` grows the boxes by ``2 tolerance`` times the smaller
    bounding-box diagonal, more than ``tolerance`` times the shorter side)."""
    a, b = candidate_pairs(vertices, 2 * tolerance)
    keep = ~(fixed[a] & fixed[b])
    return a[keep], b[keep]


def pair_separation(vertices: np.ndarray, n_vertices: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Separating-axis test of the block pairs ``(a[p], b[p])``.

    Returns
    -------
    sep_a, edge_a, sep_b, edge_b : ndarray, shape (P,)
        The largest separation along an edge normal of block ``a`` (of ``b``) and that edge's
        index.  ``max(sep_a, sep_b)`` is the signed distance of the pair (negative: overlap depth).
    """
    start, _, _, normal, _, valid = _edges(vertices, n_vertices)
    out = [np.zeros(0), np.zeros(0, int), np.zeros(0), np.zeros(0, int)]
    parts = []
    for lo in range(0, a.size, _CHUNK):
        sa, sb = a[lo:lo + _CHUNK], b[lo:lo + _CHUNK]
        s1, e1 = _separation(start[sa], normal[sa], valid[sa], vertices[sb])
        s2, e2 = _separation(start[sb], normal[sb], valid[sb], vertices[sa])
        parts.append((s1, e1, s2, e2))
    if parts:
        out = [np.concatenate([p[j] for p in parts]) for j in range(4)]
    return tuple(out)


def max_penetration(vertices: np.ndarray, n_vertices: np.ndarray, fixed: np.ndarray,
                    tolerance: float = CONTACT_TOLERANCE) -> np.ndarray:
    """Overlap depth of every pair of blocks that overlap, relative to the shorter side of the
    pair's smaller block; pairs are those whose boxes come within ``tolerance``.

    Returns
    -------
    ndarray, shape (n_pairs, 3)
        Rows ``(a, b, depth / size)`` with ``depth > 0`` only (empty when nothing overlaps).
    """
    a, b = _pairs(vertices, fixed, tolerance)
    sep_a, _, sep_b, _ = pair_separation(vertices, n_vertices, a, b)
    size = np.minimum(shorter_sides(vertices)[a], shorter_sides(vertices)[b])
    depth = -np.maximum(sep_a, sep_b) / size
    hit = depth > 0
    return np.column_stack([a[hit], b[hit], depth[hit]])


def find_contacts(
    vertices: np.ndarray,
    n_vertices: np.ndarray,
    fixed: np.ndarray,
    *,
    tolerance: float = CONTACT_TOLERANCE,
    contact_length: float = CONTACT_LENGTH,
) -> Contacts:
    """The contacts of a configuration of convex blocks (see the module docstring).

    Parameters
    ----------
    vertices : ndarray, shape (n, k, 2)
        Padded counter-clockwise polygons (as :attr:`blockmpec.geometry.Structure.vertices`).
    n_vertices : ndarray of int, shape (n,)
    fixed : ndarray of bool, shape (n,)
        Pairs of two fixed blocks are skipped.
    tolerance : float
        Contact tolerance ``g`` relative to the shorter side of a pair's smaller block: ends
        within ``g`` of the reference edge touch.
    contact_length : float
        Length of a point contact's interface, relative to the same side.

    Returns
    -------
    Contacts
        Ordered by minus block, plus block.
    """
    vertices = np.asarray(vertices, float)
    n_vertices = np.asarray(n_vertices, int)
    fixed = np.asarray(fixed, bool)
    a, b = _pairs(vertices, fixed, tolerance)
    start, end, direction, normal, length, valid = _edges(vertices, n_vertices)
    side = shorter_sides(vertices)
    sep_a, edge_a, sep_b, edge_b = pair_separation(vertices, n_vertices, a, b)
    size = np.minimum(side[a], side[b])
    g = tolerance * size
    close = np.maximum(sep_a, sep_b) <= g
    a, b, sep_a, edge_a, sep_b, edge_b, size, g = (v[close] for v in (a, b, sep_a, edge_a, sep_b, edge_b, size, g))

    # reference edge: the larger separation; ties (within g/2) to the fixed block, else the lower index a
    prefer_a = np.where(fixed[a] != fixed[b], fixed[a], True)
    ref_a = (sep_a > sep_b + 0.5 * g) | ((np.abs(sep_a - sep_b) <= 0.5 * g) & prefer_a)
    ref = np.where(ref_a, a, b)
    inc = np.where(ref_a, b, a)
    ref_edge = np.where(ref_a, edge_a, edge_b)
    r0, tau, nu, lr = start[ref, ref_edge], direction[ref, ref_edge], normal[ref, ref_edge], length[ref, ref_edge]

    # incident edge: outward normal most opposed to nu
    dots = np.einsum("pkd,pd->pk", normal[inc], nu)
    inc_edge = np.where(valid[inc], dots, np.inf).argmin(axis=1)
    q1, q2 = start[inc, inc_edge], end[inc, inc_edge]
    t1 = np.einsum("pd,pd->p", q1 - r0, tau)
    t2 = np.einsum("pd,pd->p", q2 - r0, tau)
    s1 = np.einsum("pd,pd->p", q1 - r0, nu)
    s2 = np.einsum("pd,pd->p", q2 - r0, nu)
    dt = t2 - t1
    ok = np.abs(dt) > 0
    dt = np.where(ok, dt, 1.0)
    lo = np.clip(np.minimum(t1, t2), 0.0, lr)
    hi = np.clip(np.maximum(t1, t2), 0.0, lr)
    ok &= hi - lo > g

    def along(t):  # the incident edge's point above reference parameter t, and its separation
        w = (t - t1) / dt
        return q1 + w[:, None] * (q2 - q1), s1 + w * (s2 - s1)

    p_lo, s_lo = along(lo)
    p_hi, s_hi = along(hi)
    touch_lo, touch_hi = s_lo <= g, s_hi <= g
    ok &= touch_lo | touch_hi
    eps = np.minimum(contact_length * size, hi - lo)
    both = touch_lo & touch_hi
    is_point = ~both
    # a point contact at lo runs towards hi over eps, and conversely
    seg_lo = np.where(both | touch_lo, lo, hi - eps)
    seg_hi = np.where(both | touch_hi, hi, lo + eps)
    # the interface runs from hi to lo (its normal, rot90(end - start), is then +nu: from minus into plus)
    foot_start = r0 + seg_hi[:, None] * tau
    foot_end = r0 + seg_lo[:, None] * tau
    inc_start, s_start = along(seg_hi)
    inc_end, s_end = along(seg_lo)
    touching = np.column_stack([both | touch_hi, both | touch_lo])

    keep = np.flatnonzero(ok)
    minus, plus = ref[keep], inc[keep]
    order = np.lexsort((plus, minus))
    keep, minus, plus = keep[order], minus[order], plus[order]
    nan = np.full(keep.size, np.nan)
    interfaces = Interfaces(minus.astype(int), plus.astype(int), foot_start[keep], foot_end[keep], nan, nan.copy())
    return Contacts(
        interfaces=interfaces,
        is_point=is_point[keep],
        points=np.stack([inc_start[keep], inc_end[keep]], axis=1),
        feet=np.stack([foot_start[keep], foot_end[keep]], axis=1),
        touching=touching[keep],
        gap=np.column_stack([s_start[keep], s_end[keep]]),
    )


def contact_structure(structure: Structure, vertices: np.ndarray, contacts: Contacts) -> Structure:
    """``structure`` with its blocks at ``vertices`` and ``contacts`` as its interfaces (not re-validated,
    see the module docstring).

    Material overrides of the structure's own interfaces carry over per pair of blocks: a contact
    between blocks ``i`` and ``j`` takes the friction and dilatancy of the first interface the
    structure has between them (NaN, the structure's defaults, for pairs it had none between).
    """
    itf = contacts.interfaces
    friction = np.full(len(itf), np.nan)
    dilatancy = np.full(len(itf), np.nan)
    own = structure.interfaces
    if len(own) and len(itf) and not (np.all(np.isnan(own.friction)) and np.all(np.isnan(own.dilatancy))):
        n = structure.n_blocks
        key = np.minimum(own.minus, own.plus) * n + np.maximum(own.minus, own.plus)
        first = {}
        for k in range(len(own) - 1, -1, -1):
            first[int(key[k])] = k
        mine = np.minimum(itf.minus, itf.plus) * n + np.maximum(itf.minus, itf.plus)
        for j, kk in enumerate(mine):
            k = first.get(int(kk))
            if k is not None:
                friction[j], dilatancy[j] = own.friction[k], own.dilatancy[k]
    interfaces = Interfaces(itf.minus, itf.plus, itf.start, itf.end, friction, dilatancy)
    return replace(structure, vertices=np.asarray(vertices, float), interfaces=interfaces)
