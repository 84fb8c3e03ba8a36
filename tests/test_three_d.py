"""3D blocks: closed forms, the extruded 2D suite against 2D, invariance, bad meshes, files, results, the cone.

References: the single block's multipliers are closed forms (sliding ``mu`` or overturning ``b/h`` about the toe; on
a base inclined by ``a``, ``tan(a + min(phi, atan(b/h)))``: statics of one block, see blockmpec.three_d.cases); the
extruded structures are checked against blockmpec's 2D solves of the same structures (an independent assembly: 2D
interfaces with moments, 3D contact points with a pyramid).
"""

import json
import math

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.errors import GeometryError, StructureError
from blockmpec.solvers import plan
from blockmpec.three_d import box, make_structure_3d
from blockmpec.three_d import cases as c3
from blockmpec.three_d.meshes import read_mesh, save_obj, save_structure_3d

#: measured agreement of 3D and 2D (extruded suite, static LP): 3e-13 at worst; the LPs' own round-off
LP_TOL = 1e-9


def lam(structure, method="static-lp", **options):
    res = bm.solve(structure, method, **options)
    assert res.success, res
    return res.multiplier


# ---------------------------------------------------------------------------------------------- closed forms


@pytest.mark.parametrize(("mu", "direction", "expected"), [
    (0.65, [1, 0, 0], 0.5),    # overturning about the x toe: b/h = 1/2
    (0.3, [1, 0, 0], 0.3),     # sliding along x: mu
    (0.65, [0, 1, 0], 0.25),   # overturning about the y toe: d/h = 0.5/2
    (0.2, [0, 1, 0], 0.2),     # sliding along y: mu (a vertex of the default pyramid)
    (0.65, [-1, 0, 0], 0.5),   # the other toe
])
def test_single_block_closed_forms(mu, direction, expected):
    s = c3.block_3d(mu=mu, live_direction=direction)
    closed = c3.closed_form("block-3d", "associative", mu=mu, live_direction=direction)
    assert closed is None or closed == pytest.approx(expected, rel=1e-15)
    for method in ("static-lp", "kinematic-lp", "fixed-point"):
        assert lam(s, method) == pytest.approx(expected, abs=LP_TOL)


@pytest.mark.parametrize("slope", [10.0, 20.0])
@pytest.mark.parametrize("mu", [0.65, 0.3])
def test_block_on_an_inclined_base(slope, mu):
    expected = math.tan(math.radians(slope) + min(math.atan(mu), math.atan(0.5)))
    assert c3.closed_form("block-3d", "associative", slope=slope, mu=mu) == pytest.approx(expected, rel=1e-15)
    # the registry's closed form (what blockmpec.testing's reference cases read) is the 3D one
    assert bm.cases.closed_form("block-3d", "non-associative", slope=slope, mu=mu) == \
        c3.closed_form("block-3d", "associative", slope=slope, mu=mu)
    s = c3.block_3d(slope=slope, mu=mu)
    assert lam(s) == pytest.approx(expected, abs=LP_TOL)  # measured 1.0e-13
    assert lam(s, "fixed-point") == pytest.approx(expected, abs=LP_TOL)


def test_milp_certifies_the_single_block():
    res = bm.solve(c3.block_3d(), "milp")
    assert res.success and res.status is bm.Status.OPTIMAL
    assert res.multiplier == pytest.approx(0.5, abs=1e-8)


# ---------------------------------------------------------------------------------------------- extruded 2D suite

EXTRUDED = ["two-blocks", "single-block", "round-arch", "arch-on-buttresses", "wall", "ferris-tinloi"]


@pytest.mark.parametrize("case", EXTRUDED)
def test_extruded_associative_equals_2d(case):
    two = bm.build_case(case)
    three = c3.extrude(two, thickness=0.7)
    assert lam(three) == pytest.approx(lam(two), abs=1e-8)


