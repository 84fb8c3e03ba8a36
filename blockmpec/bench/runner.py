r"""Isolated solves and their execution: serially, on local worker processes (joblib) or on Dask.

Isolation
---------
Every solve of a comparison runs in a **child process** (a separate interpreter), started by a *supervisor*: the
main process (``n_jobs=1``), a joblib/loky worker (``backend="loky"``) or a Dask
worker (``backend="dask"``).  The supervisor waits at most the task's wall-clock
limit ``wall_limit_s`` and then kills the child's whole process group, so

* a hang becomes a row with status ``time_limit`` (message: killed after the limit),
* a crash (segfault, abort, out-of-memory kill) becomes a row with status ``error``
  naming the signal,
* an exception escaping :func:`blockmpec.solve` becomes a row with status ``error``,

and the study goes on.  Children run in their own session, so Ctrl-C in the
terminal reaches only the main process, which kills the running children and
saves the finished rows; a child whose supervisor dies (a killed worker) notices
within half a second and exits.

The child is kept for the supervisor's next task (a fresh interpreter per solve
cost ~3.5 s of imports each on a loaded 2-core machine) and replaced after a kill or
crash; ``isolate=False`` runs solves in the supervisor itself (no protection, for
debugging).

Execution
---------
:func:`execute` yields :class:`Outcome` objects *as they finish* (not in task
order), for every backend:

* ``n_jobs == 1`` and no backend: a plain loop in the calling process;
* ``backend="loky"`` (or ``n_jobs > 1``): ``joblib.Parallel(n_jobs, backend="loky",
  return_as="generator_unordered")``;
* ``backend="dask"``: the same joblib call inside ``joblib.parallel_config("dask")``,
  on the cluster at ``scheduler`` (an address such as ``tcp://host:8786``) or, without
  one, on a ``distributed.LocalCluster`` of ``n_jobs`` single-threaded worker processes
  started here and closed at the end.

CPUs
----
Solves that run side by side on this machine (``n_jobs`` > 1: joblib's workers or a local Dask cluster) each
get ``cpus // n_jobs`` of the CPUs this process may run on (:func:`shared_cpus`, at least one) through the
environment variable :data:`CPUS_VARIABLE` (``BLOCKMPEC_CPUS``), which the automatic settings of a solve read,
such as the block IPM's second process for ``K`` (``factor_processes="auto"``).  So two jobs on two CPUs run one
CPU each instead of four processes competing for two.  Settings given explicitly are kept.  On a Dask cluster at ``scheduler``
the machines are the cluster's: nothing is capped there.
"""

from __future__ import annotations

import dataclasses
import math
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import blockmpec as bm
from blockmpec import OptionError
from blockmpec.options import DEFAULT_TIME_LIMIT_S
from blockmpec.solvers.linalg import cpus
from blockmpec.solvers.linalg.cpus import CPUS_VARIABLE

#: the outside wall-clock limit of a solve run with the default ``time_limit``
#: (:data:`blockmpec.options.DEFAULT_TIME_LIMIT_S`, 600 s): ``max(1.5 t, t + 30 s)`` = 900 s
DEFAULT_WALL_LIMIT_S = max(1.5 * DEFAULT_TIME_LIMIT_S, DEFAULT_TIME_LIMIT_S + 30.0)


def cpu_budget() -> int | None:
    """The CPUs one solve may use by :data:`CPUS_VARIABLE` (None when it is unset or empty).

    :func:`execute` sets it for each solve that runs beside others (``n_jobs`` > 1 on this machine: the
    CPUs this process may run on divided by ``n_jobs``); set it yourself to keep your own parallel solves
    from competing, e.g. ``BLOCKMPEC_CPUS=1``.  A value that is not a positive whole number is an
    :class:`~blockmpec.errors.OptionError` naming the variable."""
    try:
        return cpus.cpu_budget()
    except ValueError as exc:
        raise OptionError(str(exc)) from None


def usable_cpus() -> int:
    """CPUs this process may run on, at most :func:`cpu_budget` (an OptionError when that is malformed)."""
    cpu_budget()
    return cpus.usable_cpus()


