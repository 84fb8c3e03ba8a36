"""The promises of the documentation and the packaging: the version, the public API, the front page's size, the
method pages' option tables, the examples on the docs pages and the gallery scripts (issue 39, item 4).

The docs site itself is built by ``.ci/run`` (``mkdocs build --strict``); these tests keep its pages true to the
code.
"""

import ast
import contextlib
import dataclasses
import io
import os
import re
import subprocess
import sys
import types
from importlib import metadata
from importlib.resources import files
from pathlib import Path

import pytest

import blockmpec as bm
from blockmpec.solver import option_fields

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GALLERY = sorted((DOCS / "gallery").glob("*.py"))


def test_version_is_the_installed_distributions_and_the_cli_prints_it():
    assert bm.__version__ == metadata.version("blockmpec")
    out = subprocess.run([sys.executable, "-m", "blockmpec", "--version"], capture_output=True, text=True, cwd="/")
    assert out.returncode == 0 and out.stdout.strip() == f"blockmpec {bm.__version__}"


def test_all_lists_exactly_the_public_names():
    public = {name for name, value in vars(bm).items()
              if not name.startswith("_") and (not isinstance(value, types.ModuleType) or name in ("cases", "plot", "three_d"))}
    assert set(bm.__all__) == public
    assert len(bm.__all__) == len(set(bm.__all__))


def test_the_package_is_typed_and_licensed():
    assert files("blockmpec").joinpath("py.typed").is_file()
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    citation = (ROOT / "CITATION.cff").read_text()
    assert "cff-version: 1.2.0" in citation and "Non-associative Coulomb Friction" in citation


def test_readme_is_a_front_page_not_a_lab_notebook():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 250
    # no measurement log: no timing tables and no study commands (they live in CHANGELOG.md and docs/performance.md)
    assert "python studies/" not in readme
    assert not re.search(r"\|\s*[\d.,]+ s\s*\|", readme)
    for section in ("## Install and run", "## Quick start", "## Methods", "## Layout", "## How to cite"):
        assert section in readme
    assert 'python -m pytest -m "not slow"' in readme


def _section(page: str, heading: str) -> str:
    m = re.search(rf"^## {re.escape(heading)}\n(.+?)(?=^## |\Z)", page, re.S | re.M)
    assert m, f"no '## {heading}' section"
    return m.group(1)


def _first_column_names(table: str) -> set[str]:
    names = set()
    for line in table.splitlines():
        if line.startswith("| `"):
            names |= set(re.findall(r"`([a-z_]+)`", line.split("|")[1]))
    return names


@pytest.mark.parametrize("method", bm.list_solvers())
def test_method_page_lists_its_options_and_settings(method):
    """Each method's page has one row per option (as `blockmpec methods` lists them) and per engine setting."""
    page = (DOCS / "methods" / f"{method}.md").read_text()
    cls = bm.get_solver(method)
    assert _first_column_names(_section(page, "Options")) == {name for name, *_ in option_fields(cls)}
    if cls.Settings is not None:
        documented = _first_column_names(_section(page, "Engine settings"))
        assert documented == {f.name for f in dataclasses.fields(cls.Settings)}
        assert f"{cls.Settings.__module__}.{cls.Settings.__name__}" in page


def _python_blocks(page: Path) -> list[str]:
    return [b for b in re.findall(r"```python\n(.+?)\n```", page.read_text(), re.S) if "--8<--" not in b]


#: the line that marks the fenced block after it as the output of the page's Python blocks above it
OUTPUT_MARK = "<!-- output -->"


def _code_and_output(page: Path) -> list[tuple[str, str]]:
    """The page's Python blocks (``("code", text)``) and the output blocks marked by :data:`OUTPUT_MARK`
    (``("output", text)``), in page order."""
    parts = []
    for m in re.finditer(r"(?P<mark>^<!-- output -->\n)?^```(?P<lang>\w*)\n(?P<body>.*?)\n```", page.read_text(),
                         re.S | re.M):
        if m["mark"]:
            parts.append(("output", m["body"]))
        elif m["lang"] == "python" and "--8<--" not in m["body"]:
            parts.append(("code", m["body"]))
    return parts


