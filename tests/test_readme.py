"""The README's two opening commands are what CI runs, its quick start runs, and the structure-file example of the
docs (docs/structure-file.md, where the README's former example moved) loads."""

import json
import re
from pathlib import Path

import pytest
from references import README_WALL_ASSOCIATIVE, README_WALL_FIXED_POINT

import blockmpec as bm

ROOT = Path(__file__).resolve().parents[1]


def _commands():
    readme = (ROOT / "README.md").read_text()
    return re.findall(r"```bash\n(.+?)\n```", readme)


def test_readme_opens_with_install_and_test_commands():
    commands = _commands()
    assert commands[0].endswith("pip install . && blockmpec compare")
    assert commands[1].endswith('pip install ".[test]" && python -m pytest')


def test_ci_runs_the_readme_test_command_verbatim():
    ci = (ROOT / ".ci" / "run").read_text()
    assert _commands()[1] in ci


def test_structure_file_example_loads():
    page = (ROOT / "docs" / "structure-file.md").read_text()
    block = re.search(r"```json\n(.+?)\n```", page, re.S).group(1)
    s = bm.structure_from_dict(json.loads(block))
    assert s.n_blocks == 2 and len(s.interfaces) == 1
    assert bm.solve(s, "static-lp").success


def test_readme_quick_start_runs_and_its_numbers_hold(tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    code = re.search(r"```python\n(.+?)\n```", (ROOT / "README.md").read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, "README.md quick start", "exec"), namespace)
    # the references (references.py: the independent static LP; 11/19, a solution of (3) the fixed point returns, the
    # least lam of its pattern): 0 measured for both
    assert namespace["assoc"].multiplier == pytest.approx(README_WALL_ASSOCIATIVE, rel=1e-9)
    assert namespace["res"].success and namespace["res"].multiplier == pytest.approx(README_WALL_FIXED_POINT, rel=1e-9)
    # ... and the digits the quick start's comment quotes are theirs
    quoted = re.search(r"print\(assoc.multiplier, res.multiplier\)\s+# ([\d.]+) ([\d.]+)", code)
    assert quoted, "the quick start no longer quotes the two multipliers"
    assert (quoted[1], quoted[2]) == (f"{README_WALL_ASSOCIATIVE:.4f}", f"{README_WALL_FIXED_POINT:.4f}")
    assert (tmp_path / "mechanism.png").stat().st_size > 0
    import matplotlib.pyplot as plt

    plt.close("all")
