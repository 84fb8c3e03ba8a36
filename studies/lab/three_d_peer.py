"""blockmpec against the peer (issue 52): the associative 3D LP of compas_dem's kind on compas_cra's contacts.

compas_dem's limit-analysis engine is not public, so its LP is rebuilt here as the issue describes: compas_cra finds
the contacts (``assembly_interfaces_numpy``, ``--nmax`` nearest neighbours per block: at its documented 10 the dome's ground
block, which touches 12 voussoirs, loses contacts) and builds its matrices (``equilibrium_setup``, ``friction_setup``: an
8-sided pyramid *circumscribing* the Coulomb cone at each contact point, ``external_force_setup``: the weights), and
CVXPY with Clarabel solves ``max lam  s.t.  A_eq f + p_dead + lam p_live = 0, f_n >= 0, A_fr f <= 0`` (the live load
the weights along the live direction).  Beside it, on the same structures, blockmpec: the structure built and its
contacts found (``make_structure_3d``), ``static-lp`` (4-sided inscribed pyramid), ``static-lp`` with the friction
widened to ``mu / cos(pi / 8)`` and 8 sides (a circumscribed 8-sided pyramid, as the peer's but turned by 22.5
degrees), the exact cone (Clarabel) and the fixed point (non-associative, which the peer does not offer).  The
differences come from the friction model (inscribed, circumscribed, exact) and not from the contacts: the contact
points are the same polygons' vertices.

Runs in its own environment, never as a dependency of blockmpec::

    python -m venv peer && peer/bin/pip install compas_cra cvxpy clarabel && peer/bin/pip install -e .
    peer/bin/python studies/lab/three_d_peer.py --cases block-3d,corner-wall,barrel-vault,dome --bonded 100,1000

Prints a markdown table and writes ``studies/output/three_d_peer/peer.csv``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import blockmpec as bm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _tables import markdown, write_csv  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "output" / "three_d_peer"
COLUMNS = [("case", "case", "{}"), ("blocks", "free blocks", "{}"), ("peer_points", "peer points", "{:,}"),
           ("points", "points", "{:,}"), ("peer_lam", "peer lam (8, circ.)", "{:.5f}"), ("peer_status", "peer status", "{}"),
           ("lam_circ8", "lam (8, circ.)", "{:.5f}"), ("lam_cone", "lam (cone)", "{:.5f}"),
           ("lam", "lam (4, inscr.)", "{:.5f}"), ("lam_fp", "lam (3), fixed point", "{:.5f}"),
           ("peer_contacts_s", "peer contacts [s]", "{:.2f}"), ("peer_total_s", "peer total [s]", "{:.2f}"),
           ("build_s", "contacts [s]", "{:.2f}"), ("total_s", "total [s]", "{:.2f}")]


def peer_lp(s, nmax: int = 30) -> dict:
    """compas_cra's contacts and matrices, the LP by CVXPY + Clarabel (module docstring)."""
    import cvxpy as cp
    from compas_assembly.datastructures import Block
    from compas_cra.algorithms import assembly_interfaces_numpy
    from compas_cra.datastructures import CRA_Assembly
    from compas_cra.equilibrium.cra_helper import equilibrium_setup, external_force_setup, free_nodes, friction_setup

    t0 = time.perf_counter()
    a = CRA_Assembly()
    for i, (v, f) in enumerate(zip(s.vertices, s.faces)):
        a.add_block(Block.from_vertices_and_faces(v.tolist(), [[int(k) for k in face] for face in f]), node=i)
    a.set_boundary_conditions([i for i in range(s.n_blocks) if s.fixed[i]])
    t1 = time.perf_counter()
    assembly_interfaces_numpy(a, nmax=nmax, amin=1e-6, tmax=1e-6)
    t2 = time.perf_counter()
    aeq = equilibrium_setup(a)
    afr = friction_setup(a, s.friction)
    dead = external_force_setup(a, 1.0).ravel()
    live = np.zeros_like(dead).reshape(-1, 6)
    live[:, :3] = -dead.reshape(-1, 6)[:, [2]] * s.live_factor * np.asarray(s.live_direction)[None, :]
    live = live.ravel()
    f, lam = cp.Variable(aeq.shape[1]), cp.Variable()
    problem = cp.Problem(cp.Maximize(lam), [aeq @ f + dead + lam * live == 0, f[0::3] >= 0, afr @ f <= 0])
    problem.solve(solver=cp.CLARABEL)
    t3 = time.perf_counter()
    del free_nodes
    return {"peer_points": aeq.shape[1] // 3, "peer_lam": float(lam.value) if lam.value is not None else None,
            "peer_status": problem.status, "peer_contacts_s": t2 - t1, "peer_total_s": t3 - t0}


def ours(s_build, fixed_point: bool) -> dict:
    from blockmpec.three_d.cone import exact_cone

    t0 = time.perf_counter()
    s = s_build()
    t1 = time.perf_counter()
    res = bm.solve(s, "static-lp")
    t2 = time.perf_counter()
    widened = s.with_material(friction=s.friction / math.cos(math.pi / 8)).with_loads(pyramid_sides=8)
    row = {"blocks": s.n_free, "points": bm.assemble(s).n_contacts, "lam": res.multiplier,
           "lam_circ8": bm.solve(widened, "static-lp").multiplier,
           "lam_cone": exact_cone(s, pyramid=False).multiplier, "build_s": t1 - t0, "total_s": t2 - t0}
    if fixed_point:
        fp = bm.solve(s, "fixed-point", time_limit=600)
        row["lam_fp"] = fp.multiplier if fp.verified else None
    return row, s


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default="block-3d,corner-wall,barrel-vault,dome", help="built-in 3D cases")
    ap.add_argument("--bonded", default="", help="sizes of two-leaf brick walls (studies/lab/three_d_scale.py)")
    ap.add_argument("--fixed-point", action="store_true", help="also blockmpec's fixed point")
    ap.add_argument("--nmax", type=int, default=30, help="compas_cra's nearest neighbours searched per block")
    args = ap.parse_args(argv)
    builders = [(name, lambda name=name: bm.build_case(name)) for name in args.cases.split(",") if name]
    if args.bonded:
        from three_d_scale import bonded_wall

        builders += [(f"bonded wall {n}", lambda n=int(n): bonded_wall(n)) for n in args.bonded.split(",")]
    rows = []
    for name, build in builders:
        row, s = ours(build, args.fixed_point)
        rows.append({"case": name, **row, **peer_lp(s, args.nmax)})
        print(markdown(rows[-1:], COLUMNS), flush=True)
    print(markdown(rows, COLUMNS))
    write_csv(OUT / "peer.csv", rows)
    return rows


if __name__ == "__main__":
    main()
