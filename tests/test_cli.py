"""The CLI contract: spellings, --json keys, exit codes, errors without tracebacks.

Most tests call :func:`blockmpec.cli.main` in this process (``cli`` below): the argument handling, the messages and
the exit codes are the same, without an interpreter start per test.  A few run the real command in a subprocess,
where only a process shows the behaviour: stdout carrying nothing but JSON while HiGHS writes to descriptor 1, the
exit status of the process, Ctrl-C / SIGTERM and a closed pipe.
"""

import json
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest
from references import ROUND_ARCH_ASSOCIATIVE, TWO_BLOCKS_ASSOCIATIVE

import blockmpec as bm
from blockmpec.cli import main
from blockmpec.verify import RESIDUAL_NAMES


@pytest.fixture
def cli(capsys, monkeypatch, tmp_path):
    """``cli(*args) -> (exit code, stdout, stderr)`` of ``blockmpec ARGS`` run in this process, in ``tmp_path``."""
    monkeypatch.chdir(tmp_path)

    def run(*args):
        try:
            code = main([str(a) for a in args])
        except SystemExit as exc:  # argparse's own usage errors
            code = exc.code
        out, err = capsys.readouterr()
        return code, out, err

    return run


def run(*args, **kw):
    """The real command in a subprocess."""
    return subprocess.run([sys.executable, "-m", "blockmpec.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=300, **kw)


# --------------------------------------------------------------------------- solve, export, listings


def test_solve_json_has_contract_keys(cli):
    code, out, err = cli("solve", "two-blocks", "--method", "static-lp", "-p", "eta=3", "-p", "mu=0.65", "--json")
    assert code == 0, err
    out = json.loads(out)
    for key in ("method", "status", "success", "multiplier", "residuals", "time_s", "iterations"):
        assert key in out
    assert out["method"] == "static-lp" and out["status"] == "optimal" and out["success"] is True
    # 1 / 2.3825 (paper Sect. 3): one unit in the last place measured
    assert out["multiplier"] == pytest.approx(TWO_BLOCKS_ASSOCIATIVE, rel=1e-12)
    assert out["residuals"].keys() == set(RESIDUAL_NAMES)
    assert max(out["residuals"].values()) <= 1e-15  # an exact LP vertex: 7e-17 measured


def test_solve_plot_writes_the_mechanism_figure_and_refuses_an_unknown_format_before_solving(cli, tmp_path):
    code, out, err = cli("solve", "two-blocks", "--method", "static-lp", "--plot", "mechanism.png")
    assert code == 0, err
    figure = tmp_path / "mechanism.png"
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "wrote mechanism.png" in out
    code, out, err = cli("solve", "two-blocks", "--method", "static-lp", "--plot", "mechanism.foo")
    assert code == 2 and out == "" and "--plot mechanism.foo: unknown figure format '.foo'" in err
    assert len(err.strip().splitlines()) == 1
    code, out, err = cli("solve", "two-blocks", "--method", "static-lp", "--plot", "missing/m.png")
    assert code == 2 and "folder missing does not exist" in err


@pytest.mark.slow
def test_the_real_command_exit_codes_and_a_json_only_stdout():
    """The process's exit status: 0 = verified success, 2 = bad input (1 = no verified success: in-process below);
    stdout holds only the JSON although HiGHS writes its banner to descriptor 1 (only a real process shows that)."""
    ok = run("solve", "two-blocks", "--method", "static-lp", "--json")
    assert ok.returncode == 0 and json.loads(ok.stdout)["success"] is True
    bad = run("solve", "two-blocks", "--method", "milp", "-O", "time_limit=abc")
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.strip() == "blockmpec: error: method 'milp': time_limit must be a number > 0; got 'abc'"


def test_solve_exit_code_says_whether_the_success_is_verified(cli):
    code, out, _ = cli("solve", "two-blocks", "--method", "static-lp", "--json")
    assert code == 0 and json.loads(out)["success"] is True
    code, out, _ = cli("solve", "wall", "--method", "kinematic-lp", "--verify-tol", "1e-300", "--json")
    assert code == 1 and json.loads(out)["status"] == "numerical"


def test_every_case_takes_mu_and_dilatancy():
    for case in bm.cases.CASES:
        params = bm.cases.get_case(case).parameters
        assert "mu" in params and "dilatancy" in params, case


def test_export_then_solve_file(cli, tmp_path):
    path = tmp_path / "arch.json"
    code, out, err = cli("export", "round-arch", "-p", "n_voussoirs=12", "-o", path)
    assert code == 0, err
    code, out, err = cli("solve", path, "--method", "kinematic-lp", "-p", "mu=0.5", "--json")
    assert code == 0, err
    direct = bm.solve(bm.cases.round_arch(n_voussoirs=12, mu=0.5), "kinematic-lp")
    assert json.loads(out)["multiplier"] == pytest.approx(direct.multiplier, rel=1e-12)


def test_cases_methods_and_version(cli):
    code, out, _ = cli("cases")
    assert code == 0
    for name in ("two-blocks", "single-block", "round-arch", "arch-on-buttresses", "wall", "n_voussoirs", "bond"):
        assert name in out
    code, out, err = cli("methods")
    assert code == 0 and "failed to import" not in err
    assert "static-lp" in out and "kinematic-lp" in out and "algorithm" in out
    code, out, _ = cli("--version")
    assert code == 0 and out.strip() == f"blockmpec {bm.__version__}"


def test_methods_json_lists_every_method_and_its_user_facing_options(cli):
    """Issue 40: name, type, default and help of every option, plus name, problem, summary and availability."""
    import dataclasses

    code, out, _ = cli("methods", "--json")
    assert code == 0
    listing = json.loads(out)  # strict JSON: no Infinity / NaN
    assert [m["name"] for m in listing] == bm.list_solvers()
    for m in listing:
        cls = bm.get_solver(m["name"])
        assert set(m) == {"name", "problem", "summary", "available", "unavailable_reason", "certifies_minimum",
                          "source", "options"}
        assert m["source"] == bm.registry.solver_source(m["name"])  # "built-in", or where a plug-in came from
        assert m["problem"] == cls.problem and m["summary"] == cls.summary and m["summary"]
        assert m["available"] is (cls.unavailable_reason() is None)
        fields = {f.name: f for f in dataclasses.fields(cls.Options)}
        assert [o["name"] for o in m["options"]] == list(fields)
        assert {"time_limit", "verbose"} <= set(fields)  # the common options (CommonOptions)
        defaults = cls().options
        for o in m["options"]:
            assert set(o) == {"name", "type", "default", "help"}
            assert o["help"], (m["name"], o["name"])  # one line of help each
            assert o["type"] == type(getattr(defaults, o["name"])).__name__
            assert o["default"] == getattr(defaults, o["name"])
    assert sum(len(m["options"]) for m in listing) <= 45  # issue 40's budget of user-facing options


# --------------------------------------------------------------------------- bad input: one line, exit 2


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("solve", "two-blocks", "--method", "nope"), "unknown method 'nope'"),
        (("solve", "no-such-case", "--method", "static-lp"), "unknown case 'no-such-case'"),
        (("solve", "wall", "--method", "static-lp", "-p", "bond=flemish"), "bond: must be 'running' or 'stack'"),
        (("solve", "wall", "--method", "static-lp", "-p", "courses"), "-p 'courses': expected KEY=VALUE"),
        (("solve", "two-blocks", "--method", "static-lp", "-p", "mu=-1"), "friction: must be a finite number >= 0"),
        (("solve", "missing.json", "--method", "static-lp"), "missing.json: cannot read structure file"),
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
        (("compare", "--methods", "milp", "-O", "milp.time_limit=abc"), "method 'milp': time_limit must be a number"),
        (("compare", "--methods", "milp", "-O", "milp.no_such=1"), "method 'milp' has no option 'no_such'"),
        (("compare", "--methods", "static-lp", "-O", "time_limit=1"), "-O time_limit=1: expected METHOD.OPTION=VALUE"),
        (("compare", "--methods", "static-lp", "--budget", "abc"), "--budget abc: expected SECONDS or CASE=SECONDS"),
        (("compare", "--methods", "static-lp", "--budget", "inf"), "--budget inf"),
        (("compare", "--cases", "two-blocks", "--methods", "static-lp", "--budget", "nope=3"),
         "--budget nope=...: no case 'nope' in this run"),
    ],
)
def test_bad_values_are_one_line_with_exit_2_before_any_solve(cli, tmp_path, args, message):
    t0 = time.perf_counter()
    code, out, err = cli(*args)
    assert code == 2, err
    assert message in err and len(err.strip().splitlines()) == 1 and err.startswith("blockmpec: error: ")
    assert "Traceback" not in err and out == ""
    assert not (tmp_path / "blockmpec-output").exists()  # nothing ran, no folder was made
    assert time.perf_counter() - t0 < 60