@pytest.mark.parametrize("case", ["two-blocks", "round-arch", "arch-on-buttresses", "wall"])
def test_extruded_fixed_point_reaches_the_2d_value(case):
    two = bm.build_case(case)
    three = c3.extrude(two, thickness=1.0)  # (at 0.7 the wall's fixed point stops at another solution, 0.60011)
    # measured |3D - 2D|: below 5e-11 (the fixed point stops at ||n - n*|| <= 1e-9 ||n||)
    assert lam(three, "fixed-point") == pytest.approx(lam(two, "fixed-point"), abs=1e-8)


def test_the_interior_run_and_the_relaxed_steps_are_stages_of_the_3d_fixed_points_plan():
    # three LP steps do not converge on the corner wall (23 do), nor do three interior-point iterations (15 do), so
    # the relaxed "closest" sequence follows; the run's plan records the three stages in that order, and the engine
    # fact the chain that ran; a 2D run never plans the relaxed steps
    res = bm.solve(c3.corner_wall(), "fixed-point", max_iterations=3)
    assert res.status is bm.Status.ITERATION_LIMIT, res.status
    assert res.extra["plan"][1:] == ["interior fixed point on (3): block IPM",
                                     f"fixed point: HiGHS LP steps relaxed by {plan.FIXED_POINT_3D_RELAXATION} "
                                     "(tie-break closest)"], res.extra["plan"]
    assert res.extra["engine"] == "simplex, then interior, then relaxed simplex"
    solver = bm.get_solver("fixed-point")()
    solver.setup(bm.assemble(bm.cases.two_blocks()))
    assert "relaxed" not in solver.plan


# ---------------------------------------------------------------------------------------------- the interior engine
#: the interior engine stops at residuals of (3) <= 1e-9: measured |lam - closed form| 8e-15 (block), |3D - 2D| 1.3e-12
#: (round arch) and 2.8e-13 (arch on buttresses)
INTERIOR_TOL = 1e-8


@pytest.mark.parametrize(("params", "expected"), [
    ({"mu": 0.65}, 0.5), ({"mu": 0.3}, 0.3), ({"mu": 0.65, "live_direction": [0, 1, 0]}, 0.25),
    ({"mu": 0.2, "live_direction": [0, 1, 0]}, 0.2),
    ({"mu": 0.3, "slope": 10.0}, math.tan(math.radians(10) + math.atan(0.3))),
])
def test_3d_interior_fixed_point_meets_the_closed_forms(params, expected):
    res = bm.solve(c3.block_3d(**params), "fixed-point", engine="interior")
    assert res.success and res.extra["engine"] == "interior", res
    assert res.multiplier == pytest.approx(expected, abs=INTERIOR_TOL)


@pytest.mark.parametrize("case", ["round-arch", "arch-on-buttresses"])
def test_3d_interior_fixed_point_equals_the_2d_one(case):
    # on these arches (3) has one multiplier; the 2D engine works on interfaces (t, n, m), the 3D one on contact points
    # with a friction pyramid: an independent assembly and layout of the same structure
    two = bm.build_case(case)
    assert lam(c3.extrude(two), "fixed-point", engine="interior") == \
        pytest.approx(lam(two, "fixed-point", engine="interior"), abs=INTERIOR_TOL)


def test_3d_interior_cohesion_is_set_on_every_pyramid_side():
    from blockmpec.formulations import step_lps
    from blockmpec.solvers.engines.interior_fixed_point import InteriorFixedPoint
    from blockmpec.solvers.engines.scaling import LoadUnits

    ops = bm.assemble(c3.dome(mu=0.7, dilatancy=0.2, pyramid_sides=6))
    lps = step_lps(ops, tie_break=False, associative=True)
    with pytest.raises(ValueError, match="not planar"):
        InteriorFixedPoint(lps.step, lps.associative, LoadUnits.of(ops))
    engine = InteriorFixedPoint(lps.step, lps.associative, LoadUnits.of(ops), coupling="fixed", layout=lps)
    n_star = -np.random.default_rng(0).uniform(0.5, 2.0, ops.n_contacts)
    engine.set_n_star(n_star)
    rows = engine.friction_position
    expected = -(0.7 - 0.2) * n_star[ops.friction_contact]
    assert np.allclose(engine.h[rows] / engine.in_scale[rows], expected, rtol=1e-14, atol=0.0)
    assert ops.friction_contact.size == 6 * ops.n_contacts


