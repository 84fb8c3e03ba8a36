"""The CLI contract: spellings, --json keys, errors without tracebacks."""

import json
import subprocess
import sys

import pytest

import blockmpec as bm


def run(*args):
    return subprocess.run([sys.executable, "-m", "blockmpec.cli", *args], capture_output=True, text=True, timeout=300)


def test_solve_json_has_contract_keys():
    p = run("solve", "two-blocks", "--method", "static-lp", "-p", "eta=3", "-p", "mu=0.65", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    for key in ("method", "status", "success", "multiplier", "residuals", "time_s", "iterations"):
        assert key in out
    assert out["method"] == "static-lp" and out["status"] == "optimal" and out["success"] is True
    assert round(out["multiplier"], 5) == 0.41973
    assert isinstance(out["residuals"], dict) and all(isinstance(v, float) for v in out["residuals"].values())


def test_every_case_takes_mu_and_dilatancy():
    for case in bm.cases.CASES:
        params = bm.cases.get_case(case).parameters
        assert "mu" in params and "dilatancy" in params, case


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("solve", "two-blocks", "--method", "nope"), "unknown method 'nope'"),
        (("solve", "no-such-case", "--method", "static-lp"), "unknown case 'no-such-case'"),
        (("solve", "wall", "--method", "static-lp", "-p", "bond=flemish"), "bond: must be 'running' or 'stack'"),
        (("solve", "wall", "--method", "static-lp", "-p", "courses"), "-p 'courses': expected KEY=VALUE"),
        (("solve", "two-blocks", "--method", "static-lp", "-p", "mu=-1"), "friction: must be a finite number >= 0"),
        (("solve", "missing.json", "--method", "static-lp"), "missing.json: cannot read structure file"),
    ],
)
def test_errors_are_one_line_on_stderr(args, message):
    p = run(*args)
    assert p.returncode == 2
    assert message in p.stderr
    assert "Traceback" not in p.stderr and p.stdout == ""


def test_export_then_solve_file(tmp_path):
    path = tmp_path / "arch.json"
    p = run("export", "round-arch", "-p", "n_voussoirs=12", "-o", str(path))
    assert p.returncode == 0, p.stderr
    p = run("solve", str(path), "--method", "kinematic-lp", "-p", "mu=0.5", "--json")
    assert p.returncode == 0, p.stderr
    direct = bm.solve(bm.cases.round_arch(n_voussoirs=12, mu=0.5), "kinematic-lp")
    assert json.loads(p.stdout)["multiplier"] == pytest.approx(direct.multiplier, rel=1e-12)


def test_cases_and_methods_listings():
    p = run("cases")
    assert p.returncode == 0
    for name in ("two-blocks", "single-block", "round-arch", "arch-on-buttresses", "wall", "n_voussoirs", "bond"):
        assert name in p.stdout
    p = run("methods")
    assert p.returncode == 0
    assert "static-lp" in p.stdout and "kinematic-lp" in p.stdout and "algorithm" in p.stdout
    assert "failed to import" not in p.stderr


def test_compare_main_job_prints_tables(tmp_path):
    p = run("compare", "--cases", "two-blocks,round-arch", "--methods", "static-lp,kinematic-lp", "--out", str(tmp_path))
    assert p.returncode == 0, p.stderr
    assert "Collapse multiplier" in p.stdout and "0.41973" in p.stdout and "0.16034" in p.stdout
    assert (tmp_path / "results.csv").exists()
