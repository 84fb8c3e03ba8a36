"""Methods from outside blockmpec: plug-ins found by entry point, classes named ``module:Class``, the conformance suite
that judges them, the cross-check between methods and the pytest plugin.

A plug-in is "installed" here without pip: a ``*.dist-info`` folder (the metadata pip writes) with an
``entry_points.txt`` in a temporary folder on ``sys.path``, pointing at classes of ``tests/plugin_solvers.py`` or of
the worked example ``examples/blockmpec-linprog`` (``.ci/run`` installs that one with pip and runs its own tests).
The comparator's worker processes get the same ``sys.path``, so they find the same distributions.
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
import warnings
from pathlib import Path

import plugin_solvers
import pytest

import blockmpec as bm
from blockmpec import registry
from blockmpec.cli import main
from blockmpec.errors import PluginWarning
from blockmpec.testing import CHECKS, ConformanceError, Reference, ReferenceCase, assert_methods_agree, check_solver
from blockmpec.testing import reference_cases as all_reference_cases

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "blockmpec-linprog" / "src"
TESTS = Path(__file__).resolve().parent
_versions = itertools.count()
#: the paper's two blocks at eta = 3, mu = 0.65 (Sect. 3): associative lam 0.41973 (mechanism A2-1), minimum 1/3
TWO_BLOCKS = bm.cases.two_blocks(eta=3.0, mu=0.65)
ASSOCIATIVE = bm.cases.closed_form("two-blocks", "associative", eta=3.0, mu=0.65)


def write_distribution(folder: Path, entry_points: dict[str, str], name: str = "blockmpec-test-plugins") -> str:
    """An installed distribution's metadata in ``folder``: ``name``, a version of its own (each entry point is tried
    once per process and version) and ``entry_points`` in the group ``blockmpec.methods``; returns "name version"."""
    version = f"1.0.{next(_versions)}"
    info = folder / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    lines = "".join(f"{key} = {value}\n" for key, value in entry_points.items())
    (info / "entry_points.txt").write_text(f"[blockmpec.methods]\n{lines}")
    return f"{name} {version}"


@pytest.fixture
def install(tmp_path, monkeypatch):
    """``install(entry_points) -> "name version"``: a plug-in distribution on ``sys.path`` for this test (the worked
    example's source folder too); the methods it added are unregistered afterwards."""
    before = set(bm.list_solvers())
    monkeypatch.syspath_prepend(str(EXAMPLE))

    def run(entry_points: dict[str, str]) -> str:
        folder = tmp_path / f"site-{next(_versions)}"
        dist = write_distribution(folder, entry_points)
        monkeypatch.syspath_prepend(str(folder))
        return dist

    yield run
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginWarning)  # broken plug-ins were warned about in the test
        added = set(bm.list_solvers()) - before
    for name in added:
        registry.unregister_solver(name)


