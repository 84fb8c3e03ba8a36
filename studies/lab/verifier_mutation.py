r"""The verifier mutation check: which tests fail when one residual of the shared verifier is always 0.

Every success of a heuristic rests on :func:`blockmpec.verify.residuals`; a residual that no test catches when it is
zeroed is a condition of (3) the suite does not check.  For each residual in turn the script runs the test suite in a
subprocess with ``--zero-residual NAME`` (the option of ``tests/conftest.py``: the residual reads 0 in the test
process and in every Python process the tests start; nothing is edited, nothing of the library is patched here) and
reads the failed tests from pytest's JUnit XML report.  First a control run without a mutation must pass.

Prints one row per residual: how many tests failed and the first few of them; exits 1 when the control fails or a
mutation is caught by no test.

Use ``python studies/lab/verifier_mutation.py [--tests "tests/test_verify.py"] [--marks "not slow"]
[--residuals equilibrium,...] [--workers 2] [--show 4]``; the fast suite (``--tests tests``, the default) takes 9 + 1
runs of it; ``--tests tests/test_verify.py`` is the quick check (the dedicated tests, a few seconds per residual).
Writes ``studies/output/verifier_mutation/{table.md,failures.json}``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

from blockmpec.verify import RESIDUAL_NAMES

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "studies" / "output" / "verifier_mutation"


def failed_tests(tests: list[str], marks: str, workers: int, residual: str | None) -> tuple[list[str], int, float]:
    """Run pytest on ``tests``; ``(failed or erroring test ids, number of tests run, seconds)``."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "report.xml"
        command = [sys.executable, "-m", "pytest", *tests, "-q", "-p", "no:cacheprovider", "-m", marks,
                   "-n", str(workers), f"--junitxml={report}"]
        if residual:
            command.append(f"--zero-residual={residual}")
        t0 = time.perf_counter()
        run = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
        seconds = time.perf_counter() - t0
        if not report.exists():
            raise RuntimeError(f"pytest wrote no report (exit {run.returncode}):\n{run.stdout[-3000:]}{run.stderr[-3000:]}")
        failed, count = [], 0
        for case in ET.parse(report).iter("testcase"):
            count += 1
            if case.find("failure") is not None or case.find("error") is not None:
                failed.append(f"{case.get('classname')}::{case.get('name')}")
    return failed, count, seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tests", default="tests", help="comma-separated pytest paths (default: the whole suite)")
    parser.add_argument("--marks", default="not slow", help="pytest -m expression (default: the fast suite)")
    parser.add_argument("--residuals", default=",".join(RESIDUAL_NAMES), help="comma-separated residual names")
    parser.add_argument("--workers", type=int, default=2, help="pytest-xdist workers per run")
    parser.add_argument("--show", type=int, default=4, help="failed tests listed per residual")
    args = parser.parse_args(argv)
    tests = args.tests.split(",")
    residuals = [r for r in args.residuals.split(",") if r]
    unknown = sorted(set(residuals) - set(RESIDUAL_NAMES))
    if unknown:
        parser.error(f"no residual {unknown[0]!r}; the residuals are {', '.join(RESIDUAL_NAMES)}")

    failed, count, seconds = failed_tests(tests, args.marks, args.workers, None)
    print(f"control (no mutation): {count} tests, {len(failed)} failed, {seconds:.0f} s")
    if failed:
        print("the control run fails; fix the suite first:", *failed[: args.show], sep="\n  ")
        return 1
    rows, caught_by = [], {}
    for name in residuals:
        failed, count, seconds = failed_tests(tests, args.marks, args.workers, name)
        caught_by[name] = failed
        shown = ", ".join(f.rsplit(".", 1)[-1] for f in failed[: args.show]) + (" ..." if len(failed) > args.show else "")
        rows.append((name, len(failed), count, seconds, shown or "NONE: not caught"))
        print(f"{name:28s} {len(failed):4d} of {count} tests fail ({seconds:.0f} s)  {shown}", flush=True)

    OUT.mkdir(parents=True, exist_ok=True)
    lines = [f"Verifier mutation check: `python studies/lab/verifier_mutation.py --tests {args.tests} "
             f"--marks \"{args.marks}\"`", "", "| residual zeroed | tests failing | of | seconds | first failures |",
             "| --- | ---: | ---: | ---: | --- |"]
    lines += [f"| `{n}` | {k} | {c} | {s:.0f} | {shown} |" for n, k, c, s, shown in rows]
    (OUT / "table.md").write_text("\n".join(lines) + "\n")
    (OUT / "failures.json").write_text(json.dumps(caught_by, indent=1) + "\n")
    print(f"wrote {OUT / 'table.md'} and failures.json")
    missed = [n for n, k, *_ in rows if k == 0]
    if missed:
        print("not caught by any test:", ", ".join(missed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
