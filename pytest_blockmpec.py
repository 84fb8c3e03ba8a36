"""blockmpec's pytest plugin: fixtures for the tests of your own methods (entry point ``pytest11``, ``blockmpec``).

pytest loads it in every run where blockmpec is installed.  It imports nothing of blockmpec when it loads and changes
nothing for a project that does not ask for its fixtures (``-p no:blockmpec`` switches it off altogether).

Fixtures
--------
``blockmpec_case``
    Each quick reference case in turn, a :class:`blockmpec.testing.ReferenceCase` (the test runs once per case; the
    ids are the case labels): its ``structure``, ``closed_form(problem)``, ``associative``, ``minimum`` and
    ``bounds(problem)``, each reference with its source.
``blockmpec_cases``
    All quick reference cases, a dict label -> ReferenceCase (session scope).

Example::

    import blockmpec as bm

    def test_mine_within_the_references(blockmpec_case):
        res = bm.solve(blockmpec_case.structure, "mine")
        lower, upper = blockmpec_case.bounds("non-associative")
        assert res.success, res.message
        assert lower.value - 1e-6 <= res.multiplier <= upper.value + 1e-6
"""

import pytest


@pytest.fixture
def blockmpec_case(request):
    """One quick reference case of blockmpec (a ``blockmpec.testing.ReferenceCase``); the test runs once per case."""
    return request.param


@pytest.fixture(scope="session")
def blockmpec_cases():
    """The quick reference cases of blockmpec: label -> ``blockmpec.testing.ReferenceCase``."""
    from blockmpec.testing import reference_cases

    return reference_cases()


def pytest_generate_tests(metafunc):
    """Parametrise the tests that ask for ``blockmpec_case`` (blockmpec is imported only then)."""
    if "blockmpec_case" in metafunc.fixturenames:
        from blockmpec.testing import reference_cases

        cases = list(reference_cases().values())
        metafunc.parametrize("blockmpec_case", cases, ids=[c.label for c in cases], indirect=True)
