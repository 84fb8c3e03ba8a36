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


# --------------------------------------------------------------------------- exit codes and bad values (issues 15, 16)


def test_solve_exit_code_says_whether_the_success_is_verified():
    ok = run("solve", "two-blocks", "--method", "static-lp", "--json")
    assert ok.returncode == 0 and json.loads(ok.stdout)["success"] is True
    # a tolerance no round-off meets: the run finishes, its status says why it is not a success
    strict = run("solve", "wall", "--method", "kinematic-lp", "--verify-tol", "1e-300", "--json")
    out = json.loads(strict.stdout)
    assert strict.returncode == 1 and out["success"] is False and out["status"] == "numerical"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("solve", "two-blocks", "--method", "static-lp", "-p", "mu=abc"), "-p mu=abc: case 'two-blocks' expects a number"),
        (("solve", "wall", "--method", "static-lp", "-p", "bond=3"), "-p bond=3: case 'wall' expects a string"),
        (("solve", "two-blocks", "--method", "static-lp", "--verify-tol", "-1"), "--verify-tol: must be a finite number > 0"),
        (("solve", "two-blocks", "--method", "static-lp", "--verify-tol", "nan"), "--verify-tol: must be a finite number"),
        (("solve", "two-blocks", "--method", "static-lp", "--verify-tol", "abc"), "--verify-tol: must be a finite number"),
        (("export", "two-blocks", "-o", "/no/such/folder/x.json"), "folder /no/such/folder does not exist"),
        (("compare", "--out", "/dev/null", "--methods", "static-lp"), "/dev/null: exists and is not a folder"),
        (("compare", "--cases", "nope", "--methods", "static-lp"), "--cases: 'nope' is not a suite case"),
        (("compare", "--jobs", "0", "--methods", "static-lp"), "jobs: must be an integer >= 1"),
        (("compare", "--scheduler", "tcp://127.0.0.1:1", "--methods", "static-lp"), "scheduler"),
        (("compare", "--wall-limit", "-3", "--methods", "static-lp"), "--wall-limit -3"),
        (("compare", "--verify-tol", "nan", "--methods", "static-lp"), "--verify-tol"),
        (("compare", "--config", "missing-study.toml"), "cannot read the study file"),
    ],
)
def test_bad_values_are_one_line_with_exit_2_before_any_solve(args, message, tmp_path):
    import time

    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "blockmpec.cli", *args], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    assert message in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert "Traceback" not in p.stderr and p.stdout == ""
    assert not (tmp_path / "blockmpec-output" / "rows.jsonl").exists()  # nothing ran
    assert time.perf_counter() - t0 < 60


def test_compare_refuses_a_folder_with_results_unless_told(tmp_path):
    (tmp_path / "results.csv").write_text("an earlier run")
    p = run("compare", "--cases", "single-block", "--methods", "static-lp", "--out", str(tmp_path), "--no-figures")
    assert p.returncode == 2 and "--overwrite" in p.stderr and "--resume" in p.stderr
    p = run("compare", "--cases", "single-block", "--methods", "static-lp", "--out", str(tmp_path), "--no-figures",
            "--overwrite", "--quiet")
    assert p.returncode == 0, p.stderr
    assert "an earlier run" not in (tmp_path / "results.csv").read_text()


