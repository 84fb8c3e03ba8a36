"""The reference values of ``tests/references.py`` against the independent statement (``tests/independent.py``), and
the library against them.

* Associative references (always run): the independent static LP (scipy's linprog on operators written from the
  geometry) reproduces the pinned value to 1e-12, and ``static-lp`` and ``kinematic-lp`` reach it to 1e-9.
* Non-associative references (the ``scip`` lane: ``pytest -m scip``; skipped, saying so, without pyscipopt): SCIP
  with SOS1 pairs reproduces each certified minimum, each quoted solution of (3), and the one proof that (3) has no
  solution; the slow ones (SCIP over 5 s) also carry ``slow``.  The lane also checks ``milp``'s
  certificates (both senses) against SCIP's.
* The independent statement itself against closed forms, so that it is checked before it checks anything.
"""

import independent
import pytest
from references import (
    REFERENCES,
    ROUND_ARCH_ASSOCIATIVE,
    ROUND_ARCH_PUBLISHED,
    STACK_WALL_4X2_ASSOCIATIVE,
    STACK_WALL_4X2_MINIMUM,
    TWO_BLOCKS_ASSOCIATIVE,
    TWO_BLOCKS_MINIMUM,
    Reference,
    recompute,
)

import blockmpec as bm

#: the pinned values are the independent statement's own, printed to 16 digits (python tests/independent.py):
#: recomputed, they agree to 1e-16; 1e-12 leaves room for another BLAS or HiGHS build
PINNED = 1e-12
#: static-lp and kinematic-lp against the independent LP: 1.7e-13 at most measured (the round arch), relative
LIBRARY = 1e-9

needs_scip = pytest.mark.skipif(not independent.HAS_SCIP, reason="the SCIP lane needs pyscipopt (pip install pyscipopt)")


def _param(ref: Reference):
    marks = []
    if ref.kind != "associative":
        marks += [pytest.mark.scip, needs_scip] + ([pytest.mark.slow] if ref.seconds > 5 else [])
    return pytest.param(ref, id=f"{ref.name}-{ref.kind.replace(' ', '-')}", marks=marks)


@pytest.mark.parametrize("ref", [_param(r) for r in REFERENCES])
def test_the_independent_statement_reproduces_the_reference(ref):
    value, note = recompute(ref)
    if ref.value is None:
        assert value is None and note == "SCIP: infeasible", note
    else:
        assert value == pytest.approx(ref.value, rel=PINNED, abs=PINNED), note


@pytest.mark.parametrize("ref", [_param(r) for r in REFERENCES if r.kind == "associative"])
@pytest.mark.parametrize("method", ["static-lp", "kinematic-lp"])
def test_the_associative_lps_reach_the_reference(ref, method):
    res = bm.solve(ref.build(), method)
    assert res.success, res.message
    assert res.multiplier == pytest.approx(ref.value, rel=LIBRARY)


def test_the_round_arch_reference_rounds_to_the_papers_table_1():
    assert round(ROUND_ARCH_ASSOCIATIVE, 5) == ROUND_ARCH_PUBLISHED


@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (1.5, 0.3), (5, 1.2), (0.5, 0.5)])
def test_the_independent_lp_meets_the_two_block_closed_form(eta, mu):
    """The closed forms of the paper's Sect. 3 (blockmpec.cases.closed_form), on both sides of its regions."""
    structure = bm.cases.two_blocks(eta=eta, mu=mu)
    expected = bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu)
    assert independent.associative_multiplier(structure) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(("width", "height", "mu"), [(1, 2, 0.65), (1, 1, 0.3), (2, 1, 1.5)])
def test_the_independent_lp_meets_the_single_block_closed_form(width, height, mu):
    structure = bm.cases.single_block(width=width, height=height, mu=mu)
    assert independent.associative_multiplier(structure) == pytest.approx(min(mu, width / height), rel=1e-12)


@pytest.mark.scip
@needs_scip
@pytest.mark.parametrize(("eta", "mu"), [(3, 0.65), (1.5, 0.3), (5, 1.2)])
def test_scip_meets_the_two_block_closed_forms(eta, mu):
    """Least multiplier of (3) (psi = 0): mu if mu <= 1/eta else 1/eta; the largest: the associative one (Sect. 3)."""
    structure = bm.cases.two_blocks(eta=eta, mu=mu)
    least, largest = independent.mpec(structure, "min"), independent.mpec(structure, "max")
    assert least.status == largest.status == "optimal"
    assert least.multiplier == pytest.approx(min(mu, 1 / eta), rel=1e-12)
    assert largest.multiplier == pytest.approx(bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu),
                                               rel=1e-12)


@pytest.mark.scip
@needs_scip
@pytest.mark.parametrize(("name", "build", "least", "largest"), [
    ("two-blocks", lambda: bm.cases.two_blocks(eta=3, mu=0.65), TWO_BLOCKS_MINIMUM, TWO_BLOCKS_ASSOCIATIVE),
    ("wall-4x2-stack", lambda: bm.cases.wall(4, 2, bond="stack"), STACK_WALL_4X2_MINIMUM, STACK_WALL_4X2_ASSOCIATIVE),
    ("round-arch", bm.cases.round_arch, ROUND_ARCH_ASSOCIATIVE, ROUND_ARCH_ASSOCIATIVE),
], ids=lambda v: v if isinstance(v, str) else "")
def test_milp_certifies_what_scip_certifies(name, build, least, largest):
    """milp (its default engines) against SCIP's SOS1 model of (4) (tests/independent.py), both senses: the same
    certified least and largest multipliers of (3), and those of the references (the largest is the associative
    one)."""
    structure = build()
    for sense, expected in (("min", least), ("max", largest)):
        res = bm.solve(structure, "milp", sense=sense)
        assert res.status is bm.Status.OPTIMAL and res.success, (sense, res.message)
        scip = independent.mpec(structure, sense)
        assert scip.status == "optimal", sense
        assert res.multiplier == pytest.approx(scip.multiplier, rel=1e-9), sense
        assert res.multiplier == pytest.approx(expected, rel=1e-9), sense
