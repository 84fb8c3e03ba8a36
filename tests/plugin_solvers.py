"""Plug-in methods defined outside blockmpec, for tests/test_plugins.py: one that conforms, and one per way of
breaking the contract that the conformance suite must catch.

They live in a module (not inside a test) so that the comparator's worker processes can import them; none registers
itself (an entry point or a ``module:Class`` name finds them).  Each delegates the static LP (1) to blockmpec's
``static-lp`` (a plug-in may call any registered method), then breaks one rule.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.options import CommonOptions


class DelegatingLP(bm.SolverBase):
    """A conforming plug-in: the static LP (1), solved by ``static-lp`` within this run's deadline."""

    name = "test-plugin-lp"
    problem = "associative"
    summary = "static LP (1) by static-lp, as a plug-in (test)"

    def setup(self, ops: bm.Operators) -> None:
        self.inner = bm.get_solver("static-lp")(time_limit=self.options.time_limit)
        self.inner.setup(ops)

    def run(self, deadline: Deadline) -> bm.RunOutput:
        return self.inner.run(deadline)


class LambdaOnePercentOff(DelegatingLP):
    """Reports a multiplier 1 % above the LP optimum (its forces are the optimum's)."""

    name = "test-plugin-lam-off"

    def run(self, deadline: Deadline) -> bm.RunOutput:
        out = super().run(deadline)
        if out.solution.multiplier is not None:
            out.solution.multiplier *= 1.01
        return out


class FalseInfeasible(DelegatingLP):
    """Says ``infeasible`` wherever its LP is not optimal at once, here always (a heuristic that gave up)."""

    name = "test-plugin-false-infeasible"

    def run(self, deadline: Deadline) -> bm.RunOutput:
        if deadline.expired():
            return bm.RunOutput(bm.Status.TIME_LIMIT)
        return bm.RunOutput(bm.Status.INFEASIBLE, message="no collapse mechanism found")


class IgnoresTimeLimit(DelegatingLP):
    """Runs its LP without a deadline, whatever the time limit."""

    name = "test-plugin-ignores-time-limit"

    def run(self, deadline: Deadline) -> bm.RunOutput:
        return self.inner.run(Deadline())


@dataclass
class UncheckedOptions(CommonOptions):
    """An option declared but never validated (no ``__post_init__`` of its own)."""

    scale: float = field(default=1.0, metadata={"help": "a factor (never checked)"})


class UncheckedOption(DelegatingLP):
    """Accepts ``scale="banana"``."""

    name = "test-plugin-unchecked-option"
    Options = UncheckedOptions


class NamedLikeABuiltIn(DelegatingLP):
    """Takes the name of a built-in method."""

    name = "static-lp"


#: not a method: an entry point naming it is a broken plug-in
NOT_A_SOLVER = "a string, not a SolverBase subclass"
