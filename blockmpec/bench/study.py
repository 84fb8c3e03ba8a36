"""Studies on disk: the output folder of a comparison and study files (``--config study.toml``).

Output folder
-------------
:class:`ResultsFolder` owns one folder for one run:

* it is validated before anything runs (a path that is a file, ``/dev/null`` or a
  folder that cannot be created or written is an :class:`~blockmpec.errors.OptionError`);
* a folder holding files is **refused** unless ``overwrite=True`` (the outputs of the
  earlier run -- tables, figures, solutions, metadata -- are deleted first, so no stale
  figure is left beside new tables) or ``resume=True`` (the finished rows are kept and
  their runs skipped);
* a lock file (``.blockmpec.lock``, holding the process id) keeps two concurrent runs
  out of one folder;
* every finished row is appended to ``rows.jsonl`` (one JSON object per line, flushed
  and fsynced: an interrupt keeps every finished row) and its result pickled into
  ``solutions/`` (written to a temporary name, then renamed); the tables
  ``results.csv`` and ``results.parquet`` are rewritten by rename, never in place;
* ``run.json`` records the run: versions, CPU, date, command and settings.

Study file
----------
A TOML file read with :mod:`tomllib` (``tomli`` before Python 3.11)::

    repeat = 1                    # optional
    verify_tol = 1e-6             # optional
    jobs = 2                      # optional, as --jobs
    backend = "loky"              # optional: "loky" or "dask"
    scheduler = "tcp://host:8786" # optional, with backend = "dask"

    budget = 120                  # optional: time budget of every case [s] (as --budget); or a table
                                  # [budget] with case label = seconds

    [wall_limits]                 # optional: outside wall-clock limit per method name [s]
    milp = 90

    [[cases]]                     # a built-in case with parameters ...
    label = "arch-mu0.5"          # optional (default: name[k=v,...])
    case = "round-arch"
    params = { mu = 0.5 }
    [[cases]]                     # ... a suite label ...
    suite = "wall-5x4"
    [[cases]]                     # ... or a structure file (relative to the study file)
    file = "../blockmpec/data/leaning-pier.json"
    params = { mu = 0.6 }

    [[methods]]
    name = "fixed-point"
    label = "fixed-point-relaxed" # optional (default: name[k=v,...])
    options = { relaxation = 0.5 }
    wall_limit = 60               # optional, overrides [wall_limits]

Unknown keys are errors naming the key and where it is.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import shutil
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from blockmpec.errors import OptionError

#: the files and folders a run writes (all of them are removed by ``overwrite=True``)
OUTPUT_NAMES = ("results.csv", "results.parquet", "rows.jsonl", "run.json", "summary.csv", "solutions")
LOCK_NAME = ".blockmpec.lock"


# --------------------------------------------------------------------------- output folder


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _atomic_write(path: Path, write) -> None:
    """``write(tmp_path)``, then rename onto ``path`` (readers never see a half-written file)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    write(tmp)
    os.replace(tmp, path)


