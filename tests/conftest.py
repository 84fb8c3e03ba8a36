"""Fixtures, and a guard that the tests run against the *installed* package.

``python -m pytest`` puts the working directory first on ``sys.path``, where the
source folder ``blockmpec/`` would shadow the installed package; but
``blockmpec.formulations`` and ``blockmpec.solvers`` exist only in the install
(``pyproject.toml`` maps the top-level ``formulations/`` and ``solvers/`` folders
into ``blockmpec``).  So the repository root is taken off ``sys.path`` before
anything imports ``blockmpec``.  An editable install (``pip install -e .``)
serves the source folders through its own finder.
"""

import sys
from pathlib import Path

_ROOT = Path(__file__).resolve().parents[1]
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _ROOT]

import os  # noqa: E402

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

import blockmpec as bm  # noqa: E402

#: property tests (hypothesis) draw the same examples on every run and machine (a failure reproduces; CI never
#: passes by luck); no deadline: an example is a solve, whose time depends on the machine's load
settings.register_profile("blockmpec", derandomize=True, database=None, deadline=None, print_blob=True)
settings.load_profile("blockmpec")

_MUTATION = Path(__file__).resolve().parent / "mutation"


def pytest_addoption(parser):
    parser.addoption(
        "--zero-residual", metavar="NAME", default=None,
        help="the verifier mutation check: run with the verifier's residual NAME always 0 (blockmpec.verify."
             "RESIDUAL_NAMES), in this process and in every Python process the tests start; the tests that catch "
             "it fail (see tests/README.md and studies/lab/verifier_mutation.py)")


def pytest_configure(config):
    """``--zero-residual NAME``: zero that residual here and, through ``tests/mutation/sitecustomize.py`` on
    ``PYTHONPATH``, in the processes the tests start."""
    name = config.getoption("zero_residual")
    if not name:
        return
    sys.path.insert(0, str(_MUTATION))
    from sitecustomize import VARIABLE, zero_residual

    try:
        zero_residual(name)
    except ValueError as exc:
        raise pytest.UsageError(str(exc)) from None
    os.environ[VARIABLE] = name
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(_MUTATION), os.environ.get("PYTHONPATH")]))


def pytest_report_header(config):
    name = config.getoption("zero_residual")
    return f"verifier mutation: the residual {name!r} is always 0" if name else None


@pytest.fixture(scope="session")
def builtin_structures():
    """One default instance of every built-in case."""
    return {name: spec.build() for name, spec in bm.cases.CASES.items()}


def pytest_collection_modifyitems(config, items):
    """Timing benchmarks (``@pytest.mark.benchmark``) run only when a ``-m`` expression names them (``-m benchmark``).

    pyproject's ``addopts`` deselects them with ``-m "not benchmark"``, but a ``-m`` on the command line replaces that
    one: without this hook the fast command ``python -m pytest -m "not slow"`` would run them."""
    if "benchmark" in (config.getoption("markexpr") or ""):
        return
    kept = [item for item in items if item.get_closest_marker("benchmark") is None]
    if len(kept) < len(items):
        config.hook.pytest_deselected(items=[item for item in items if item.get_closest_marker("benchmark") is not None])
        items[:] = kept
