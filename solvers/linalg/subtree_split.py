r"""The split of a supernodal elimination tree into two halves that two processes factorise side by side
(:mod:`blockmpec.solvers.linalg.cholesky`, ``processes=2``).

Each supernode's cost is estimated from its front (a fixed cost, its dense ``potrf``/``trsm``/``syrk`` work
``w^3/3 + r w^2 + r^2 w`` for ``w`` columns and ``r`` rows below, and the ``m^2`` entries assembled).  Two unions of
whole subtrees need no update from each other, so the tree is cut below a *top* (the supernodes left to the end) and
its subtrees dealt to two halves, longest first; the cut with the least ``cost(top) + max(cost of a half)`` is kept.
:class:`SubtreeSplit` is a part of :class:`~blockmpec.solvers.linalg.cholesky.SupernodalCholesky`, whose supernodal
tree it reads.
"""

from __future__ import annotations

import numpy as np


class SubtreeSplit:
    """Front costs and the split of the supernodal tree into two halves and a top (see the module docstring)."""

    def front_flops(self) -> np.ndarray:
        """Each supernode's dense work: ``potrf``, ``trsm`` and ``syrk`` on its front, ``w^3/3 + r w^2 + r^2 w`` for
        ``w`` columns and ``r`` rows below (multiply-adds counted once)."""
        w = (self.end - self.first).astype(float)
        r = np.array([R.size for R in self.rows], dtype=float) - w
        return w ** 3 / 3 + r * w * w + r * r * w

    def front_costs(self) -> np.ndarray:
        """An estimate of each supernode's factorisation time (s): a fixed cost per front, its dense work
        (:meth:`front_flops`) and the ``m^2`` entries of the front that are zeroed and assembled."""
        m = np.array([R.size for R in self.rows], dtype=float)
        return 3e-5 + 2.5e-10 * self.front_flops() + 2e-9 * m * m

    def supernode_parents(self) -> np.ndarray:
        """Each supernode's parent in the supernodal elimination tree (-1: a root)."""
        parent = np.full(self.supernodes, -1, dtype=np.int64)
        for s, kids in enumerate(self.children):
            parent[kids] = s
        return parent

    def subtree_halves(self) -> tuple[list[np.ndarray], np.ndarray]:
        """``([half_0, half_1], top)``: supernodes two processes can factorise side by side, then the rest.

        From the roots of the supernodal elimination tree, the costliest subtree (:meth:`front_costs`) is split
        into its root (to ``top``) and its children's subtrees, and the split with the least ``cost(top) + max(cost of
        a half)`` is kept (the search stops once ``(cost(all) + cost(top)) / 2``, a bound below every later split's,
        reaches the best); the subtrees are dealt to the halves longest first.  Each half is a union of whole subtrees,
        so it needs no update matrix from the other, and the rows below its supernodes are its own or the top's.
        Every list is in increasing supernode order."""
        ns = self.supernodes
        parent = self.supernode_parents()
        cost = self.front_costs()
        subtree = cost.copy()
        for s in range(ns):  # children before their parent
            if parent[s] >= 0:
                subtree[parent[s]] += subtree[s]
        frontier = [int(s) for s in np.flatnonzero(parent < 0)]
        top: list[int] = []
        best = None
        total = float(cost.sum())
        for _ in range(min(ns, 1000)):
            top_cost = float(cost[top].sum())
            if best is not None and (total + top_cost) / 2 >= best[0]:
                break  # every makespan from here on is at least (total + cost(top)) / 2, and cost(top) only grows
            loads, halves = [0.0, 0.0], [[], []]
            for s in sorted(frontier, key=lambda s: -subtree[s]):
                g = int(np.argmin(loads))
                loads[g] += subtree[s]
                halves[g].append(s)
            makespan = top_cost + max(loads)
            if best is None or makespan < best[0]:
                best = (makespan, list(top), halves)
            biggest = max(frontier, key=lambda s: subtree[s])
            if not self.children[biggest]:
                break
            frontier.remove(biggest)
            top.append(biggest)
            frontier.extend(self.children[biggest])
        _, top, halves = best
        owner = np.full(ns, -1, dtype=np.int64)  # the half of each supernode, -1: the top
        root_half = {s: g for g, roots in enumerate(halves) for s in roots}
        in_top = set(top)
        for s in range(ns - 1, -1, -1):  # parents before their children
            if s in root_half:
                owner[s] = root_half[s]
            elif s not in in_top:
                owner[s] = owner[parent[s]]
        return [np.flatnonzero(owner == g) for g in (0, 1)], np.flatnonzero(owner < 0)