@pytest.mark.parametrize("method", bm.list_solvers())
def test_every_method_names_a_bad_option_in_one_line(cli, method):
    """Issue 39 item 5: for every method a bad value or an unknown option is one line naming the option."""
    for option, value, message in (("time_limit", "abc", f"method '{method}': time_limit must be a number > 0; "
                                                          "got 'abc'"),
                                   ("time_limit", "-1", "time_limit must be a number > 0; got -1"),
                                   ("verbose", "3", "verbose must be true or false; got 3"),
                                   ("no_such", "1", f"method '{method}' has no option 'no_such'; valid options: ")):
        code, out, err = cli("solve", "single-block", "--method", method, "-O", f"{option}={value}")
        assert code == 2 and out == "", (option, value, err)
        assert message in err and len(err.strip().splitlines()) == 1, err
    from blockmpec.solver import option_fields

    for name, typ, default, _ in option_fields(bm.get_solver(method)):  # a value of the wrong kind for each option
        if typ is str:
            continue
        code, _, err = cli("solve", "single-block", "--method", method, "-O", f"{name}=[1]")
        assert code == 2 and f"{name} must be" in err and len(err.strip().splitlines()) == 1, (name, err)


# --------------------------------------------------------------------------- compare


def test_compare_main_job_prints_tables_summary_and_budget(cli, tmp_path):
    code, out, err = cli("compare", "--cases", "two-blocks,round-arch", "--methods", "static-lp,kinematic-lp",
                         "--out", tmp_path / "o", "--quiet", "--no-figures")
    assert code == 0, err
    # the two cases' associative lam to five digits: 1/2.3825 and the round arch's (references.py, the paper's Table 1)
    assert "Collapse multiplier" in out and f"{TWO_BLOCKS_ASSOCIATIVE:.5f}" in out and f"{ROUND_ARCH_ASSOCIATIVE:.5f}" in out
    assert (tmp_path / "o" / "results.csv").exists()
    from blockmpec.bench.profiles import SOLVED_DEFINITION

    assert SOLVED_DEFINITION in out  # the printed definition of "solved" is the code's
    assert "budget per case (the largest wall-clock limit of the case's runs; the same for every method of a " \
           "case): two-blocks 900 s, round-arch 900 s" in out
    assert "ran 4 solve(s) in" in out and "kept" not in out
    # a budget set by the user, for every case or one
    code, out, err = cli("compare", "--cases", "two-blocks,round-arch", "--methods", "static-lp", "--out",
                         tmp_path / "b", "--quiet", "--no-figures", "--budget", "20", "--budget", "round-arch=5")
    assert code == 0, err
    assert "(set by the user; the same for every method of a case): two-blocks 20 s, round-arch 5 s" in out
    assert list(pd.read_csv(tmp_path / "b" / "results.csv")["budget_s"]) == [20.0, 5.0]