def output_matches(expected: str, printed: str) -> bool:
    """``printed`` is what ``expected`` shows, line by line (trailing blanks ignored): ``...`` within a line stands for
    any text (times, digits beyond those shown), a line that is only ``...`` for any number of lines."""
    pattern = []
    for line in expected.strip("\n").splitlines():
        if line.strip() == "...":
            pattern.append(r"(?:[^\n]*\n)*?")
        else:
            pattern.append(".*?".join(re.escape(part) for part in line.rstrip().split("...")) + r"\n")
    text = "".join(line.rstrip() + "\n" for line in printed.strip("\n").splitlines())
    return re.fullmatch("".join(pattern), text) is not None


@pytest.mark.parametrize(("expected", "printed", "match"), [
    ("0.65\n   a  b\n0  1  2", "0.65\n   a  b\n0  1  2\n", True),
    ("0.65", "0.66", False),
    ("lam = 0.4197271773...", "lam = 0.4197271773347324", True),
    ("time 0.1 s", "time 0.2 s", False),
    ("time ... s, done", "time 0.213 s, done", True),
    ("a\n...\nz", "a\nb\nc\nz", True),
    ("a\n...\nz", "a\nz", True),
    ("a\nz", "a\nb\nz", False),
])
def test_output_matching(expected, printed, match):
    assert output_matches(expected, printed) is match


def _page_param(page: Path):
    # slow: the comparator's examples run worker processes (15-35 s), the maps solve 110 structures per panel
    # (about 40 s), the pushover example runs 20 steps of two methods and writes a GIF (about 60 s)
    slow = any(call in block for block in _python_blocks(page) for call in ("compare(", "multiplier_map(", "pushover("))
    return pytest.param(page, id=str(page.relative_to(DOCS)), marks=[pytest.mark.slow] if slow else [])


PAGES_WITH_CODE = [_page_param(p) for p in sorted(DOCS.rglob("*.md")) if _python_blocks(p) and "gallery" not in p.parts]


@pytest.mark.parametrize("page", PAGES_WITH_CODE)
def test_docs_examples_run_and_print_what_the_page_shows(page, tmp_path, monkeypatch):
    """Every Python example on a docs page runs (the page's blocks in order, in one namespace), and what they print
    is what the page shows: each block marked ``<!-- output -->`` is matched (:func:`output_matches`) against what
    the Python blocks above it printed since the previous one, and nothing printed goes unshown."""
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    printed = io.StringIO()
    name = page.relative_to(DOCS)
    for i, (kind, text) in enumerate(_code_and_output(page)):
        if kind == "code":
            with contextlib.redirect_stdout(printed):
                exec(compile(text, f"{name} example {i}", "exec"), namespace)
            continue
        assert output_matches(text, printed.getvalue()), (
            f"{name}: the output shown in its block {i}:\n{text}\nis not what the examples print:\n{printed.getvalue()}")
        printed = io.StringIO()
    assert not printed.getvalue().strip(), f"{name}: printed, but not shown on the page:\n{printed.getvalue()}"
    import matplotlib.pyplot as plt

    plt.close("all")


ALLOWED_IMPORTS = ("blockmpec", "blockmpec.cases", "blockmpec.bench.compare", "blockmpec.bench.suite", "numpy",
                   "pandas", "matplotlib", "argparse", "sys", "pathlib", "__future__")


@pytest.mark.parametrize("script", GALLERY, ids=lambda p: p.name)
def test_gallery_script_uses_only_the_public_api(script):
    tree = ast.parse(script.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        else:
            continue
        for name in names:
            assert name.split(".")[0] != "studies", f"{script.name} imports {name}"
            assert any(name == a or (name.startswith(a + ".") and a != "blockmpec") for a in ALLOWED_IMPORTS), (
                f"{script.name} imports {name}, which is not public API")


@pytest.mark.slow
@pytest.mark.parametrize("script", GALLERY, ids=lambda p: p.name)
def test_gallery_script_reproduces_at_small_size(script, tmp_path):
    """Each gallery script runs with --small and exits 0: its result agrees with what it reproduces."""
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, str(script), "--small", "--out", str(out)], capture_output=True, text=True,
                         cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=600)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert any(out.iterdir())
