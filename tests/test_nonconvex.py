"""Non-convex blocks: exact areas and centroids, interfaces, closed-form rocking, snapping (issue 42)."""

import json

import numpy as np
import pytest

import blockmpec as bm

BASE = [[-1.0, -0.5], [4.0, -0.5], [4.0, 0.0], [-1.0, 0.0]]
#: an L: a 2 x 0.5 foot with a 0.5 x 1.5 upright at its left end; its toe is (2, 0)
L_BLOCK = [[0.0, 0.0], [2.0, 0.0], [2.0, 0.5], [0.5, 0.5], [0.5, 2.0], [0.0, 2.0]]


def rectangles_area_centroid(rects):
    """Area and centroid of a union of disjoint rectangles (x0, y0, x1, y1), by hand."""
    areas = np.array([(x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in rects])
    centres = np.array([[(x0 + x1) / 2, (y0 + y1) / 2] for x0, y0, x1, y1 in rects])
    return areas.sum(), (areas[:, None] * centres).sum(axis=0) / areas.sum()


@pytest.mark.parametrize(
    ("poly", "rects"),
    [
        (L_BLOCK, [(0, 0, 2, 0.5), (0, 0.5, 0.5, 2)]),
        ([[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]], [(0, 0, 3, 1), (0, 1, 1, 2), (2, 1, 3, 2)]),
        ([[0, 0], [1, 0], [1, 1], [3, 1], [3, 2], [0, 2]], [(0, 0, 1, 1), (0, 1, 3, 2)]),
    ],
    ids=["L", "U", "step"],
)
def test_area_and_centroid_of_non_convex_blocks_are_exact_from_any_starting_vertex(poly, rects):
    area, centroid = rectangles_area_centroid(rects)
    for shift in range(len(poly)):
        rolled = np.roll(np.array(poly, float), shift, axis=0)
        s = bm.make_structure([BASE, rolled], [True, False], friction=0.6)
        np.testing.assert_allclose(s.area[1], area, rtol=1e-14)
        np.testing.assert_allclose(s.centroid[1], centroid, rtol=1e-14)


def test_l_block_rocks_about_its_toe_at_the_closed_form_multiplier():
    """Rocking about the toe (2, 0): lam = (x_toe - x_c) / y_c, the moment of the weight about the toe over
    that of the live load; with mu = 5 nothing slides.  By hand: x_c = y_c = 19/28, so lam = 37/19."""
    area, (xc, yc) = rectangles_area_centroid([(0, 0, 2, 0.5), (0, 0.5, 0.5, 2)])
    closed = (2.0 - xc) / yc
    assert closed == pytest.approx(37 / 19, rel=1e-15)
    s = bm.make_structure([BASE, L_BLOCK], [True, False], friction=5.0)
    assert len(s.interfaces) == 1
    for method in ("static-lp", "kinematic-lp", "fixed-point"):
        res = bm.solve(s, method)
        assert res.success, (method, res.status, res.message)
        assert res.multiplier == pytest.approx(closed, rel=1e-9), method


def test_l_block_rocking_the_other_way_turns_about_its_heel():
    """Live load towards -x: the L rocks about (0, 0): lam = x_c / y_c = 1."""
    s = bm.make_structure([BASE, L_BLOCK], [True, False], friction=5.0, live_direction=-1)
    res = bm.solve(s, "static-lp")
    assert res.success and res.multiplier == pytest.approx(1.0, rel=1e-9)


def test_block_in_the_notch_of_a_u_round_trips_through_a_file_with_its_interfaces(tmp_path):
    """A U-shaped stone whose centroid is not between it and the block in its notch: the interface
    orientation is checked on the edges, and the explicit interfaces of the saved file validate."""
    u = [[0, 0], [3, 0], [3, 2], [2, 2], [2, 0.5], [1, 0.5], [1, 2], [0, 2]]
    plug = [[1, 0.5], [2, 0.5], [2, 1.5], [1, 1.5]]
    s = bm.make_structure([BASE, u, plug], [True, False, False], friction=0.6)
    pairs = sorted(zip(s.interfaces.minus.tolist(), s.interfaces.plus.tolist()))
    assert pairs == [(0, 1), (1, 2), (1, 2), (1, 2)]  # the base; the notch's floor and both of its sides
    np.testing.assert_allclose(sorted(s.interfaces.length), [1.0, 1.0, 1.0, 3.0])
    path = tmp_path / "u.json"
    bm.save_structure(s, path)
    back = bm.load_structure(path)
    assert np.array_equal(back.interfaces.start, s.interfaces.start)
    lam = bm.solve(s, "static-lp").multiplier
    assert bm.solve(back, "static-lp").multiplier == lam


def test_reversed_interface_on_a_non_convex_block_is_named():
    u = [[0, 0], [3, 0], [3, 2], [2, 2], [2, 0.5], [1, 0.5], [1, 2], [0, 2]]
    plug = [[1, 0.5], [2, 0.5], [2, 1.5], [1, 1.5]]
    good = bm.make_structure([BASE, u, plug], [True, False, False], friction=0.6).interfaces
    k = int(np.flatnonzero((good.minus == 1) & (good.plus == 2))[0])
    start, end = good.start.copy(), good.end.copy()
    start[k], end[k] = good.end[k], good.start[k]
    bad = bm.Interfaces(good.minus, good.plus, start, end, good.friction, good.dilatancy)
    with pytest.raises(bm.GeometryError, match=rf"interface {k}: its normal .* points from block 2 into block 1"):
        bm.make_structure([BASE, u, plug], [True, False, False], friction=0.6, interfaces=bad)


def test_block_overlapping_the_notch_of_a_non_convex_block_is_an_error():
    inside = [[0.2, 0.6], [1.8, 0.6], [1.8, 1.0], [0.2, 1.0]]  # in the L's convex hull, partly in its upright
    with pytest.raises(bm.GeometryError, match=r"blocks 1 and 2 overlap \(penetration 0\.1"):
        bm.make_structure([BASE, L_BLOCK, inside], [True, False, False], friction=0.6)


def test_point_load_in_the_notch_of_an_l_is_outside_it():
    with pytest.raises(bm.StructureError, match=r"point load 0: its point \[1\.5, 1\.5\] lies outside block 1"):
        bm.make_structure([BASE, L_BLOCK], [True, False], friction=0.6,
                          point_loads=[bm.PointLoad(1, (1.5, 1.5), (0.0, -1.0))])
    s = bm.make_structure([BASE, L_BLOCK], [True, False], friction=0.6,
                          point_loads=[bm.PointLoad(1, (0.25, 1.5), (0.0, -1.0))])
    assert len(s.point_loads) == 1


# ------------------------------------------------------------------------------------------- snapping

#: two blocks on a base whose edges miss each other by up to 1e-3 (a drawing's gaps)
GAPPY = [
    BASE,
    [[0.0, 0.0008], [1.0, 0.0], [1.0005, 3.0], [0.0, 3.0]],
    [[1.0, 0.0002], [2.0, 0.0], [2.0, 3.0], [1.0, 3.0]],
]


def test_without_snapping_a_drawing_s_gaps_and_overlaps_are_errors():
    with pytest.raises(bm.GeometryError, match=r"blocks 1 and 2 overlap \(penetration 0\.0005\)"):
        bm.make_structure(GAPPY, [True, False, False], friction=0.65)
    with pytest.raises(bm.StructureError, match=r"block 1 touches no other block"):
        bm.make_structure(GAPPY, [True, False, False], friction=0.65, check_overlap=False)


def test_snapping_makes_near_edges_interfaces_and_records_every_move(tmp_path):
    s = bm.make_structure(GAPPY, [True, False, False], friction=0.65, snap=1e-3)
    record = s.metadata["snapping"]
    assert record["snap"] == 1e-3 and record["distance"] == pytest.approx(1e-3 * np.median([5.02494, 3.16228,
                                                                                           3.16228]), rel=1e-4)
    pairs = sorted(zip(s.interfaces.minus.tolist(), s.interfaces.plus.tolist()))
    assert pairs == [(0, 1), (0, 2), (1, 2)]
    moved = {(b, tuple(before), tuple(after)) for b, *xy in record["vertices"] for before, after in [(xy[:2], xy[2:])]}
    assert (0, (0.0, 0.0), (0.0, 0.0008)) in moved  # the base's corner pulled up to block 1's
    assert (2, (1.0, 0.0002), (1.0, 0.0)) in moved  # block 2's corner onto block 1's
    assert (2, (1.0, 3.0), (1.0005, 3.0)) in moved
    assert all(np.hypot(b[0] - a[0], b[1] - a[1]) <= record["distance"] for _, b, a in moved)
    assert record["largest"] == pytest.approx(8e-4)
    # unmoved vertices keep their bits
    assert [2.0, 3.0] in s.polygon(2).tolist() and [0.0, 3.0] in s.polygon(1).tolist()
    # the record is saved and read back with the structure
    bm.save_structure(s, tmp_path / "s.json")
    assert json.loads((tmp_path / "s.json").read_text())["metadata"]["snapping"] == record
    assert bm.load_structure(tmp_path / "s.json").metadata["snapping"] == record
    # within 1e-3 of the two-block closed form (the geometry moved by 1e-3)
    lam = bm.solve(s, "static-lp").multiplier
    assert lam == pytest.approx(bm.cases.closed_form("two-blocks", "associative", eta=3, mu=0.65), rel=2e-3)


def test_snapping_leaves_matching_structures_unchanged():
    wall = bm.cases.wall(3, 2)
    polys = [wall.polygon(i) for i in range(wall.n_blocks)]
    s = bm.make_structure(polys, wall.fixed, friction=0.65, snap=1e-3)
    assert s.metadata["snapping"]["vertices"] == []
    assert all(np.array_equal(s.polygon(i), wall.polygon(i)) for i in range(wall.n_blocks))
    assert np.array_equal(s.interfaces.start, wall.interfaces.start)


def test_overlap_beyond_the_snapping_distance_is_an_error():
    polys = [BASE, [[0, 0], [1.01, 0], [1.01, 3], [0, 3]], [[1, 0], [2, 0], [2, 3], [1, 3]]]
    with pytest.raises(bm.GeometryError, match=r"blocks 1 and 2 overlap \(penetration 0\.00\d+, more than the "
                                               r"snapping distance 0\.00\d+\)"):
        bm.make_structure(polys, [True, False, False], friction=0.65, snap=1e-3)


@pytest.mark.parametrize("snap", [-1e-3, float("nan"), "0.1"])
def test_bad_snapping_distance_is_named(snap):
    with pytest.raises(bm.GeometryError, match=r"snap: must be a finite number >= 0"):
        bm.make_structure(GAPPY, [True, False, False], friction=0.65, snap=snap)