def test_the_3d_fixed_point_runs_the_interior_engine_from_500_free_blocks():
    # the same rule as in 2D; the plan of a structure below it keeps the LP steps first
    many = bm.assemble(c3.barrel_vault(rings=72))
    few = bm.assemble(c3.barrel_vault())
    assert few.n_free_blocks < plan.FIXED_POINT_INTERIOR_BLOCKS <= many.n_free_blocks
    for ops, first in ((many, "interior"), (few, "simplex")):
        solver = bm.get_solver("fixed-point")()
        solver.setup(ops)
        assert solver.plan.stages[0].key == first


def test_extruded_non_convex_stones():
    two = bm.cases.stone_wall(width=1.6, height=1.0, stone_size=0.35, irregularity=0.6, seed=3)
    three = c3.extrude(two, thickness=0.4)
    assert lam(three) == pytest.approx(lam(two), abs=1e-8)


# ---------------------------------------------------------------------------------------------- invariance


def _moved(s, rotate_deg=0.0, shift=(0.0, 0.0, 0.0), order=None, scale=1.0):
    a = math.radians(rotate_deg)
    R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    order = np.arange(s.n_blocks) if order is None else np.asarray(order)
    blocks = []
    for i in order:
        v = (s.vertices[i] @ R.T) * scale + np.asarray(shift)
        perm = np.roll(np.arange(len(v)), 3)  # the block's vertex list reordered, its faces remapped
        inv = np.argsort(perm)
        blocks.append((v[perm], [inv[f].tolist() for f in s.faces[i]]))
    return make_structure_3d(blocks, s.fixed[order], friction=s.friction, dilatancy=s.dilatancy,
                             live_direction=R @ s.live_direction, pyramid_sides=s.pyramid_sides)


def test_invariance_to_translation_rotation_order_and_units():
    """The canonical frame and snapping give the same operators, bit for bit, so even the fixed point (whose
    solution of (3) is not unique) returns the same multiplier; a far offset only to round-off (the LP's ``lam``)."""
    s = c3.corner_wall(courses=3, blocks_per_course=2)
    ops = bm.assemble(s)
    base_static, base_fp = lam(s), lam(s, "fixed-point")
    rng = np.random.default_rng(1)
    same_bits = [_moved(s, shift=(3.3, -2.7, 0.1)), _moved(s, rotate_deg=33.0), _moved(s, rotate_deg=-71.0),
                 _moved(s, order=rng.permutation(s.n_blocks)), _moved(s, scale=1e-3), _moved(s, scale=0.25,
                                                                                           rotate_deg=90.0)]
    for v in same_bits:
        o = bm.assemble(v)
        assert (o.E != ops.E).nnz == 0 and np.array_equal(o.f_d, ops.f_d) and np.array_equal(o.f_l, ops.f_l)
        assert lam(v, "fixed-point") == base_fp
    far = _moved(s, shift=(1e3, -2e2, 7.0), rotate_deg=12.0)
    assert lam(far) == pytest.approx(base_static, rel=1e-12)  # measured 5e-14


def test_mechanism_turns_with_the_structure():
    s = c3.block_3d()
    r0 = bm.solve(s, "static-lp").mechanism
    r1 = bm.solve(_moved(s, rotate_deg=90.0), "static-lp").mechanism
    u0 = r0[["u_x", "u_y", "u_z"]].to_numpy()[0]
    u1 = r1[["u_x", "u_y", "u_z"]].to_numpy()[0]
    np.testing.assert_allclose(u1, [-u0[1], u0[0], u0[2]], atol=1e-9)


# ---------------------------------------------------------------------------------------------- bad meshes


def _two_boxes(upper=((0, 0, 0), (1, 1, 1))):
    return [box((-1, -1, -1), (2, 2, 0)), box(*upper)]


def test_open_mesh_is_one_clear_line():
    base, blk = _two_boxes()
    v, f = blk
    with pytest.raises(GeometryError, match=r"^block 1: its surface is not closed") as err:
        make_structure_3d([base, (v, f[:-1])], [True, False], friction=0.6)
    assert "\n" not in str(err.value)