def test_wall_limit_inf_means_none(cli, tmp_path):
    code, _, err = cli("compare", "--cases", "single-block", "--methods", "static-lp,kinematic-lp", "--wall-limit",
                       "inf", "--wall-limit", "kinematic-lp=30", "--out", tmp_path / "o", "--quiet", "--no-figures")
    assert code == 0, err
    df = pd.read_csv(tmp_path / "o" / "results.csv")
    assert list(df["wall_limit_s"]) == [float("inf"), 30.0] and list(df["budget_s"]) == [30.0, 30.0]


def test_compare_refuses_a_folder_with_results_unless_told(cli, tmp_path):
    (tmp_path / "results.csv").write_text("an earlier run")
    args = ("compare", "--cases", "single-block", "--methods", "static-lp", "--out", tmp_path, "--no-figures")
    code, _, err = cli(*args)
    assert code == 2 and "--overwrite" in err and "--resume" in err
    code, _, err = cli(*args, "--overwrite", "--quiet")
    assert code == 0, err
    assert "an earlier run" not in (tmp_path / "results.csv").read_text()


def test_resume_reports_what_it_ran_and_what_it_kept(cli, tmp_path):
    """Issue 39 item 5: after an interrupted run, --resume ran the missing solves and says so (not the total)."""
    out_dir = tmp_path / "o"
    code, out, err = cli("compare", "--cases", "two-blocks,single-block", "--methods", "static-lp", "--out", out_dir,
                         "--quiet", "--no-figures")
    assert code == 0 and "ran 2 solve(s)" in out, err
    code, out, err = cli("compare", "--cases", "two-blocks,single-block", "--methods", "static-lp,kinematic-lp",
                         "--out", out_dir, "--quiet", "--no-figures", "--resume")
    assert code == 0, err
    assert "ran 2 solve(s) in" in out and "and kept 2 finished row(s) of the earlier run; 4 row(s)" in out
    df = pd.read_csv(out_dir / "results.csv")
    assert list(df["resumed"]) == [True, False, True, False]  # task order: case by case
    meta = json.loads((out_dir / "run.json").read_text())
    assert meta["rows"] == 4 and meta["rows_kept"] == 2 and meta["rows_run"] == 2


