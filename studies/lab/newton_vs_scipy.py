r"""Our semismooth Newton method against scipy's general nonlinear solvers on the same MCP (3).

Every solver gets the same square system ``Phi(w) = 0`` -- the Fischer–Burmeister
form of (3) built by :class:`blockmpec.solvers.engines.newton_system.MCPSystem`
(scaled rows and unknowns) -- its sparse generalised Jacobian, and the same start:
the associative solution (static LP (1) with HiGHS and its duals), as
``mcp-newton`` takes it for ``start="associative"`` (``StaticLP`` + ``compile_mcp``
+ ``MCPSystem``), solved directly at ``tan(psi)`` (no continuation in the dilatancy,
so every solver faces the same single problem).

Solvers
-------
* ``semismooth_newton`` (ours): Newton / Levenberg–Marquardt / gradient directions
  with an Armijo search on ``||Phi||^2 / 2``, ``tol = 1e-10``.
* ``least_squares(method="trf", x_scale="jac")`` with the sparse Jacobian
  (``tr_solver="lsmr"``), ``ftol = xtol = gtol = 1e-15``.
* ``root(method="lm")`` (MINPACK ``lmder``) and ``root(method="hybr")`` (MINPACK
  ``hybrj``) with the Jacobian densified: only where the system has at most
  ``--dense-max`` unknowns (default 1500).

A run is *converged* when its final scaled ``||Phi||_inf <= 1e-10`` (the same test
for all); *verified* when every residual of
:func:`blockmpec.verify.residuals` (non-associative flow) is ``<= 1e-6``.  CPU time
is ``time.process_time`` of the solve alone (start and compilation excluded; they
are the same for all); each solve is capped at ``--cap`` CPU seconds (default 60)
by stopping in its residual callback.  "evals" counts residual evaluations /
Jacobian evaluations (Newton: line-search trials / iterations + 1).

Use ``python studies/lab/newton_vs_scipy.py [--cap 60] [--dense-max 1500] [--only "NAME;..."]``;
writes ``studies/output/newton_vs_scipy/table.md``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import blockmpec as bm
from blockmpec.deadline import Deadline
from blockmpec.formulations import compile_mcp
from blockmpec.solvers.engines.newton_system import MCPSystem, semismooth_newton
from blockmpec.verify import residuals

OUT = Path(__file__).resolve().parents[1] / "output" / "newton_vs_scipy"
TOL = 1e-10
VERIFY_TOL = 1e-6

CASES = [
    ("two-blocks(eta=3)", lambda: bm.cases.two_blocks(eta=3, mu=0.65)),
    ("single-block", lambda: bm.cases.single_block()),
    ("round-arch", lambda: bm.cases.round_arch()),
    ("arch-on-buttresses", lambda: bm.cases.arch_on_buttresses()),
    ("wall(4,2,stack)", lambda: bm.cases.wall(courses=4, blocks_per_course=2, bond="stack")),
    ("wall(5,4)", lambda: bm.cases.wall(5, 4)),
    ("wall(10,5)", lambda: bm.cases.wall(10, 5)),
    ("wall(20,10)", lambda: bm.cases.wall(20, 10)),
]


class _OutOfTime(Exception):
    pass


class Counted:
    """``Phi`` and ``J`` of a system with evaluation counts, the last point seen and a CPU-time cap."""

    def __init__(self, system: MCPSystem, cap: float, dense: bool = False) -> None:
        self.system, self.cap, self.dense = system, cap, dense
        self.nfev = self.njev = 0
        self.last = None
        self.t0 = time.process_time()

    def _tick(self, w):
        self.last = np.array(w, float)
        if time.process_time() - self.t0 > self.cap:
            raise _OutOfTime

    def fun(self, w):
        self._tick(w)
        self.nfev += 1
        return self.system.residual(w)

    def jac(self, w):
        self._tick(w)
        self.njev += 1
        J = self.system.residual(w, jacobian=True)[1]
        return J.toarray() if self.dense else J


def _newton(system, w0, cap):
    out = semismooth_newton(system, w0, tol=TOL, max_iterations=2000, deadline=Deadline(cap))
    return system.pack(out.solution), f"{out.iterations} it", out.message if out.status.value != "converged" else ""


def _least_squares(system, w0, cap):
    from scipy.optimize import least_squares

    f = Counted(system, cap)
    try:
        r = least_squares(f.fun, w0, jac=f.jac, method="trf", x_scale="jac", tr_solver="lsmr",
                          ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=10**6)
        return r.x, f"{f.nfev} / {f.njev}", "" if r.success else "scipy: " + r.message
    except _OutOfTime:
        return f.last, f"{f.nfev} / {f.njev}", "CPU cap"


def _root(method):
    def run(system, w0, cap):
        from scipy.optimize import root

        f = Counted(system, cap, dense=True)
        options = {"xtol": 1e-15}
        options["maxiter" if method == "lm" else "maxfev"] = 10**6
        try:
            r = root(f.fun, w0, jac=f.jac, method=method, options=options)
            return r.x, f"{f.nfev} / {f.njev}", "" if r.success else "scipy: " + str(r.message).splitlines()[0][:48]
        except _OutOfTime:
            return f.last, f"{f.nfev} / {f.njev}", "CPU cap"
    return run


SOLVERS = [
    ("semismooth_newton (ours)", _newton, False),
    ("least_squares trf, sparse", _least_squares, False),
    ("root lm (dense)", _root("lm"), True),
    ("root hybr (dense)", _root("hybr"), True),
]


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cap", type=float, default=60.0, help="CPU seconds per solve")
    parser.add_argument("--dense-max", type=int, default=1500, help="largest system for the dense root methods")
    parser.add_argument("--only", default="", help="semicolon-separated case names")
    args = parser.parse_args(argv)
    only = [s for s in args.only.split(";") if s]
    rows = []
    header = ("| case | unknowns | solver | converged | final ‖Φ‖∞ | iterations or evals (f / J) | CPU s "
              "| λ | verified (≤ 1e-6) | note |")
    lines = [header, "|" + "---|" * 10]
    print(header, flush=True)
    print(lines[1], flush=True)
    for name, build in CASES:
        if only and name not in only:
            continue
        ops = bm.assemble(build())
        form = compile_mcp(ops)
        start = bm.solve(ops, "static-lp").solution  # the associative start of mcp-newton
        system = MCPSystem(form, start)
        w0 = system.pack(start)
        for label, solve, dense in SOLVERS:
            if dense and w0.size > args.dense_max:
                line = f"| {name} | {w0.size} | {label} | — | — | — | — | — | — | skipped (dense, n > {args.dense_max}) |"
                print(line, flush=True)
                lines.append(line)
                continue
            t0 = time.process_time()
            w, evals, note = solve(system, w0.copy(), args.cap)
            cpu = time.process_time() - t0
            res = float(np.max(np.abs(system.residual(w))))
            sol = system.unpack(w)
            ver = residuals(ops, sol, associative=False)
            worst = max(ver.values()) if ver else float("nan")
            row = dict(case=name, n=w0.size, solver=label, converged=res <= TOL, residual=res, evals=evals,
                       cpu=cpu, lam=sol.multiplier, verified=worst <= VERIFY_TOL, worst=worst, note=note)
            rows.append(row)
            line = (f"| {name} | {w0.size} | {label} | {'yes' if row['converged'] else 'no'} | {res:.1e} | {evals} "
                    f"| {cpu:.3f} | {sol.multiplier:.5f} | {'yes' if row['verified'] else 'no'} ({worst:.0e}) "
                    f"| {note.replace('|', '/')} |")
            print(line, flush=True)
            lines.append(line)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "table.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT / 'table.md'}")
    return rows


if __name__ == "__main__":
    main()