class ResultsFolder:
    """The output folder of one comparison run (see the module docstring)."""

    def __init__(self, path: str | Path, *, overwrite: bool = False, resume: bool = False, flag: str = "--out"):
        self.path = Path(path)
        self._locked = False
        if overwrite and resume:
            raise OptionError(f"{flag}: choose --overwrite or --resume, not both")
        if self.path.exists() and not self.path.is_dir():
            raise OptionError(f"{flag} {path}: exists and is not a folder")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OptionError(f"{flag} {path}: cannot create the folder ({exc.strerror or exc})") from None
        self._lock(flag)
        try:
            present = sorted(p.name for p in self.path.iterdir() if p.name != LOCK_NAME)
            if present and not (overwrite or resume):
                raise OptionError(
                    f"{flag} {path}: folder is not empty ({', '.join(present[:3])}{', ...' if len(present) > 3 else ''});"
                    " pass --overwrite to replace its results, --resume to continue them, or choose another folder")
            if overwrite:
                self.clear()
        except BaseException:
            self.close()
            raise
        (self.path / "solutions").mkdir(exist_ok=True)
        self.rows_path = self.path / "rows.jsonl"

    def _lock(self, flag: str) -> None:
        lock = self.path / LOCK_NAME
        for _ in range(2):
            try:
                fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(lock.read_text().strip() or 0)
                except (OSError, ValueError):
                    pid = 0
                if pid and _pid_alive(pid):
                    raise OptionError(f"{flag} {self.path}: another blockmpec run (process {pid}) is writing into "
                                      "this folder") from None
                lock.unlink(missing_ok=True)  # stale: its process is gone
                continue
            except OSError as exc:
                raise OptionError(f"{flag} {self.path}: cannot write into the folder ({exc.strerror or exc})") from None
            with os.fdopen(fd, "w") as fh:
                fh.write(str(os.getpid()))
            self._locked = True
            return
        raise OptionError(f"{flag} {self.path}: cannot take the lock {LOCK_NAME}")  # pragma: no cover

    def clear(self) -> None:
        """Delete the outputs of an earlier run: tables, rows, solutions, metadata and every figure."""
        for p in self.path.iterdir():
            if p.name in OUTPUT_NAMES or p.suffix.lower() == ".png":
                shutil.rmtree(p) if p.is_dir() else p.unlink()

    def close(self) -> None:
        """Release the lock."""
        if self._locked:
            (self.path / LOCK_NAME).unlink(missing_ok=True)
            self._locked = False

    def __enter__(self) -> ResultsFolder:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # ------------------------------------------------------------------ rows

    def finished_rows(self) -> list[dict[str, Any]]:
        """The rows of ``rows.jsonl`` (a torn last line, from a hard kill, is dropped)."""
        if not self.rows_path.exists():
            return []
        rows = []
        for line in self.rows_path.read_text().splitlines():
            try:
                rows.append(json.loads(line))
            except json.JSONDecodeError:
                continue
        return rows

    def append(self, row: dict[str, Any], result: Any = None) -> None:
        """Save one finished row (and its result, for the figures of a resumed run)."""
        import pickle

        if result is not None:
            try:
                data = pickle.dumps(result)
                _atomic_write(self.solution_path(row["run_key"]), lambda p: p.write_bytes(data))
            except Exception:  # a result that does not pickle only costs its figures
                pass
        line = json.dumps({k: _plain(v) for k, v in row.items()}) + "\n"
        with open(self.rows_path, "a") as fh:
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())

    def solution_path(self, run_key: str) -> Path:
        import hashlib

        return self.path / "solutions" / (hashlib.sha1(run_key.encode()).hexdigest()[:16] + ".pkl")

    def load_result(self, run_key: str) -> Any:
        """The pickled result of a finished row, or None."""
        import pickle

        path = self.solution_path(run_key)
        try:
            return pickle.loads(path.read_bytes())
        except Exception:
            return None

    def write_tables(self, df, stem: str = "results") -> list[Path]:
        """``<stem>.csv`` and ``<stem>.parquet``, each written to a temporary name and renamed."""
        return write_frame(df, self.path, stem)

    def write_metadata(self, info: dict[str, Any]) -> Path:
        path = self.path / "run.json"
        _atomic_write(path, lambda p: p.write_text(json.dumps(info, indent=1, default=str) + "\n"))
        return path


