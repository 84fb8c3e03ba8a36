"""mcp-newton strategies (starting points, continuation, fallback) on the heuristic suite.

Every strategy runs on every structure of ``studies/lab/heuristic_suite.py`` and is
judged like the fixed-point strategies (same runner and table as
``studies/lab/fixed_point_strategies.py``, imported from it): the share verified and
within 1 % / 2 % of the certified minimum (all certified structures, and those
whose minimum lies below the associative multiplier), the large walls against the
best verified value of the run, median and maximum relative error, runs below a
certificate (must be 0), friction admissibility and median solve time.

Strategies: ``start`` = ``associative`` (the former default: static LP (1), then the
continuation in the dilatancy ``tan(phi) -> tan(psi)``; also without continuation),
``fixed-point`` (the fixed point's default solution), ``dead-load`` and seeded
``random`` (one fixed-point step from those normal forces), ``nlp``; with and
without the associative ``fallback``.  The default ``fixed-point`` method is listed
as a reference row.

Use ``python studies/lab/mcp_newton_strategies.py [--only LABEL,...] [--no-large] [--time-limit 60]``;
writes ``studies/output/mcp_newton_strategies/{runs.csv,table.md}``.  Certificates come
from the cache of ``heuristic_suite.py`` (run it first).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1] / "_common")]
from fixed_point_strategies import run_study  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "mcp_newton_strategies"

NEWTON = "mcp-newton"
STRATEGIES: list[tuple[str, str, dict]] = [
    ("newton associative, continuation (old default)", NEWTON, {"start": "associative"}),
    ("newton associative, no continuation", NEWTON, {"start": "associative", "continuation": False}),
    ("newton fixed-point", NEWTON, {"start": "fixed-point"}),
    ("newton fixed-point, no fallback", NEWTON, {"start": "fixed-point", "fallback": False}),
    ("newton dead-load", NEWTON, {"start": "dead-load"}),
    ("newton dead-load, no fallback", NEWTON, {"start": "dead-load", "fallback": False}),
    *[(f"newton random(seed={s})", NEWTON, {"start": "random", "seed": s}) for s in (0, 1, 2)],
    ("newton random(seed=0), no fallback", NEWTON, {"start": "random", "seed": 0, "fallback": False}),
    ("newton nlp", NEWTON, {"start": "nlp"}),
    ("fixed-point default (reference)", "fixed-point", {}),
]


def main(argv: list[str] | None = None) -> list[dict]:
    return run_study(argv, STRATEGIES, OUT, 60.0, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