def test_inward_faces_and_inconsistent_orientation():
    base, (v, f) = _two_boxes()
    with pytest.raises(GeometryError, match="oriented inward"):
        make_structure_3d([base, (v, [face[::-1] for face in f])], [True, False], friction=0.6)
    with pytest.raises(GeometryError, match="not consistently oriented"):
        make_structure_3d([base, (v, [f[0][::-1]] + f[1:])], [True, False], friction=0.6)


def test_self_intersecting_block():
    # a bow-tie prism: its top and bottom faces cross themselves
    bottom = np.array([[0, 0, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]], float)
    top = bottom + [0, 0, 1]
    v = np.vstack([bottom, top])
    faces = [[3, 2, 1, 0], [4, 5, 6, 7]] + [[j, (j + 1) % 4, 4 + (j + 1) % 4, 4 + j] for j in range(4)]
    with pytest.raises(GeometryError, match="block 1") as err:
        make_structure_3d([box((-1, -1, -1), (2, 2, 0)), (v, faces)], [True, False], friction=0.6)
    assert "\n" not in str(err.value)


def test_overlapping_blocks():
    with pytest.raises(GeometryError, match=r"blocks 1 and 2 overlap \(penetration"):
        make_structure_3d([box((-1, -1, -1), (3, 2, 0)), box((0, 0, 0), (1, 1, 1)), box((0.5, 0, 0), (1.5, 1, 1))],
                          [True, False, False], friction=0.6)


def test_block_touching_nothing():
    with pytest.raises(StructureError, match="^block 2 touches no other block"):
        make_structure_3d([box((-1, -1, -1), (3, 2, 0)), box((0, 0, 0), (1, 1, 1)), box((2, 0, 0.5), (3, 1, 1.5))],
                          [True, False, False], friction=0.6)