def cli(*args) -> tuple[int, str, str]:
    """``blockmpec ARGS`` in this process (the current folder is the test's): exit code, stdout, stderr."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


# --------------------------------------------------------------------------- discovery


def test_an_installed_plugin_is_a_method_like_the_built_in_ones(install):
    dist = install({"test-plugin-lp": "plugin_solvers:DelegatingLP"})
    names = bm.list_solvers()
    assert "test-plugin-lp" in bm.list_solvers("associative") and names.index("test-plugin-lp") > names.index("milp")
    assert bm.get_solver("test-plugin-lp") is plugin_solvers.DelegatingLP
    assert registry.solver_source("test-plugin-lp") == \
        f"plug-in test-plugin-lp = plugin_solvers:DelegatingLP (entry point of {dist})"
    assert registry.solver_source("static-lp") == "built-in"
    res = bm.solve(TWO_BLOCKS, "test-plugin-lp")
    assert res.success and res.method == "test-plugin-lp"
    assert res.multiplier == pytest.approx(ASSOCIATIVE, rel=1e-12)  # HiGHS's optimum: 6e-17 from the closed form


def test_broken_plugins_are_one_warning_line_each_and_the_rest_works(install, tmp_path):
    dist = install({"test-plugin-lp": "plugin_solvers:DelegatingLP",
                    "test-broken-import": "no_such_module_for_blockmpec_tests:Solver",
                    "test-not-a-method": "plugin_solvers:NOT_A_SOLVER",
                    "static-lp": "plugin_solvers:NamedLikeABuiltIn",
                    "test-other-name": "plugin_solvers:DelegatingLP"})
    with pytest.warns(PluginWarning) as caught:
        names = bm.list_solvers()
    messages = sorted(str(w.message) for w in caught)
    assert len(messages) == 4 and all("\n" not in m and f"(entry point of {dist}) not loaded: " in m for m in messages)
    reasons = {m.split(" = ")[0].removeprefix("method plug-in "): m for m in messages}
    assert "ModuleNotFoundError" in reasons["test-broken-import"] and "no_such_module_for_blockmpec_tests" in \
        reasons["test-broken-import"]
    assert "is not a subclass of blockmpec.SolverBase" in reasons["test-not-a-method"]
    assert "the name 'static-lp' is taken by the built-in method" in reasons["static-lp"]
    assert "the entry point's name 'test-other-name' and the class's name 'test-plugin-lp' differ" in \
        reasons["test-other-name"]
    assert "test-plugin-lp" in names and not {"test-broken-import", "test-not-a-method", "test-other-name"} & set(names)
    assert bm.get_solver("static-lp") is not plugin_solvers.NamedLikeABuiltIn  # a built-in name always wins
    assert {f.entry_point.split(" = ")[0] for f in registry.plugin_failures()} >= set(reasons)


def test_the_command_line_lists_plugins_warns_in_one_line_and_imports_them_lazily(install, tmp_path):
    dist = install({"test-plugin-lp": "plugin_solvers:DelegatingLP",
             "test-broken-import": "no_such_module_for_blockmpec_tests:Solver"})
    code = ("import sys, blockmpec\n"
            "assert not {'plugin_solvers', 'blockmpec.solvers'} & set(sys.modules), 'loaded at import'\n"
            "from blockmpec.cli import main\n"
            "sys.exit(main(['methods']))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                          env={**_environ(), "PYTHONPATH": ":".join(sys.path)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.splitlines() == [
        f"blockmpec: warning: method plug-in test-broken-import = no_such_module_for_blockmpec_tests:Solver (entry "
        f"point of {dist}) not loaded: importing it raised ModuleNotFoundError: No module named "
        "'no_such_module_for_blockmpec_tests'"]
    line = next(t for t in proc.stdout.splitlines() if t.startswith("test-plugin-lp "))
    assert "[associative]" in line and "; plug-in test-plugin-lp = plugin_solvers:DelegatingLP" in line


def _environ() -> dict[str, str]:
    import os

    return {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def test_a_class_path_names_a_method_that_is_not_installed(tmp_path, monkeypatch):
    res = bm.solve(TWO_BLOCKS, "plugin_solvers:DelegatingLP")
    assert res.success and res.method == "test-plugin-lp"
    assert "plugin_solvers:DelegatingLP" not in bm.list_solvers() and "test-plugin-lp" not in bm.list_solvers()
    assert registry.solver_source("plugin_solvers:DelegatingLP") == "class plugin_solvers:DelegatingLP"
    for name, error, message in (
            ("plugin_solvers:NOT_A_SOLVER", bm.OptionError, "'a string, not a SolverBase subclass' is not a subclass"),
            ("plugin_solvers:NoSuchClass", bm.UnknownNameError, "module plugin_solvers has no 'NoSuchClass'"),
            ("no_such_module_for_blockmpec_tests:X", bm.UnknownNameError, "no module named"),
            ("plugin_solvers:NamedLikeABuiltIn", bm.OptionError, "its name 'static-lp' is taken by the built-in"),
            (":X", bm.UnknownNameError, "expected a method name or MODULE:CLASS")):
        with pytest.raises(error, match=message) as caught:
            bm.solve(TWO_BLOCKS, name)
        assert "\n" not in str(caught.value)
    # the command line finds a module in the current folder, as `python -m` does
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_method.py").write_text("from plugin_solvers import DelegatingLP\n\n\n"
                                           "class MyMethod(DelegatingLP):\n    name = 'my-method'\n")
    code, out, err = cli("solve", "two-blocks", "--method", "my_method:MyMethod", "--json")
    assert code == 0, err
    assert json.loads(out)["method"] == "my-method" and json.loads(out)["success"]
    code, _, err = cli("solve", "two-blocks", "--method", "plugin_solvers:NOT_A_SOLVER")
    assert code == 2 and err.startswith("blockmpec: error: method 'plugin_solvers:NOT_A_SOLVER': ")


# --------------------------------------------------------------------------- in the comparison


def test_plugins_and_class_paths_are_compared_on_equal_terms(install, tmp_path, monkeypatch):
    """The worked example's two methods (entry points), a class named by its module and two built-in methods, in one
    ``blockmpec compare``: every solve in a worker process, which finds the plug-ins itself."""
    install({"linprog": "blockmpec_linprog:StaticLinprog",
             "linprog-fixed-point": "blockmpec_linprog:FixedPointLinprog"})
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_method.py").write_text("from plugin_solvers import DelegatingLP\n\n\n"
                                           "class MyMethod(DelegatingLP):\n    name = 'my-method'\n")
    methods = "linprog,linprog-fixed-point,my_method:MyMethod,static-lp,fixed-point"
    code, out, err = cli("compare", "--cases", "two-blocks", "--methods", methods, "--out", "out", "--quiet",
                         "--no-figures")
    assert code == 0, err
    for label in methods.split(","):
        assert label in out
    import pandas as pd

    rows = pd.read_csv(tmp_path / "out" / "results.csv").set_index("method_label")
    assert set(rows.index) == set(methods.split(","))
    assert rows["success"].all(), rows[["status", "message"]]
    # the closed forms of the paper's Sect. 3 (eta = 3, mu = 0.65): associative 0.41973, minimum 1/3; the LPs reach
    # them to 6e-17, the fixed points' points of (3) lie in between
    for label in ("linprog", "my_method:MyMethod", "static-lp"):
        assert rows.loc[label, "multiplier"] == pytest.approx(ASSOCIATIVE, rel=1e-12)
    for label in ("linprog-fixed-point", "fixed-point"):
        assert 1 / 3 - 1e-12 <= rows.loc[label, "multiplier"] <= ASSOCIATIVE + 1e-12
        assert rows.loc[label, "reference_source"] == "closed-form" and pd.isna(rows.loc[label, "anomaly"])


@pytest.mark.slow
def test_plugins_run_on_dask(install):
    from blockmpec.bench.compare import compare

    install({"test-plugin-lp": "plugin_solvers:DelegatingLP"})
    df = compare({"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}, ["test-plugin-lp", "static-lp"], n_jobs=1,
                 backend="dask", progress=False)
    assert list(df["status"]) == ["optimal", "optimal"], df["message"].tolist()
    assert df["multiplier"].tolist() == pytest.approx([ASSOCIATIVE, ASSOCIATIVE], rel=1e-12)


def test_a_class_defined_in_the_running_script_is_refused_before_the_workers_start():
    from blockmpec.bench.compare import compare

    cls = type("ScriptMethod", (plugin_solvers.DelegatingLP,), {"name": "test-script-method", "__module__": "__main__"})
    registry.register_solver(cls)
    try:
        with pytest.raises(bm.OptionError, match="defined in the script being run"):
            compare({"two-blocks": ("two-blocks", {})}, ["test-script-method"], progress=False)
    finally:
        registry.unregister_solver("test-script-method")


# --------------------------------------------------------------------------- the conformance suite


def test_the_worked_example_and_a_delegating_plugin_pass_the_conformance_suite(install):
    install({"linprog": "blockmpec_linprog:StaticLinprog",
             "linprog-fixed-point": "blockmpec_linprog:FixedPointLinprog"})
    for solver in ("linprog", "linprog-fixed-point", plugin_solvers.DelegatingLP):
        table = check_solver(solver)
        assert table["passed"].all() and len(table) >= 40


@pytest.mark.parametrize(("broken", "failed"), [
    # a multiplier 1 % off: its point no longer balances the loads, and it still claims optimal
    (plugin_solvers.LambdaOnePercentOff, {"honesty", "closed-form"}),
    # infeasible where the closed form (or the static LP) shows a solution
    (plugin_solvers.FalseInfeasible, {"honesty", "closed-form"}),
    # a deadline that had passed before the run began, ignored
    (plugin_solvers.IgnoresTimeLimit, {"time-limit"}),
    # scale="not-a-number" accepted
    (plugin_solvers.UncheckedOption, {"options.value"}),
])
def test_a_broken_plugin_fails_the_checks_that_name_what_is_broken(broken, failed):
    with pytest.raises(AssertionError) as caught:
        check_solver(broken)
    assert isinstance(caught.value, ConformanceError)
    table = caught.value.checks
    bad = table[~table["passed"]]
    assert set(bad["check"]) == failed
    for row in bad.itertuples():  # the message names every failed check and what it found
        assert f"  {row.check}[{row.subject}]: {row.message}" in str(caught.value)
    first = bad.iloc[0]
    expected = {plugin_solvers.LambdaOnePercentOff: "claims optimal but is not verified: equilibrium residual",
                plugin_solvers.FalseInfeasible: "claims infeasible, but a solution is known: lam = 0.4197271773",
                plugin_solvers.IgnoresTimeLimit: "returned optimal although its deadline",
                plugin_solvers.UncheckedOption: "scale='not-a-number' was accepted"}[broken]
    assert expected in first["message"]


@pytest.mark.slow
def test_the_full_suite_adds_the_larger_cases():
    """``quick=False``: ferris-tinloi and the default sizes too (for an associative method the references are LPs,
    so this takes seconds; a non-associative one waits for milp's certificates)."""
    table = check_solver("static-lp", quick=False)
    larger = [label for label, case in all_reference_cases(quick=False).items() if not case.quick]
    assert "ferris-tinloi" in larger and set(larger) <= set(table["subject"])
    ferris = table[(table["check"] == "case") & (table["subject"] == "ferris-tinloi")].iloc[0]
    # Ferris & Tin-Loi (2001) publish "about 0.643"; the static LP gives 0.642859 (blockmpec.cases.ferris_tinloi)
    assert ferris["passed"] and round(ferris["multiplier"], 3) == 0.643
    assert ferris["reference_source"] == "kinematic LP (2) by kinematic-lp, verified"


def test_the_guide_explains_every_check():
    page = (ROOT / "docs" / "guide" / "your-own-method.md").read_text()
    assert [check for check in CHECKS if f"`{check}`" not in page] == []


def test_the_table_can_be_read_without_raising():
    table = check_solver(plugin_solvers.IgnoresTimeLimit, raise_on_failure=False)
    assert table.loc[~table["passed"], "check"].tolist() == ["time-limit"]
    with pytest.raises(TypeError, match="check_solver needs a SolverBase subclass"):
        check_solver(42)


# --------------------------------------------------------------------------- cross-checks


def test_methods_that_should_agree_agree_and_the_others_are_named(monkeypatch):
    case = all_reference_cases()["wall[courses=4,blocks_per_course=2,bond=stack]"].structure
    # the minimum (certified by milp) is 0.5 and nlp's local minimum reaches it; the LPs agree on 0.554017
    results = assert_methods_agree(case, ["milp", "nlp", "static-lp", ("kinematic-lp", {"time_limit": 60})])
    assert set(results) == {"milp", "nlp", "static-lp", "kinematic-lp[time_limit=60]"}
    with pytest.raises(AssertionError, match=r"slp did not succeed: numerical"):
        assert_methods_agree(case, ["static-lp", "slp"])  # slp's point is not a solution of (3) here
    # two solutions of (3) of the two blocks: the fixed point's 1/3 and the example's associative point, 0.41973
    monkeypatch.syspath_prepend(str(EXAMPLE))
    with pytest.raises(AssertionError) as caught:
        assert_methods_agree(TWO_BLOCKS, ["fixed-point", "blockmpec_linprog:FixedPointLinprog",
                                          "plugin_solvers:LambdaOnePercentOff"])
    message = str(caught.value)
    assert "blockmpec_linprog:FixedPointLinprog (lam = 0.419727177335) and fixed-point (lam = 0.333333333333) " \
           "disagree beyond rtol = 1e-06 on the non-associative problem" in message
    assert "plugin_solvers:LambdaOnePercentOff did not succeed: numerical" in message


# --------------------------------------------------------------------------- the pytest plugin


def test_the_pytest_fixture_runs_a_test_once_per_reference_case(blockmpec_case):
    assert isinstance(blockmpec_case, ReferenceCase) and blockmpec_case.label in all_reference_cases()
    assert isinstance(blockmpec_case.structure, (bm.Structure, bm.three_d.Structure3D))
    lower, upper = blockmpec_case.bounds("non-associative")
    assert isinstance(lower, Reference) and lower.source and upper.source
    # every quick case has a certified or closed-form minimum, never above the associative multiplier
    assert lower.exact and lower.value <= upper.value + 1e-9 * max(1.0, upper.value)


def test_the_pytest_fixture_of_all_cases(blockmpec_cases):
    assert list(blockmpec_cases) == list(all_reference_cases())


def test_the_pytest_plugin_imports_nothing_and_changes_nothing_where_unused(tmp_path):
    (tmp_path / "test_plain.py").write_text(
        "import sys\n\n\ndef test_plain():\n"
        "    assert 'pytest_blockmpec' in sys.modules  # loaded by its entry point\n"
        "    assert not [m for m in sys.modules if m.split('.')[0] in ('blockmpec', 'numpy', 'pandas')]\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_plain.py"],
                          capture_output=True, text=True, cwd=tmp_path, env=_environ())
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "1 passed" in proc.stdout
