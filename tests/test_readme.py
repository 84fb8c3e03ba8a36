"""The README's two opening commands are what CI runs, and its structure-file example loads."""

import json
import re
from pathlib import Path

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


def test_readme_structure_file_example_loads():
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"```json\n(.+?)\n```", readme, re.S).group(1)
    s = bm.structure_from_dict(json.loads(block))
    assert s.n_blocks == 2 and len(s.interfaces) == 1
    assert bm.solve(s, "static-lp").success
