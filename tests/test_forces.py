"""Results in the user's terms: ``res.forces`` and ``res.mechanism`` (blockmpec.report), and the CLI's
``--forces`` / ``--mechanism``.

Every check is made in the structure file's frame and units, from the polygons as written here
(areas and centroids by the shoelace formula in this file, not by the library), so that a wrong
sign (mirror, flipped interface), order or unit in the conversion breaks an equilibrium.
"""

import pickle

import numpy as np
import pandas as pd
import pytest

import blockmpec as bm
from blockmpec import cli

METHODS = ["kinematic-lp", "static-lp", "fixed-point", "milp"]
ASSOCIATIVE = {"kinematic-lp", "static-lp"}
FORCE_COLUMNS = ["interface", "minus", "plus", "start_x", "start_y", "end_x", "end_y", "shear", "normal", "moment"]
MECHANISM_COLUMNS = ["block", "u_x", "u_y", "rotation"]


def shoelace(poly):
    """Area and centroid of a counter-clockwise polygon, from its first vertex (no library function)."""
    p = np.asarray(poly, float)
    q = p - p[0]
    x, y = q[:, 0], q[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = cross.sum() / 2
    centroid = np.array([((x + x1) * cross).sum(), ((y + y1) * cross).sum()]) / (6 * area)
    return area, p[0] + centroid


def cross2(r, f):
    return r[0] * f[1] - r[1] * f[0]


# ---------------------------------------------------------------- a structure in non-trivial units

OFFSET = np.array([1234.5, -678.25])
A = 0.37  # the length unit of the drawing


def _rect(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def stack(direction):
    """Three free blocks (one a quadrilateral with a slanted top) on a base of two fixed blocks, all offset,
    of non-unit size and density, with a dead and a live point load.  The base is listed last (two fixed
    blocks side by side: an interface that carries no unknown) and the top block before the right one, so
    that some detected interfaces (minus = lower index) are flipped in the canonical order (fixed blocks,
    then upwards) and some are not."""
    polys = [
        _rect(-0.75 * A, 0.0, 0.0, 1.6 * A),  # course 1, left
        [[-0.75 * A, 1.6 * A], [0.75 * A, 1.6 * A], [0.5 * A, 2.3 * A], [-0.5 * A, 2.1 * A]],  # top
        _rect(0.0, 0.0, 0.75 * A, 1.6 * A),  # course 1, right
        _rect(-3 * A, -A, 0.0, 0.0),  # base, left (fixed)
        _rect(0.0, -A, 3 * A, 0.0),  # base, right (fixed)
    ]
    polys = [(np.asarray(p) + OFFSET).tolist() for p in polys]
    density = [23.5, 31.0, 17.0, 5.0, 5.0]
    loads = [
        bm.PointLoad(1, tuple(OFFSET + [0.1 * A, 1.8 * A]), (0.4, -2.0), "dead"),
        bm.PointLoad(2, tuple(OFFSET + [0.75 * A, 0.5 * A]), (direction * 1.1, 0.25), "live"),
    ]
    s = bm.make_structure(polys, [False, False, False, True, True], friction=0.7, density=density,
                          live_direction=direction, live_factor=0.8, point_loads=loads, name=f"stack{direction:+d}")
    return s, polys, density


def block_equilibrium(s, polys, density, lam, forces):
    """Largest relative imbalance (force, moment) over the free blocks: loads (dead + lam live, point loads
    included) plus the interface forces of ``forces``, each block's moments about its own centroid."""
    worst_force = worst_moment = 0.0
    for i in np.flatnonzero(~s.fixed):
        area, centroid = shoelace(polys[i])
        weight = density[i] * area
        terms = [(centroid, np.array([lam * s.live_direction * s.live_factor * weight, -weight]), 0.0)]
        for pl in s.point_loads:
            if pl.block == i:
                scale = lam if pl.kind == "live" else 1.0
                terms.append((np.asarray(pl.point, float), scale * np.asarray(pl.force, float), 0.0))
        for row in forces.itertuples():
            if i not in (row.minus, row.plus):
                continue
            start, end = np.array([row.start_x, row.start_y]), np.array([row.end_x, row.end_y])
            tau = (end - start) / np.hypot(*(end - start))
            nu = np.array([-tau[1], tau[0]])
            force, moment = row.shear * tau + row.normal * nu, row.moment
            sign = 1.0 if row.minus == i else -1.0  # the plus block feels the opposite
            terms.append((0.5 * (start + end), sign * force, sign * moment))
        size = np.ptp(np.asarray(polys[i]), axis=0).max()
        total_force = sum(f for _, f, _ in terms)
        total_moment = sum(cross2(p - centroid, f) + m for p, f, m in terms)
        force_scale = sum(np.hypot(*f) for _, f, _ in terms)
        moment_scale = force_scale * size + sum(abs(m) for _, _, m in terms)
        worst_force = max(worst_force, np.hypot(*total_force) / force_scale)
        worst_moment = max(worst_moment, abs(total_moment) / moment_scale)
    return worst_force, worst_moment


@pytest.mark.parametrize("direction", [1, -1])
@pytest.mark.parametrize("method", METHODS)
def test_every_free_block_is_in_equilibrium_in_the_files_units(method, direction):
    s, polys, density = stack(direction)
    ops = bm.assemble(s)
    # what this test covers: a mirrored frame for direction -1, flipped and fixed-fixed interfaces
    assert ops.mirror == direction
    assert ops.interface_flipped.any() and not ops.interface_flipped.all()
    assert ops.n_interfaces < len(s.interfaces)
    res = bm.solve(ops, method)
    assert res.success, res.message
    f = res.forces
    assert list(f.columns) == FORCE_COLUMNS
    assert len(f) == len(s.interfaces) and (f["interface"] == np.arange(len(s.interfaces))).all()
    assert (f["minus"].to_numpy() == s.interfaces.minus).all() and (f["plus"].to_numpy() == s.interfaces.plus).all()
    assert (f[["start_x", "start_y"]].to_numpy() == s.interfaces.start).all()
    assert (f[["end_x", "end_y"]].to_numpy() == s.interfaces.end).all()
    both_fixed = s.fixed[s.interfaces.minus] & s.fixed[s.interfaces.plus]
    assert f.loc[both_fixed, ["shear", "normal", "moment"]].isna().all().all()
    kept = f.loc[~both_fixed]
    assert kept[["shear", "normal", "moment"]].notna().all().all()
    # the signs under test are exercised: shear and moment on flipped interfaces
    flipped = np.zeros(len(s.interfaces), bool)
    flipped[ops.interface_ids[ops.interface_flipped]] = True
    weight = density[1] * shoelace(polys[1])[0]
    assert (kept.loc[flipped[~both_fixed], "moment"].abs() > 1e-3 * weight * A).any()
    assert (kept["shear"].abs() > 1e-3 * weight).any()
    assert (kept["normal"] <= 1e-9 * weight).all()  # compression negative
    worst_force, worst_moment = block_equilibrium(s, polys, density, res.multiplier, f)
    assert worst_force < 1e-9 and worst_moment < 1e-9, (worst_force, worst_moment)

    mech = res.mechanism
    assert list(mech.columns) == MECHANISM_COLUMNS
    assert (mech["rotation"].abs() > 0).any()  # slender blocks: the mechanism rocks (rotation's sign under test)
    assert mech["block"].tolist() == np.flatnonzero(~s.fixed).tolist()
    # f_l^T u = 1 in the file's units: body forces at the centroids, the live point load at its point
    u = {row.block: (np.array([row.u_x, row.u_y]), row.rotation) for row in mech.itertuples()}
    power, scale = 0.0, 0.0
    for i in u:
        area, centroid = shoelace(polys[i])
        term = s.live_direction * s.live_factor * density[i] * area * u[i][0][0]
        power, scale = power + term, scale + abs(term)
    for pl in s.point_loads:
        if pl.kind == "live":
            _, centroid = shoelace(polys[pl.block])
            r = np.asarray(pl.point) - centroid
            v = u[pl.block][0] + u[pl.block][1] * np.array([-r[1], r[0]])
            term = float(np.dot(pl.force, v))
            power, scale = power + term, scale + abs(term)
    assert abs(power - 1.0) <= 1e-9 * scale
    # a mechanism opens or closes nothing into a neighbour: the normal velocity jump at both ends of every
    # interface is >= 0 (plus moving away from minus along nu), computed from the file's geometry
    centroids = {i: shoelace(polys[i])[1] for i in range(s.n_blocks)}
    size = max(abs(v) for v, _ in u.values() for v in v) + max(abs(w) for _, w in u.values()) * 3 * A

    def velocity(block, point):
        if block not in u:
            return np.zeros(2)
        v, w = u[block]
        r = point - centroids[block]
        return v + w * np.array([-r[1], r[0]])

    for row in f.loc[~both_fixed].itertuples():
        start, end = np.array([row.start_x, row.start_y]), np.array([row.end_x, row.end_y])
        tau = (end - start) / np.hypot(*(end - start))
        nu = np.array([-tau[1], tau[0]])
        for p in (start, end):
            jump = velocity(row.plus, p) - velocity(row.minus, p)
            assert jump @ nu >= -1e-9 * size, (row.interface, jump @ nu)


# ---------------------------------------------------------------- one block on a base: closed forms

def block_on_base(width, height, *, friction, density, direction=1, offset=(0.0, 0.0)):
    ox, oy = offset
    base = _rect(ox - 2 * width, oy - 1.0, ox + 2 * width, oy)
    block = _rect(ox - width / 2, oy, ox + width / 2, oy + height)
    s = bm.make_structure([base, block], [True, False], friction=friction, density=density, live_direction=direction)
    return s, block


@pytest.mark.parametrize("method", METHODS)
def test_a_sliding_block_carries_its_weight_and_mu_times_it(method):
    density, width, height, mu = 2.5, 2.0, 1.0, 0.65
    s, block = block_on_base(width, height, friction=mu, density=density, offset=(-40.0, 7.5))
    weight = density * shoelace(block)[0]
    res = bm.solve(s, method)
    assert res.success, res.message
    assert res.multiplier == pytest.approx(mu, rel=1e-9)  # sliding (mu = 0.65) before rocking (b/h = 2)
    (row,) = res.forces.itertuples()
    assert (row.minus, row.plus) == (0, 1)
    assert row.normal == pytest.approx(-weight, rel=1e-9)
    assert abs(row.shear) == pytest.approx(mu * weight, rel=1e-9)
    # the block pushes the base along +x (nu = +y, tau = +x): t = +mu W; the moment of the live load
    # (lam W at height h/2 over the midpoint of the joint) on the base: m = -lam W h / 2
    assert row.shear == pytest.approx(mu * weight, rel=1e-9)
    assert row.moment == pytest.approx(-mu * weight * height / 2, rel=1e-9)
    (mech,) = res.mechanism.itertuples()
    # sliding along +x, with f_l^T u = W u_x = 1; the associative flow rule lifts the block by tan(phi) u_x
    assert mech.block == 1
    assert mech.u_x == pytest.approx(1 / weight, rel=1e-9)
    assert mech.u_y == pytest.approx(mu / weight if method in ASSOCIATIVE else 0.0, rel=1e-9, abs=1e-12 / weight)
    assert abs(mech.rotation) <= 1e-12 / weight


@pytest.mark.parametrize("direction", [1, -1])
@pytest.mark.parametrize("method", METHODS)
def test_a_slender_block_rocks_about_its_toe(method, direction):
    density, width, height = 1.9, 0.3, 1.2
    s, block = block_on_base(width, height, friction=0.8, density=density, direction=direction,
                             offset=(315.0, -12.25))
    area, centroid = shoelace(block)
    weight = density * area
    toe = np.array([centroid[0] + direction * width / 2, -12.25])  # the downstream bottom corner
    res = bm.solve(s, method)
    assert res.success, res.message
    assert res.multiplier == pytest.approx(width / height, rel=1e-9)
    (mech,) = res.mechanism.itertuples()
    # a rotation theta about the toe moves the centroid by theta x (c - toe): u = theta (-(c_y - toe_y), c_x - toe_x)
    assert mech.u_x / mech.rotation == pytest.approx(-(centroid[1] - toe[1]), rel=1e-9)
    assert mech.u_y / mech.rotation == pytest.approx(centroid[0] - toe[0], rel=1e-9)
    assert direction * weight * mech.u_x == pytest.approx(1.0, rel=1e-9)  # f_l^T u = 1 in the file's units
    assert np.sign(mech.rotation) == -direction  # clockwise for a live load along +x
    (row,) = res.forces.itertuples()
    # at rocking the resultant sits at the toe: |m| = -n L / 2 with n = -W, L = width
    assert row.normal == pytest.approx(-weight, rel=1e-9)
    assert abs(row.moment) == pytest.approx(weight * width / 2, rel=1e-9)
    assert row.shear == pytest.approx(direction * width / height * weight, rel=1e-9)


# ---------------------------------------------------------------- the Result's contract

def test_a_result_without_a_solution_has_empty_frames_with_the_columns():
    res = bm.Result(method="static-lp", status=bm.Status.SKIPPED, problem="associative")
    assert list(res.forces.columns) == FORCE_COLUMNS and res.forces.empty
    assert list(res.mechanism.columns) == MECHANISM_COLUMNS and res.mechanism.empty


def test_a_solution_without_a_structure_is_one_clear_error():
    res = bm.Result(method="static-lp", status=bm.Status.OPTIMAL, problem="associative",
                    solution=bm.Solution(multiplier=1.0, x=np.zeros(3), u=np.zeros(3)))
    with pytest.raises(bm.StructureError, match="not assembled from a Structure"):
        res.forces


def test_frames_survive_pickling_and_solution_stays_internal():
    s, _, _ = stack(-1)
    res = bm.solve(s, "static-lp")
    back = pickle.loads(pickle.dumps(res))
    pd.testing.assert_frame_equal(back.forces, res.forces)
    pd.testing.assert_frame_equal(back.mechanism, res.mechanism)
    ops = bm.assemble(s)
    assert res.solution.x.shape == (3 * ops.n_interfaces,)  # canonical arrays, unchanged
    pd.testing.assert_frame_equal(bm.forces_frame(ops, res.solution), res.forces)
    pd.testing.assert_frame_equal(bm.mechanism_frame(ops, res.solution), res.mechanism)


# ---------------------------------------------------------------- the CLI

def test_cli_writes_the_frames(tmp_path, capsys):
    s, _, _ = stack(-1)
    path = tmp_path / "stack.json"
    bm.save_structure(s, path)
    forces, mechanism = tmp_path / "forces.csv", tmp_path / "mechanism.csv"
    code = cli.main(["solve", str(path), "-m", "static-lp", "--forces", str(forces), "--mechanism", str(mechanism)])
    assert code == 0, capsys.readouterr().err
    assert f"wrote {forces} ({len(s.interfaces)} interfaces)" in capsys.readouterr().out
    res = bm.solve(bm.load_structure(path), "static-lp")
    pd.testing.assert_frame_equal(pd.read_csv(forces), res.forces, check_exact=True)
    pd.testing.assert_frame_equal(pd.read_csv(mechanism), res.mechanism, check_exact=True)


@pytest.mark.parametrize(("flag", "value", "message"), [
    ("--forces", "{tmp}/missing/forces.csv", "--forces {tmp}/missing/forces.csv: folder {tmp}/missing does not exist"),
    ("--mechanism", "{tmp}", "--mechanism {tmp}: is a folder; give a file name such as {tmp}/mechanism.csv"),
])
def test_cli_a_bad_output_path_is_one_line_before_the_solve(tmp_path, capsys, monkeypatch, flag, value, message):
    def no_solve(*args, **kwargs):
        raise AssertionError("solved before checking the output path")

    monkeypatch.setattr(cli, "solve", no_solve)
    code = cli.main(["solve", "two-blocks", "-m", "static-lp", flag, value.format(tmp=tmp_path)])
    err = capsys.readouterr().err
    assert code == 2
    assert err == f"blockmpec: error: {message.format(tmp=tmp_path)}\n"


def test_the_docs_example_prints_what_the_page_shows(capsys):
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "results.md").read_text()
    code = re.search(r"```python\n(.+?)\n```", page, re.S).group(1)
    shown = re.search(r"```text\n(.+?)\n```", page, re.S).group(1)
    exec(compile(code, "docs/results.md", "exec"), {})
    assert capsys.readouterr().out.strip() == shown.strip()