def test_compare_takes_builtin_cases_and_structure_files(tmp_path):
    from blockmpec.structure_file import save_structure

    save_structure(bm.cases.single_block(width=1.0, height=4.0), tmp_path / "tall.json")
    out = tmp_path / "out"
    p = run("compare", "--cases", f"single-block,{tmp_path / 'tall.json'},two-blocks", "--methods",
            "static-lp,fixed-point", "--out", str(out), "--quiet", "--jobs", "2", "--no-figures")
    assert p.returncode == 0, p.stderr
    import pandas as pd

    df = pd.read_csv(out / "results.csv").set_index(["case", "method"])
    assert df.loc[("single-block", "static-lp"), "multiplier"] == pytest.approx(0.5, rel=1e-9)  # min(mu, b/h)
    assert df.loc[("tall", "static-lp"), "multiplier"] == pytest.approx(0.25, rel=1e-9)
    assert df.loc[("two-blocks", "fixed-point"), "reference_source"] == "closed-form"
    assert (out / "results.parquet").exists() and (out / "summary.csv").exists()
    meta = json.loads((out / "run.json").read_text())
    assert meta["settings"]["jobs"] == 2 and meta["rows"] == 6 and meta["versions"]["highspy"]
    from blockmpec.bench.runner import usable_cpus

    assert meta["settings"]["cpus_per_solve"] == max(1, usable_cpus() // 2)  # two solves side by side share them
    assert "Summary (solved" in p.stdout
    assert not (out / ".blockmpec.lock").exists()


def test_compare_reads_a_study_file(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(
        'repeat = 2\n[wall_limits]\nfixed-point = 100\n'
        '[[cases]]\nlabel = "sb-tall"\ncase = "single-block"\nparams = { height = 4.0 }\n'
        '[[methods]]\nname = "static-lp"\n'
        '[[methods]]\nname = "fixed-point"\nlabel = "fp-relaxed"\noptions = { relaxation = 0.5 }\n')
    p = run("compare", "--config", str(study), "--out", str(tmp_path / "out"), "--quiet", "--no-figures")
    assert p.returncode == 0, p.stderr
    import pandas as pd

    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(df["method_label"]) == ["static-lp", "static-lp", "fp-relaxed", "fp-relaxed"]
    # static-lp: the default outside limit, room for its own default time_limit; fixed-point: the study's
    from blockmpec.bench.runner import default_wall_limit

    assert list(df["wall_limit_s"]) == [default_wall_limit({}, "static-lp")] * 2 + [100.0, 100.0]
    assert (df["p_method_relaxation"].dropna() == 0.5).all() and len(df["p_method_relaxation"].dropna()) == 2
    assert df["multiplier"].tolist() == pytest.approx([0.25] * 4, rel=1e-9)
    study.write_text('[[cases]]\ncase = "single-block"\nparms = { height = 4.0 }\n[[methods]]\nname = "static-lp"\n')
    p = run("compare", "--config", str(study), "--out", str(tmp_path / "out2"))
    assert p.returncode == 2 and "cases[0]: unknown key 'parms'" in p.stderr


def test_the_example_study_file_is_valid():
    from pathlib import Path

    from blockmpec.bench.study import load_study

    study = load_study(Path(__file__).resolve().parents[1] / "studies" / "example_study.toml")
    assert len(study.cases) >= 3 and len(study.methods) >= 3 and study.repeat >= 1
    labels = [m.label for m in study.methods]
    assert len(labels) == len(set(labels))
    assert any(c.structure is not None for c in study.cases)  # a structure file


def _big_wall(folder):
    """A 20 x 10 running-bond wall as a structure file: far beyond what milp certifies in seconds."""
    from blockmpec.structure_file import save_structure

    path = folder / "big-wall.json"
    save_structure(bm.cases.wall(courses=20, blocks_per_course=10), path)
    return path


def test_sigint_during_milp_saves_the_finished_rows_and_exits_130(tmp_path):
    """A real Ctrl-C while milp works on a wall it cannot certify quickly."""
    import signal
    import time

    out = tmp_path / "out"
    wall = _big_wall(tmp_path)
    # as a foreground command gets it: a test run started in the background by a non-interactive shell
    # inherits SIGINT ignored (POSIX), and an ignored signal stays ignored across exec
    proc = subprocess.Popen(
        [sys.executable, "-m", "blockmpec.cli", "compare", "--cases", f"two-blocks,{wall}", "--methods",
         "static-lp,milp", "-O", "milp.time_limit=300", "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    rows = out / "rows.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and (not rows.exists() or len(rows.read_text().splitlines()) < 3):
        time.sleep(0.2)
    assert rows.exists() and len(rows.read_text().splitlines()) == 3, "the first three solves did not finish"
    time.sleep(1.5)  # milp on the 200-block wall is running now
    t0 = time.time()
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert time.time() - t0 < 20  # milp is not waited for
    assert "interrupted (SIGINT): 3 finished row(s) saved" in stderr and "Traceback" not in stderr
    import pandas as pd

    df = pd.read_csv(out / "results.csv")
    assert len(df) == 3 and "big-wall" in set(df["case"]) and df["success"].all()
    assert json.loads((out / "run.json").read_text())["interrupted"] == "SIGINT"
    assert not (out / ".blockmpec.lock").exists()
    # --resume runs only what is missing (here: with a short limit, so milp stops at once)
    p = run("compare", "--cases", f"two-blocks,{wall}", "--methods", "static-lp,milp", "-O", "milp.time_limit=300",
            "--wall-limit", "milp=3", "--out", str(out), "--resume", "--quiet", "--no-figures")
    assert p.returncode == 0, p.stderr
    df = pd.read_csv(out / "results.csv")
    assert len(df) == 4 and df.iloc[3]["status"] == "time_limit" and df.iloc[3]["wall_limit_s"] == 3.0
    assert "killed after the wall-clock limit" in df.iloc[3]["message"]


def test_sigterm_is_handled_like_ctrl_c(tmp_path):
    import signal
    import time

    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "blockmpec.cli", "compare", "--cases", f"single-block,{_big_wall(tmp_path)}",
         "--methods", "milp",
         "-O", "milp.time_limit=300", "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rows = out / "rows.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and not (rows.exists() and rows.read_text().strip()):
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert "interrupted (SIGTERM): 1 finished row(s) saved" in stderr and "Traceback" not in stderr


@pytest.mark.parametrize("module", ["blockmpec", "blockmpec.cli"])
def test_closed_output_pipe_stops_quietly(module):
    """``blockmpec methods | head``: the reader leaves before the output is written; no error message,
    exit code 141 (the shell's code for SIGPIPE), and ``python -m blockmpec`` is the same command."""
    proc = subprocess.Popen([sys.executable, "-m", module, "methods"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # before the child has imported anything, so its first write meets a closed pipe
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 141, stderr
    assert stderr == ""
