"""The suite that judges the non-associative heuristics: structures with a certified minimum of (4).

Each entry is a structure and where its reference minimum comes from:

* ``"closed form"``: the two-block grid over ``(eta, mu)`` with ``psi = 0``
  (``bm.cases.closed_form("two-blocks", "non-associative", ...)`` = ``min(mu, 1/eta)``);
* ``"milp"``: the global minimum certified by ``milp`` (status ``optimal``, gap closed):
  stack and running-bond walls of a few blocks, walls with openings, arches, arches
  on buttresses, and a few cases with ``psi > 0``;
* ``"best verified"``: larger walls, where no certificate is in reach; their
  reference is the lowest verified multiplier any strategy of the run found.

Certificates are cached on disk (``studies/output/heuristic_suite/certificates.json``,
keyed by the entry's label, with a hash of the structure's JSON form; never in git); an uncertified
``milp`` run (time limit) leaves its structure out of the certified set and says so.

Use ``python studies/lab/heuristic_suite.py [--time-limit 120]`` to (re)compute and list
the certificates; :func:`suite` is imported by ``studies/lab/fixed_point_strategies.py``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import blockmpec as bm

OUT = Path(__file__).resolve().parents[1] / "output" / "heuristic_suite"
CACHE = OUT / "certificates.json"

ETAS = (1.5, 2.5, 3.0, 4.0, 6.0)
MUS = (0.3, 0.5, 0.65, 0.9, 1.2)


@dataclass
class Entry:
    """One suite structure: label, family, builder and the source of its reference."""

    label: str
    family: str
    build: Callable[[], bm.Structure]
    source: str  # "closed form" | "milp" | "best verified"
    closed_form: float | None = None
    params: dict = field(default_factory=dict)


def _two_blocks(eta: float, mu: float, dilatancy: float = 0.0) -> Entry:
    cf = bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu, dilatancy=dilatancy)
    label = f"two-blocks(eta={eta:g},mu={mu:g}" + (f",psi={dilatancy:g})" if dilatancy else ")")
    return Entry(label, "two-blocks" if not dilatancy else "psi>0",
                 lambda: bm.cases.two_blocks(eta=eta, mu=mu, dilatancy=dilatancy),
                 "closed form" if cf is not None else "milp", cf)


def _wall(courses: int, per_course: int, bond: str = "running", family: str | None = None,
          source: str = "milp", **kw) -> Entry:
    extra = ",".join(f"{k}={v}" for k, v in kw.items())
    label = f"wall-{courses}x{per_course}-{bond}" + (f"({extra})" if extra else "")
    fam = family or f"{bond} wall"
    return Entry(label, fam, lambda: bm.cases.wall(courses, per_course, bond=bond, **kw), source)


def _arch(**kw) -> Entry:
    label = "round-arch(" + ",".join(f"{k}={v}" for k, v in kw.items()) + ")"
    return Entry(label, "arch" if not kw.get("dilatancy") else "psi>0", lambda: bm.cases.round_arch(**kw), "milp")


def _buttressed(**kw) -> Entry:
    label = "arch-on-buttresses(" + ",".join(f"{k}={v}" for k, v in kw.items()) + ")"
    return Entry(label, "arch on buttresses", lambda: bm.cases.arch_on_buttresses(**kw), "milp")


def suite(include_large: bool = True) -> list[Entry]:
    """The suite's entries, in a fixed order."""
    entries = [_two_blocks(eta, mu) for eta in ETAS for mu in MUS]
    entries += [_wall(c, b, "stack") for c, b in ((2, 2), (3, 2), (4, 2), (3, 3), (5, 2))]
    entries += [_wall(c, b, "running") for c, b in ((2, 2), (3, 2), (2, 3))]
    entries += [_wall(4, 2, "stack", mu=mu) for mu in (0.4, 0.5, 0.8, 1.0)]
    entries += [_wall(5, 2, "stack", mu=0.8), _wall(3, 2, "stack", block_height=1.0),
                _wall(4, 2, "stack", block_height=0.75), _wall(3, 1, "stack", block_height=1.5)]
    entries += [
        _wall(3, 2, "running", family="wall with opening", openings=[[0.5, 0.5, 1.5, 1.0]]),
        _wall(3, 2, "running", family="wall with opening", openings=[[0.0, 1.0, 1.0, 1.5]]),
    ]
    entries += [_arch(n_voussoirs=n, thickness=t, mu=mu)
                for n, t, mu in ((6, 0.15, 0.65), (8, 0.15, 0.65), (10, 0.15, 0.65), (12, 0.12, 0.65),
                                 (10, 0.2, 0.4), (10, 0.15, 0.5))]
    entries += [_buttressed(), _buttressed(buttress_courses=4, mu=0.5), _buttressed(n_voussoirs=8, mu=0.4)]
    entries += [_two_blocks(3.0, 0.65, 0.2), _two_blocks(5.0, 1.2, 0.4),
                _wall(4, 2, "stack", family="psi>0", dilatancy=0.3), _arch(n_voussoirs=10, mu=0.65, dilatancy=0.3)]
    if include_large:
        entries += [_wall(10, 5, source="best verified", family="large wall"),
                    _wall(10, 20, source="best verified", family="large wall"),
                    _wall(20, 10, "stack", source="best verified", family="large wall")]
    return entries