def default_wall_limit(options: dict[str, Any], method: str | None = None) -> float:
    """The outside wall-clock limit of one solve: ``max(1.5 t, t + 30 s)`` for a method run with
    ``time_limit = t`` (room for set-up and the method's own overshoot, so that the method reports its
    ``time_limit`` itself before it is killed).

    ``t`` is the ``time_limit`` in ``options``, else the method's default: the one default of
    :class:`blockmpec.options.CommonOptions` (:data:`~blockmpec.options.DEFAULT_TIME_LIMIT_S`, 600 s, so
    900 s outside) unless the method declares its own.  ``time_limit = inf`` asks for no limit: the outside
    limit is then ``inf`` too (the supervisor waits; give ``wall_limit=`` / ``--wall-limit`` to bound it).
    """
    t = options.get("time_limit")
    if t is None:
        t = _default_time_limit(method) if method is not None else None
    if t is None:
        t = DEFAULT_TIME_LIMIT_S
    if isinstance(t, (int, float)) and not isinstance(t, bool) and t > 0:
        return math.inf if math.isinf(t) else max(1.5 * float(t), float(t) + 30.0)
    return DEFAULT_WALL_LIMIT_S  # not a time limit: the method refuses it before anything runs


def _default_time_limit(method: str) -> float | None:
    """The default of the method's ``time_limit`` option (None for an unknown method or one without it)."""
    try:
        fields = {f.name: f for f in dataclasses.fields(bm.get_solver(method).Options)}
    except bm.BlockmpecError:
        return None
    f = fields.get("time_limit")
    return None if f is None or f.default is dataclasses.MISSING else f.default


@dataclasses.dataclass
class Task:
    """One solve: a structure, a method with options, and the limits it runs under."""

    task_id: int
    structure: Any  # blockmpec.geometry.Structure
    method: str
    options: dict[str, Any]
    verify_tol: float
    wall_limit_s: float
    #: modules to import in the child before solving (methods registered outside ``blockmpec.solvers``)
    plugins: tuple[str, ...] = ()
    #: the parent's ``sys.path`` (so that the child finds the same plug-ins)
    sys_path: tuple[str, ...] = ()
    #: folder where the supervisor marks the start of the solve (for the progress bar), or None
    marker_dir: str | None = None
    #: CPUs the solve's automatic settings may use (:data:`CPUS_VARIABLE` while it runs), None: not capped here
    cpus: int | None = None
    #: the method's engine settings (an instance of its ``Settings``), None: its measured defaults
    settings: Any = None


@dataclasses.dataclass
class Outcome:
    """What a task produced: a :class:`~blockmpec.result.Result`, or why there is none."""

    task_id: int
    result: Any = None  # blockmpec.result.Result | None
    status: str = ""  # set when result is None: "error" or "time_limit"
    message: str = ""
    traceback: str = ""
    wall_time_s: float = 0.0


# --------------------------------------------------------------------------- one solve


def run_in_process(task: Task) -> Outcome:
    """Solve ``task`` here; an exception escaping :func:`blockmpec.solve` becomes an ``error`` outcome."""
    t0 = time.perf_counter()
    previous = os.environ.get(CPUS_VARIABLE)
    if task.cpus is not None:
        os.environ[CPUS_VARIABLE] = str(task.cpus)
    try:
        if task.settings is None:
            res = bm.solve(task.structure, task.method, verify_tol=task.verify_tol, **task.options)
        else:
            solver = bm.get_solver(task.method)(settings=task.settings, **task.options)
            res = bm.run_solver(solver, task.structure, verify_tol=task.verify_tol)
    except BaseException as exc:  # noqa: BLE001 - every failure of one solve is a row
        if isinstance(exc, KeyboardInterrupt):
            raise
        return Outcome(task.task_id, status="error", message=f"run failed: {type(exc).__name__}: {exc}",
                       traceback=traceback.format_exc(limit=5), wall_time_s=time.perf_counter() - t0)
    finally:
        if task.cpus is not None:
            if previous is None:
                os.environ.pop(CPUS_VARIABLE, None)
            else:
                os.environ[CPUS_VARIABLE] = previous
    return Outcome(task.task_id, result=res, wall_time_s=time.perf_counter() - t0)


def _picklable(outcome: Outcome) -> Outcome:
    """The outcome, with ``result.extra`` cut to plain values if the whole result does not pickle."""
    try:
        pickle.dumps(outcome)
        return outcome
    except Exception:
        res = outcome.result
        res.extra = {k: v for k, v in res.extra.items() if isinstance(v, (int, float, str, bool, type(None)))}
        return outcome