def test_bad_mesh_file_on_the_command_line(tmp_path, capsys):
    from blockmpec.cli import main

    s = c3.block_3d()
    path = tmp_path / "open.obj"
    save_obj(s, path)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n")  # the block loses a face
    assert main(["solve", str(path), "--method", "static-lp"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("blockmpec: error: block block: its surface is not closed") and "\n" not in err


# ---------------------------------------------------------------------------------------------- files


def test_obj_round_trip_with_fixed_names(tmp_path):
    s = c3.barrel_vault(voussoirs=5, rings=2)
    path = tmp_path / "vault.obj"
    save_obj(s, path)
    text = path.read_text().replace("o springer-left", "o fixed").replace("o springer-right", "o fixed.001")
    path.write_text(text)
    t = read_mesh(path)
    assert t.fixed.sum() == 2 and t.block_ids[0] == "fixed"
    assert lam(t) == pytest.approx(lam(s), rel=1e-9)


def test_stl_split_into_components(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    s = c3.block_3d()
    meshes = [trimesh.Trimesh(v, [(f[0], f[j], f[j + 1]) for f in fs for j in range(1, len(f) - 1)])
              for v, fs in zip(s.vertices, s.faces)]
    path = tmp_path / "block.stl"
    trimesh.util.concatenate(meshes).export(path)
    t = read_mesh(path, live_direction=[0, 1, 0])
    assert t.n_blocks == 2 and t.fixed.tolist() == [True, False]  # the lowest block is the support
    assert lam(t) == pytest.approx(0.25, abs=LP_TOL)


def test_json_file_and_cli(tmp_path, capsys):
    from blockmpec.cli import main

    path = tmp_path / "block.json"
    save_structure_3d(c3.block_3d(), path)
    assert json.loads(path.read_text())["format"] == "blockmpec-3d"
    code = main(["solve", str(path), "--method", "static-lp", "-p", "live_direction=[0,1,0]", "--json",
                 "--forces", str(tmp_path / "f.csv"), "--mechanism", str(tmp_path / "m.csv")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["multiplier"] == pytest.approx(0.25, abs=LP_TOL)
    assert main(["solve", "block-3d", "--method", "static-lp", "--export-drawing", str(tmp_path / "x.svg")]) == 2


# ---------------------------------------------------------------------------------------------- results


def test_forces_and_resultants_balance_the_block():
    from blockmpec.three_d.report import resultants

    s = c3.block_3d(mu=0.3)  # slides at lam = mu: the base carries W down and 0.3 W along x
    res = bm.solve(s, "static-lp")
    forces, total = res.forces, resultants(res)
    assert len(forces) == 4 and (forces["normal"] <= 1e-12).all()
    w = s.weight[1]
    row = total.iloc[0]
    # the force of the block (plus) on the base (minus): its weight down, the live load along x
    np.testing.assert_allclose([row.force_x, row.force_y, row.force_z], [0.3 * w, 0, -w], atol=1e-9)
    assert row.normal == pytest.approx(-w) and row.shear == pytest.approx(0.3 * w)
    np.testing.assert_allclose(forces[["force_x", "force_y", "force_z"]].sum().to_numpy(), [0.3 * w, 0, -w], atol=1e-9)
    mech = res.mechanism
    assert list(mech.columns) == ["block", "block_id", "u_x", "u_y", "u_z", "rotation_x", "rotation_y", "rotation_z"]
    assert mech.u_x.iat[0] * w == pytest.approx(1.0)  # live-load power f_l^T u = 1 (f_l = W along x)


def test_verifier_rejects_a_perturbed_3d_answer():
    s = c3.corner_wall(courses=2, blocks_per_course=2)
    res = bm.solve(s, "static-lp")
    ops = bm.assemble(s)
    bad = bm.Solution(multiplier=res.multiplier, x=res.solution.x * 1.01, u=res.solution.u,
                      z_u=res.solution.z_u, z_f=res.solution.z_f)
    assert bm.residuals(ops, bad, associative=True)["equilibrium"] > 1e-3
    assert max(bm.residuals(ops, res.solution, associative=True).values()) < 1e-9


def test_plot_and_mesh_export(tmp_path):
    from matplotlib.figure import Figure

    from blockmpec.three_d.plot import export_mechanism, structure_3d

    s = c3.block_3d()
    res = bm.solve(s, "static-lp")
    ax = bm.plot.mechanism(res, s, ax=Figure().add_subplot(projection="3d"))
    assert ax.name == "3d"
    structure_3d(s, ax=Figure().add_subplot(projection="3d"))
    with pytest.raises(TypeError, match="3D axes"):
        bm.plot.mechanism(res, s, ax=Figure().add_subplot())
    export_mechanism(res, s, tmp_path / "m.obj")
    text = (tmp_path / "m.obj").read_text()
    assert text.count("\no ") == 2 and text.count("\nv ") == 16
    v = np.array([line.split()[1:] for line in text.splitlines() if line.startswith("v ")], float)
    np.testing.assert_array_equal(v[:8], s.vertices[0])  # the base stays
    assert not np.allclose(v[8:], s.vertices[1])  # the block moves


# ---------------------------------------------------------------------------------------------- the exact cone


def test_exact_cone_brackets_and_sliding():
    pytest.importorskip("clarabel")
    from blockmpec.three_d.cone import exact_cone

    sliding = exact_cone(c3.block_3d(mu=0.3))
    assert sliding.multiplier == pytest.approx(0.3, abs=1e-8)  # along a vertex of the pyramid: exact
    r = exact_cone(c3.corner_wall(courses=2, blocks_per_course=2))
    assert r.status == "Solved" and r.equilibrium < 1e-8 and r.cone_admissibility < 1e-8
    assert r.inscribed <= r.multiplier + 1e-9 <= r.circumscribed + 2e-9
    assert r.relative_error >= 0


@pytest.mark.parametrize("name", list(c3.CASES_3D))
def test_3d_cases_round_trip_through_a_structure_file(tmp_path, name):
    s = bm.build_case(name)
    bm.save_structure(s, tmp_path / "s.json")
    t = bm.load_structure(tmp_path / "s.json")
    assert t.block_ids == s.block_ids and all(np.array_equal(a, b) for a, b in zip(s.vertices, t.vertices))
    assert len(t.contacts) == len(s.contacts)
    if name in ("block-3d", "arch-3d", "corner-wall"):
        assert lam(t) == lam(s)