def structure_key(structure: bm.Structure) -> str:
    """Content hash of a structure (its lossless JSON form)."""
    text = json.dumps(bm.structure_to_dict(structure), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def _load_cache() -> dict:
    return json.loads(CACHE.read_text()) if CACHE.exists() else {}


def certificate(entry: Entry, time_limit: float = 120.0, compute: bool = True) -> dict:
    """The entry's reference: ``{"value", "source", "certified", ...}`` (cached for ``milp``).

    ``value`` is None when no certificate was obtained (``milp`` not optimal within
    ``time_limit``) or the entry is judged against the best verified value.
    """
    if entry.source == "closed form":
        return {"value": entry.closed_form, "source": "closed form", "certified": True}
    if entry.source == "best verified":
        return {"value": None, "source": "best verified", "certified": False}
    structure = entry.build()
    key = entry.label  # labels name the generator and its parameters; the hash is kept to spot changes
    cache = _load_cache()
    hit = cache.get(key)
    if hit is not None and (hit["certified"] or hit.get("time_limit", 0) >= time_limit or not compute):
        return hit
    if not compute:
        return {"value": None, "source": "milp", "certified": False}
    t0 = time.perf_counter()
    res = bm.solve(structure, "milp", time_limit=time_limit)
    certified = res.status is bm.Status.OPTIMAL
    record = {"structure_hash": structure_key(structure), "value": res.multiplier if certified else None, "source": "milp",
              "certified": certified, "status": res.status.value, "time_limit": time_limit,
              "seconds": round(time.perf_counter() - t0, 3)}
    cache = _load_cache()
    cache[key] = record
    OUT.mkdir(parents=True, exist_ok=True)
    CACHE.write_text(json.dumps(cache, indent=1, sort_keys=True))
    return record


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--time-limit", type=float, default=120.0, help="seconds per milp certificate")
    parser.add_argument("--first", type=int, default=None, help="only the suite's first N structures")
    args = parser.parse_args(argv)
    certified = 0
    for entry in suite(include_large=False)[:args.first]:
        ref = certificate(entry, args.time_limit)
        ops = bm.assemble(entry.build())
        lam_assoc = bm.solve(ops, "static-lp").multiplier
        assoc = "-" if lam_assoc is None else f"{lam_assoc:.6f}"
        certified += bool(ref["certified"])
        value = "-" if ref["value"] is None else f"{ref['value']:.6f}"
        print(f"{entry.label:<58} {entry.family:<20} {ref['source']:<12} {value:>9}  assoc {assoc}"
              f"  {ref.get('status', '')} {ref.get('seconds', '')}", flush=True)
    print(f"{certified} structures with a certified minimum; cache {CACHE}")


if __name__ == "__main__":
    main()