@pytest.mark.slow
def test_compare_takes_builtin_cases_and_structure_files(cli, tmp_path):
    from blockmpec.structure_file import save_structure

    save_structure(bm.cases.single_block(width=1.0, height=4.0), tmp_path / "tall.json")
    out = tmp_path / "out"
    code, stdout, err = cli("compare", "--cases", f"single-block,{tmp_path / 'tall.json'},two-blocks", "--methods",
                            "static-lp,fixed-point", "--out", out, "--quiet", "--jobs", "2", "--no-figures")
    assert code == 0, err
    df = pd.read_csv(out / "results.csv").set_index(["case", "method"])
    assert df.loc[("single-block", "static-lp"), "multiplier"] == pytest.approx(0.5, rel=1e-9)  # min(mu, b/h)
    assert df.loc[("tall", "static-lp"), "multiplier"] == pytest.approx(0.25, rel=1e-9)
    assert df.loc[("two-blocks", "fixed-point"), "reference_source"] == "closed-form"
    assert (out / "results.parquet").exists() and (out / "summary.csv").exists()
    meta = json.loads((out / "run.json").read_text())
    assert meta["settings"]["jobs"] == 2 and meta["rows"] == 6 and meta["versions"]["highspy"]
    from blockmpec.bench.runner import usable_cpus

    assert meta["settings"]["cpus_per_solve"] == max(1, usable_cpus() // 2)  # two solves side by side share them
    assert "Summary" in stdout
    assert not (out / ".blockmpec.lock").exists()


def test_compare_reads_a_study_file(cli, tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(
        'repeat = 2\nbudget = 50\n[wall_limits]\nfixed-point = 100\n'
        '[[cases]]\nlabel = "sb-tall"\ncase = "single-block"\nparams = { height = 4.0 }\n'
        '[[methods]]\nname = "static-lp"\n'
        '[[methods]]\nname = "fixed-point"\nlabel = "fp-relaxed"\noptions = { relaxation = 0.5 }\n')
    code, _, err = cli("compare", "--config", study, "--out", tmp_path / "out", "--quiet", "--no-figures")
    assert code == 0, err
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(df["method_label"]) == ["static-lp", "static-lp", "fp-relaxed", "fp-relaxed"]
    # static-lp: the default outside limit, room for its own default time_limit; fixed-point: the study's
    from blockmpec.bench.runner import default_wall_limit

    assert list(df["wall_limit_s"]) == [default_wall_limit({}, "static-lp")] * 2 + [100.0, 100.0]
    assert (df["p_method_relaxation"].dropna() == 0.5).all() and len(df["p_method_relaxation"].dropna()) == 2
    assert df["multiplier"].tolist() == pytest.approx([0.25] * 4, rel=1e-9)
    assert (df["budget_s"] == 50.0).all()
    study.write_text('[[cases]]\ncase = "single-block"\nparms = { height = 4.0 }\n[[methods]]\nname = "static-lp"\n')
    code, _, err = cli("compare", "--config", study, "--out", tmp_path / "out2")
    assert code == 2 and "cases[0]: unknown key 'parms'" in err


def test_the_example_study_file_is_valid():
    from pathlib import Path

    from blockmpec.bench.study import load_study

    study = load_study(Path(__file__).resolve().parents[1] / "studies" / "example_study.toml")
    assert len(study.cases) >= 3 and len(study.methods) >= 3 and study.repeat >= 1
    labels = [m.label for m in study.methods]
    assert len(labels) == len(set(labels))
    assert any(c.structure is not None for c in study.cases)  # a structure file


# --------------------------------------------------------------------------- signals (real processes)


def _big_wall(folder):
    """A 20 x 10 running-bond wall as a structure file: far beyond what milp certifies in seconds."""
    from blockmpec.structure_file import save_structure

    path = folder / "big-wall.json"
    save_structure(bm.cases.wall(courses=20, blocks_per_course=10), path)
    return path


@pytest.mark.slow
def test_sigint_during_milp_saves_the_finished_rows_and_exits_130(tmp_path, capsys, monkeypatch):
    """A real Ctrl-C while milp works on a wall it cannot certify quickly; --resume then runs only what is
    missing and says so."""
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
    df = pd.read_csv(out / "results.csv")
    assert len(df) == 3 and "big-wall" in set(df["case"]) and df["success"].all()
    assert json.loads((out / "run.json").read_text())["interrupted"] == "SIGINT"
    assert not (out / ".blockmpec.lock").exists()
    # --resume runs only what is missing (here: with a short limit, so milp stops at once), and says so
    monkeypatch.chdir(tmp_path)
    code = main(["compare", "--cases", f"two-blocks,{wall}", "--methods", "static-lp,milp", "-O",
                 "milp.time_limit=300", "--wall-limit", "milp=3", "--out", str(out), "--resume", "--quiet",
                 "--no-figures"])
    printed = capsys.readouterr().out
    assert code == 0
    assert "ran 1 solve(s) in" in printed and "and kept 3 finished row(s) of the earlier run; 4 row(s)" in printed
    df = pd.read_csv(out / "results.csv")
    assert len(df) == 4 and df.iloc[3]["status"] == "time_limit" and df.iloc[3]["wall_limit_s"] == 3.0
    assert "killed after the wall-clock limit" in df.iloc[3]["message"]
    assert list(df["resumed"]) == [True, True, True, False]


@pytest.mark.slow
def test_sigterm_is_handled_like_ctrl_c(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "blockmpec.cli", "compare", "--cases", f"single-block,{_big_wall(tmp_path)}",
         "--methods", "milp", "-O", "milp.time_limit=300", "--out", str(out), "--quiet"],
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


@pytest.mark.parametrize("module", ["blockmpec.cli", pytest.param("blockmpec", marks=pytest.mark.slow)])
def test_closed_output_pipe_stops_quietly(module):
    """``blockmpec methods | head``: the reader leaves before the output is written; no error message,
    exit code 141 (the shell's code for SIGPIPE), and ``python -m blockmpec`` is the same command."""
    proc = subprocess.Popen([sys.executable, "-m", module, "methods"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # before the child has imported anything, so its first write meets a closed pipe
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 141, stderr
    assert stderr == ""
