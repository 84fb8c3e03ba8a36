"""Throw-away methods for the comparator's tests, registered on import.

They live in a module (not inside a test) so that the comparator's worker processes can
import them too (:class:`blockmpec.bench.runner.Task` carries the module name and ``sys.path``).
"""

from __future__ import annotations

import os
import signal
import time

from blockmpec import registry
from blockmpec.errors import BlockmpecError
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solver import SolverBase


class _Base(SolverBase):
    problem = "non-associative"
    summary = "test dummy"


class RaisesInRun(_Base):
    name = "test-raises-in-run"

    def run(self, deadline):
        raise RuntimeError("deliberate failure")


class RaisesInSetup(_Base):
    name = "test-raises-in-setup"

    def setup(self, ops):
        raise ZeroDivisionError("deliberate set-up failure")


class NeverFits(_Base):
    name = "test-never-fits"

    def skip_reason(self, ops):
        return "this dummy fits no case"

    def run(self, deadline):  # pragma: no cover - never reached
        return RunOutput(Status.CONVERGED, Solution(multiplier=1.0))


class EscapesSolve(_Base):
    name = "test-escapes-solve"

    def run(self, deadline):
        raise BlockmpecError("escaped from solve")  # solve() re-raises its own errors


class Segfaults(_Base):
    name = "test-segfaults"

    def run(self, deadline):
        os.kill(os.getpid(), signal.SIGSEGV)
        time.sleep(10)  # pragma: no cover


class Hangs(_Base):
    name = "test-hangs"

    def run(self, deadline):
        time.sleep(3600)  # pragma: no cover - killed from outside


class ReportsCpus(_Base):
    """Reports the CPUs its solve may use: :data:`blockmpec.bench.runner.CPUS_VARIABLE` as the solve sees it and what the
    block IPM's automatic settings read from it."""

    name = "test-reports-cpus"

    def run(self, deadline):
        from blockmpec.bench.runner import CPUS_VARIABLE, usable_cpus

        return RunOutput(Status.CONVERGED, Solution(multiplier=1.0),
                         extra={"cpus_variable": os.environ.get(CPUS_VARIABLE), "usable_cpus": usable_cpus()})


#: the dummies that fail, each in its own way
DUMMIES = [RaisesInRun, RaisesInSetup, NeverFits, EscapesSolve, Segfaults, Hangs]
NAMES = [c.name for c in DUMMIES]

registry.list_solvers()  # load the real plug-ins first
for _cls in (*DUMMIES, ReportsCpus):
    registry.register_solver(_cls)