def _signal_name(code: int) -> str:
    try:
        return signal.Signals(-code).name
    except ValueError:
        return f"signal {-code}"


def run_isolated(task: Task) -> Outcome:
    """Solve ``task`` in this supervisor's child process, killed after ``task.wall_limit_s``
    (see the module docstring).  The child is started on first use and kept for this thread's
    next task unless it died or was killed."""
    marker = None
    if task.marker_dir:
        marker = Path(task.marker_dir) / f"{task.task_id}.start"
        try:
            marker.write_text(repr(time.time()))
        except OSError:
            marker = None
    server = getattr(_LOCAL, "server", None)
    try:
        if server is None or not server.alive(task.sys_path):
            server = _LOCAL.server = SolveServer(task.sys_path)
        return server.solve(task)
    except BaseException:  # KeyboardInterrupt or a worker shut down: take the child with us
        if server is not None:
            server.kill()
            _LOCAL.server = None
        raise
    finally:
        if marker is not None:
            try:
                marker.unlink()
            except OSError:
                pass


class SolveServer:
    """A child interpreter that solves tasks sent over a pipe, one at a time.

    Protocol: 8-byte big-endian length + pickle, a :class:`Task` in and an :class:`Outcome`
    out, on two pipes of their own (solver libraries print freely on stdout).  The child
    runs in a new session (Ctrl-C in a terminal does not reach it) and exits when its
    parent goes away.
    """

    def __init__(self, sys_path: tuple[str, ...] = ()) -> None:
        self.sys_path = tuple(sys_path)
        task_r, self._task_w = os.pipe()
        self._out_r, out_w = os.pipe()
        self._log = tempfile.TemporaryFile()
        env = dict(os.environ)
        paths = [p for p in self.sys_path if p]
        if paths:
            env["PYTHONPATH"] = os.pathsep.join(paths + [env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        self.process = subprocess.Popen([sys.executable, "-c", _CHILD, str(task_r), str(out_w)],
                                        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=self._log,
                                        start_new_session=True, env=env, pass_fds=(task_r, out_w))
        os.close(task_r)
        os.close(out_w)

    def alive(self, sys_path: tuple[str, ...]) -> bool:
        """True if the child runs and was started with the same ``sys_path``."""
        return self.process.poll() is None and tuple(sys_path) == self.sys_path

    def solve(self, task: Task) -> Outcome:
        """Send ``task``, wait at most ``task.wall_limit_s`` for its outcome (see :func:`run_isolated`)."""
        import select

        t0 = time.perf_counter()
        data = pickle.dumps(task)
        try:
            _write_all(self._task_w, len(data).to_bytes(8, "big") + data)
        except OSError:
            return self._died(task, t0)
        deadline = t0 + task.wall_limit_s
        buf = b""
        need = 8
        size = None
        while True:
            left = deadline - time.perf_counter()
            if left <= 0:
                self.kill()
                return Outcome(task.task_id, status="time_limit", wall_time_s=time.perf_counter() - t0,
                               message=f"killed after the wall-clock limit of {task.wall_limit_s:g} s "
                                       "(enforced from outside)")
            ready, _, _ = select.select([self._out_r], [], [], min(left, 1.0))
            if not ready:
                continue
            chunk = os.read(self._out_r, 1 << 20)
            if not chunk:
                return self._died(task, t0)
            buf += chunk
            if size is None and len(buf) >= need:
                size = int.from_bytes(buf[:8], "big")
                buf = buf[8:]
            if size is not None and len(buf) >= size:
                outcome = pickle.loads(buf[:size])
                outcome.wall_time_s = time.perf_counter() - t0
                return outcome

    def _died(self, task: Task, t0: float) -> Outcome:
        try:
            code = self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - closed its pipe but still running
            self.kill()
            code = self.process.returncode
        self._log.seek(0)
        tail = self._log.read().decode(errors="replace").strip().splitlines()[-3:]
        why = f"killed by {_signal_name(code)}" if code is not None and code < 0 else f"exited with code {code}"
        self.close_pipes()
        return Outcome(task.task_id, status="error", wall_time_s=time.perf_counter() - t0,
                       message=f"solver process {why}" + (f": {' | '.join(tail)}" if tail else ""))

    def kill(self) -> None:
        """Kill the child's process group and wait for it."""
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL does not wait
            pass
        self.close_pipes()

    def close_pipes(self) -> None:
        for fd in (self._task_w, self._out_r):
            try:
                os.close(fd)
            except OSError:
                pass
        self._task_w = self._out_r = -1


#: one child per supervising thread (a Dask worker may run several tasks at once)
_LOCAL = threading.local()


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _read_exact(fd: int, n: int) -> bytes | None:
    buf = b""
    while len(buf) < n:
        chunk = os.read(fd, n - len(buf))
        if not chunk:
            return None
        buf += chunk
    return buf


def _watch_parent() -> None:
    """Exit this child as soon as the process that started it is gone (e.g. a killed worker)."""
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(70)

    threading.Thread(target=watch, daemon=True).start()


#: the child's command line (not ``-m blockmpec.bench.runner``: its classes must unpickle as ``blockmpec.bench.runner.*``)
_CHILD = "import sys; from blockmpec.bench.runner import _child_main; sys.exit(_child_main(sys.argv[1:]))"


def _child_main(argv: list[str]) -> int:
    """``python -c _CHILD TASK_FD OUTCOME_FD``: the child side of :class:`SolveServer`."""
    import importlib

    _watch_parent()
    task_r, out_w = int(argv[0]), int(argv[1])
    importlib.import_module("blockmpec.solvers")
    while True:
        head = _read_exact(task_r, 8)
        if head is None:
            return 0
        task: Task = pickle.loads(_read_exact(task_r, int.from_bytes(head, "big")))
        for module in task.plugins:
            importlib.import_module(module)
        outcome = _picklable(run_in_process(task))
        data = pickle.dumps(outcome)
        _write_all(out_w, len(data).to_bytes(8, "big") + data)


# --------------------------------------------------------------------------- many solves


def shared_cpus(n_jobs: int) -> int:
    """Each of ``n_jobs`` solves' share of :func:`usable_cpus`, at least 1: what :func:`execute` gives each solve
    that runs beside others on this machine."""
    return max(1, usable_cpus() // max(int(n_jobs), 1))


BACKENDS = ("loky", "dask")


def check_backend(n_jobs: int, backend: str | None, scheduler: str | None) -> None:
    """Raise OptionError for a bad combination of ``n_jobs``, ``backend`` and ``scheduler`` (or a bad
    :data:`CPUS_VARIABLE`, which :func:`execute` reads)."""
    cpu_budget()
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs < 1:
        raise OptionError(f"jobs: must be an integer >= 1; got {n_jobs!r}")
    if backend is not None and backend not in BACKENDS:
        raise OptionError(f"backend: must be one of {', '.join(BACKENDS)}; got {backend!r}")
    if scheduler and backend != "dask":
        raise OptionError("scheduler: an address is used only with backend 'dask'")
    if backend == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise OptionError("backend 'dask' needs dask and distributed: pip install 'blockmpec[dask]'") from None


def execute(tasks: Iterable[Task], *, n_jobs: int = 1, backend: str | None = None, scheduler: str | None = None,
            isolate: bool = True) -> Iterator[Outcome]:
    """Run ``tasks`` and yield their outcomes as they finish (see the module docstring)."""
    tasks = list(tasks)
    check_backend(n_jobs, backend, scheduler)
    work = run_isolated if isolate else run_in_process
    if not tasks:
        return
    if backend is None and n_jobs == 1:
        for task in tasks:
            yield work(task)
        return
    if not scheduler:  # n_jobs solves side by side on this machine: each gets its share of the CPUs
        share = shared_cpus(n_jobs)
        tasks = [task if task.cpus is not None else dataclasses.replace(task, cpus=share) for task in tasks]
    from joblib import Parallel, delayed, parallel_config

    if backend == "dask":
        from distributed import Client, LocalCluster

        cluster = None
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=n_jobs, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=40)
            client = Client(cluster)
        try:
            with parallel_config(backend="dask"):
                yield from Parallel(return_as="generator_unordered", batch_size=1)(delayed(work)(t) for t in tasks)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
        return
    yield from Parallel(n_jobs=n_jobs, backend="loky", return_as="generator_unordered", batch_size=1)(
        delayed(work)(t) for t in tasks)