def write_frame(df, out_dir: str | Path, stem: str = "results") -> list[Path]:
    """``<stem>.csv`` and ``<stem>.parquet`` (pyarrow) in ``out_dir``, each written by rename."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = df.drop(columns=[c for c in ("traceback",) if c in df.columns])
    csv = out / f"{stem}.csv"
    _atomic_write(csv, lambda p: table.to_csv(p, index=False))
    safe = table.copy()
    for col in safe.columns:
        if safe[col].dtype == object:  # mixed columns (None, numbers, strings) as text
            safe[col] = safe[col].map(lambda v: None if v is None or (isinstance(v, float) and math.isnan(v))
                                      else str(v))
    parquet = out / f"{stem}.parquet"
    _atomic_write(parquet, lambda p: safe.to_parquet(p, index=False, engine="pyarrow"))
    return [csv, parquet]


def _plain(v: Any) -> Any:
    """A JSON-able value (numpy scalars to Python, everything else exotic to text)."""
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    try:
        import numpy as np

        if isinstance(v, np.generic):
            return v.item()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(v, (list, tuple, dict)):
        return json.loads(json.dumps(v, default=str))
    return str(v)


def run_metadata(command: list[str] | None = None, settings: dict[str, Any] | None = None) -> dict[str, Any]:
    """Versions, CPU, date and command of this run (the ``run.json`` sidecar)."""
    from importlib import metadata

    versions = {"python": platform.python_version()}
    for pkg in ("blockmpec", "numpy", "scipy", "pandas", "pyomo", "highspy", "cyipopt-wheels", "matplotlib",
                "joblib", "tqdm", "pyarrow", "dask", "distributed"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": command if command is not None else sys.argv,
        "cwd": os.getcwd(),
        "platform": platform.platform(),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "versions": versions,
        "settings": settings or {},
    }


# --------------------------------------------------------------------------- study files


@dataclasses.dataclass
class Study:
    """A study read from a TOML file: arguments of :func:`blockmpec.bench.compare.compare`."""

    cases: list[Any]
    methods: list[Any]
    repeat: int = 1
    verify_tol: float = 1e-6
    wall_limits: dict[str, float] = dataclasses.field(default_factory=dict)
    jobs: int | None = None
    backend: str | None = None
    scheduler: str | None = None
    #: the time budget of every case, or case label -> seconds (None: each case's default)
    budget: float | dict[str, float] | None = None


_TOP_KEYS = {"cases", "methods", "repeat", "verify_tol", "wall_limits", "jobs", "backend", "scheduler", "budget"}
_CASE_KEYS = {"label", "case", "suite", "file", "params"}
_METHOD_KEYS = {"label", "name", "options", "wall_limit"}


def _unknown(keys, allowed, where: str) -> None:
    extra = sorted(set(keys) - allowed)
    if extra:
        raise OptionError(f"{where}: unknown key {extra[0]!r}; valid keys: {', '.join(sorted(allowed))}")


def load_study(path: str | Path) -> Study:
    """Read a study file (format in the module docstring); every error names the file and the entry."""
    from blockmpec.bench.runs import CaseRun, MethodRun, parametrised_label

    try:
        import tomllib
    except ImportError:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise OptionError(f"--config {path}: cannot read the study file ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise OptionError(f"--config {path}: not valid TOML: {exc}") from None
    _unknown(data, _TOP_KEYS, f"{path}")
    cases, methods = [], []
    for i, entry in enumerate(data.get("cases") or []):
        where = f"{path}: cases[{i}]"
        if not isinstance(entry, dict):
            raise OptionError(f"{where}: expected a table with case, suite or file")
        _unknown(entry, _CASE_KEYS, where)
        params = dict(entry.get("params") or {})
        given = [k for k in ("case", "suite", "file") if k in entry]
        if len(given) != 1:
            raise OptionError(f"{where}: give exactly one of case, suite or file")
        if "suite" in entry:
            from blockmpec.bench.suite import BENCHMARK_SUITE

            label = entry["suite"]
            if label not in BENCHMARK_SUITE:
                raise OptionError(f"{where}: unknown suite case {label!r}; choose from {', '.join(BENCHMARK_SUITE)}")
            name, base = BENCHMARK_SUITE[label]
            params = {**base, **params}
            cases.append(CaseRun(entry.get("label", label), name, params))
        elif "case" in entry:
            cases.append(CaseRun(entry.get("label", parametrised_label(entry["case"], params)), entry["case"], params))
        else:
            from blockmpec.cases import load_case

            file = (path.parent / entry["file"]) if not Path(entry["file"]).is_absolute() else Path(entry["file"])
            structure = load_case(str(file), params)
            label = entry.get("label", parametrised_label(Path(entry["file"]).stem, params))
            cases.append(CaseRun(label, None, {}, structure))
    wall_limits = {}
    for name, value in (data.get("wall_limits") or {}).items():
        wall_limits[name] = _positive(value, f"{path}: wall_limits.{name}")
    for i, entry in enumerate(data.get("methods") or []):
        where = f"{path}: methods[{i}]"
        if not isinstance(entry, dict) or "name" not in entry:
            raise OptionError(f"{where}: expected a table with a name")
        _unknown(entry, _METHOD_KEYS, where)
        options = dict(entry.get("options") or {})
        run = MethodRun(entry.get("label", parametrised_label(entry["name"], options)), entry["name"], options)
        methods.append(run)
        if "wall_limit" in entry:
            wall_limits[run.label] = _positive(entry["wall_limit"], f"{where}: wall_limit")
    if not cases or not methods:
        raise OptionError(f"--config {path}: a study needs at least one [[cases]] and one [[methods]] entry")
    repeat = data.get("repeat", 1)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise OptionError(f"{path}: repeat must be an integer >= 1; got {repeat!r}")
    jobs = data.get("jobs")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise OptionError(f"{path}: jobs must be an integer >= 1; got {jobs!r}")
    budget = data.get("budget")
    if isinstance(budget, dict):
        labels = [c.label for c in cases]
        for label in budget:
            if label not in labels:
                raise OptionError(f"{path}: budget.{label}: no case labelled {label!r}; cases: {', '.join(labels)}")
        budget = {str(k): _positive(v, f"{path}: budget.{k}") for k, v in budget.items()}
    elif budget is not None:
        budget = _positive(budget, f"{path}: budget")
    return Study(cases, methods, repeat, check_tolerance(data.get("verify_tol", 1e-6), f"{path}: verify_tol"),
                 wall_limits, jobs, data.get("backend"), data.get("scheduler"), budget)


def _positive(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (value > 0 and math.isfinite(value)):
        raise OptionError(f"{where}: must be a finite number of seconds > 0; got {value!r}")
    return float(value)


def check_tolerance(value: Any, where: str = "--verify-tol") -> float:
    """A verification tolerance: a finite number > 0 (else OptionError naming ``where``)."""
    try:
        tol = float(value)
    except (TypeError, ValueError):
        raise OptionError(f"{where}: must be a finite number > 0; got {value!r}") from None
    if isinstance(value, bool) or not (math.isfinite(tol) and tol > 0):
        raise OptionError(f"{where}: must be a finite number > 0; got {value!r}")
    return tol
