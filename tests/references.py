"""The tests' reference multipliers, each with its source, and the independent computation that checks it.

A reference is a closed form, a published value, or a value of the independent statement of the problems in
``tests/independent.py`` (written from the geometry, solved by scipy's linprog and by SCIP): never a value copied
from the library's output.  ``tests/test_references.py`` recomputes every entry of :data:`REFERENCES` (the
associative ones always, with scipy; the non-associative ones in the optional ``scip`` lane) and checks the library
against them; ``python tests/independent.py`` prints them all (the command that produced the values below).

Published values carry their digits only: the paper's Table 1 gives five (its geometry is not ours to the last
digit), so a test compares with the full-precision value here and, separately, rounds to the published digits.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import blockmpec as bm

# ------------------------------------------------------------------ closed forms

#: two blocks at eta = 3, mu = 0.65, associative: A2-1, lam = [eta (1 - mu^2) + mu]^-1 = 1 / 2.3825 (paper Sect. 3,
#: which prints 0.41973)
TWO_BLOCKS_ASSOCIATIVE = 1 / (3 * (1 - 0.65**2) + 0.65)
#: ... and the least multiplier of (3) (psi = 0): 1 / eta since mu > 1 / eta (paper Sect. 3, NA2)
TWO_BLOCKS_MINIMUM = 1 / 3

# ------------------------------------------------------------------ the independent statement (tests/independent.py)

#: ``cases.round_arch()`` (10 voussoirs, radius 1, thickness 0.15, mu = 0.65), associative: the independent static LP;
#: the paper's Table 1 prints 0.16034 for every method (no sliding in the mechanism), and SCIP's least multiplier of
#: (3) is the same 0.1603447650886125
ROUND_ARCH_ASSOCIATIVE = 0.1603447650886125
ROUND_ARCH_PUBLISHED = 0.16034  # the paper's Table 1 (five digits)
#: ``cases.arch_on_buttresses()``: associative (independent LP) and the least multiplier of (3) (SCIP, certified): equal
ARCH_ON_BUTTRESSES_ASSOCIATIVE = 0.11736637355005171
#: ``cases.wall(2, 2)`` and ``cases.wall(3, 2)`` (running bond, mu = 0.65): the least multiplier of (3) is mu (SCIP,
#: certified; the associative one is mu too: the walls slide on their base)
WALL_2X2_MINIMUM = WALL_3X2_MINIMUM = 0.65
#: ``cases.wall(4, 2, bond="stack")``: associative (independent LP) and least multiplier of (3) (SCIP, certified)
STACK_WALL_4X2_ASSOCIATIVE = 0.5540166204986149
STACK_WALL_4X2_MINIMUM = 0.5
#: ``cases.wall(4, 3)`` (running bond): associative (independent LP), and 7/11, a solution of (3): SCIP finds one at
#: 7/11 and the least lam over its pattern of active pairs is exactly 7/11 (the library's milp certifies 7/11 as the
#: least multiplier of (3) in 24 s; SCIP does not certify it within 20 minutes, its bound stays at 0)
WALL_4X3_ASSOCIATIVE = 0.6415508412582297
WALL_4X3_MINIMUM = 7 / 11
#: the README's wall ``cases.wall(6, 4, mu=0.65)``: associative (independent LP, 0.5976), and 11/19 = 0.5789, a solution
#: of (3) (SCIP finds one at 11/19, the least lam over its pattern), which the fixed point returns; not certified least
README_WALL_ASSOCIATIVE = 0.5975794251134644
README_WALL_FIXED_POINT = 11 / 19
#: issue 41's door wall (3 courses of 1 x 0.5 blocks, 3 per course, the bottom middle one left out, mu = 0.65): the
#: least multiplier of (3), certified by SCIP (8 s)
DOOR_WALL_MINIMUM = 0.5852298662141963
#: the side-friction wall (3 x 3 stack bond, bottom middle block left out): associative (independent LP); (3) has no
#: solution (SCIP proves the MPEC infeasible)
SIDE_FRICTION_WALL_ASSOCIATIVE = 0.15966574647466986
#: Ferris & Tin-Loi's wall 1 (``cases.ferris_tinloi()``): associative (independent LP; the paper publishes about
#: 0.643, see cases.py), and the fixed point's 0.63997, a solution of (3) (SCIP finds one there, 21 s; the least lam over
#: its pattern is 0.6391497569, below it): not a minimum
FERRIS_TINLOI_ASSOCIATIVE = 0.6428590033139113
FERRIS_TINLOI_FIXED_POINT = 0.6399685551655289


def door_wall() -> bm.Structure:
    return bm.cases.wall(courses=3, blocks_per_course=3, block_length=1, block_height=0.5,
                         openings=[(1.0, 0.0, 2.0, 0.5)], mu=0.65)


def side_friction_wall() -> bm.Structure:
    return bm.cases.wall(3, 3, bond="stack", openings=[(1.0, 0.0, 2.0, 0.5)], mu=0.65)


@dataclass(frozen=True)
class Reference:
    """One reference: ``kind`` is "associative" (the optimum of (1)), "minimum" (the least multiplier of (3),
    problem (4)), "solution" (a multiplier of (3), not necessarily the least) or "no solution" (``value`` None: (3) has none); ``seconds`` roughly what SCIP needs
    (the slow ones run only in the full suite)."""

    name: str
    build: Callable[[], bm.Structure]
    kind: str
    value: float | None
    seconds: float = 1.0


REFERENCES = [
    Reference("two-blocks", lambda: bm.cases.two_blocks(eta=3, mu=0.65), "associative", TWO_BLOCKS_ASSOCIATIVE),
    Reference("two-blocks", lambda: bm.cases.two_blocks(eta=3, mu=0.65), "minimum", TWO_BLOCKS_MINIMUM),
    Reference("round-arch", bm.cases.round_arch, "associative", ROUND_ARCH_ASSOCIATIVE),
    Reference("round-arch", bm.cases.round_arch, "minimum", ROUND_ARCH_ASSOCIATIVE),
    Reference("arch-on-buttresses", bm.cases.arch_on_buttresses, "associative", ARCH_ON_BUTTRESSES_ASSOCIATIVE),
    Reference("arch-on-buttresses", bm.cases.arch_on_buttresses, "minimum", ARCH_ON_BUTTRESSES_ASSOCIATIVE),
    Reference("wall-2x2", lambda: bm.cases.wall(2, 2), "minimum", WALL_2X2_MINIMUM),
    Reference("wall-3x2", lambda: bm.cases.wall(3, 2), "minimum", WALL_3X2_MINIMUM),
    Reference("wall-4x2-stack", lambda: bm.cases.wall(4, 2, bond="stack"), "associative", STACK_WALL_4X2_ASSOCIATIVE),
    Reference("wall-4x2-stack", lambda: bm.cases.wall(4, 2, bond="stack"), "minimum", STACK_WALL_4X2_MINIMUM),
    Reference("wall-4x3", lambda: bm.cases.wall(4, 3), "associative", WALL_4X3_ASSOCIATIVE),
    Reference("wall-4x3", lambda: bm.cases.wall(4, 3), "solution", WALL_4X3_MINIMUM),
    Reference("readme-wall-6x4", lambda: bm.cases.wall(6, 4, mu=0.65), "associative", README_WALL_ASSOCIATIVE),
    Reference("readme-wall-6x4", lambda: bm.cases.wall(6, 4, mu=0.65), "solution", README_WALL_FIXED_POINT),
    Reference("door-wall", door_wall, "minimum", DOOR_WALL_MINIMUM, seconds=8.0),
    Reference("side-friction-wall", side_friction_wall, "associative", SIDE_FRICTION_WALL_ASSOCIATIVE),
    Reference("side-friction-wall", side_friction_wall, "no solution", None),
    Reference("ferris-tinloi", bm.cases.ferris_tinloi, "associative", FERRIS_TINLOI_ASSOCIATIVE),
    Reference("ferris-tinloi", bm.cases.ferris_tinloi, "solution", FERRIS_TINLOI_FIXED_POINT, seconds=21.0),
]


def recompute(ref: Reference, time_limit: float = 600.0):
    """The independent value of ``ref`` and a note (None for a non-associative one without pyscipopt):
    the associative optimum, SCIP's polished minimum, or, for a "solution", ``ref.value`` if SCIP finds a solution of
    (3) there and ``ref.value`` lies in the range of lam over its pattern of active pairs (else that range's nearer
    end; None if SCIP finds none)."""
    import independent

    structure = ref.build()
    if ref.kind == "associative":
        return independent.associative_multiplier(structure), "static LP (1), scipy linprog"
    at = ref.value if ref.kind == "solution" else None
    found = independent.mpec(structure, at=at, time_limit=time_limit)
    if found is None:
        return None, "pyscipopt not installed"
    if ref.kind == "solution":
        if found.lam_range is None:
            return None, f"SCIP: {found.status}, no solution of (3) at {ref.value!r}"
        low, high = found.lam_range
        return min(max(ref.value, low), high), f"SCIP: a solution of (3) there; its pattern's lam in [{low}, {high}]"
    if ref.kind == "no solution":
        return None, f"SCIP: {found.status}"
    return found.multiplier, f"SCIP: {found.status}, bound {found.bound!r}"


def report() -> None:
    """Print every reference beside its independent recomputation."""
    for ref in REFERENCES:
        t0 = time.perf_counter()
        value, note = recompute(ref)
        seconds = time.perf_counter() - t0
        print(f"{ref.name:20s} {ref.kind:12s} pinned {ref.value!r:22s} independent {value!r:22s} "
              f"({seconds:.1f} s; {note})", flush=True)
