"""Every class of bad input gets a clear error naming the block, interface or field."""

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import blockmpec as bm

BASE = [[-1, -1], [3, -1], [3, 0], [-1, 0]]
SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]


def make(polys, fixed, **kw):
    kw.setdefault("friction", 0.5)
    return bm.make_structure(polys, fixed, **kw)


def test_non_convex_polygon_is_a_block_but_a_self_intersecting_one_is_not():
    arrow = [[0, 0], [2, 0], [1, 0.5], [2, 1], [0, 1]]
    s = make([BASE, arrow], [True, False])
    np.testing.assert_allclose(s.area[1], 1.5)  # 2 x 1 less the notch of 0.5
    crossing = [[0, 0], [1, 0], [1, 3], [0, 3], [0.5, 3.5], [0.5, 2.5]]
    with pytest.raises(bm.GeometryError, match=r"block 1: polygon is self-intersecting .* at \[0\.5, 3\.0\]"):
        make([BASE, crossing], [True, False])
    star = [[0, 0], [2, 0.5], [0.2, 1.3], [1.0, -0.5], [1.8, 1.3]]  # turns left everywhere, twice round
    with pytest.raises(bm.GeometryError, match=r"block 1: polygon is self-intersecting"):
        make([BASE, star], [True, False])


def test_clockwise_polygon():
    with pytest.raises(bm.GeometryError, match=r"block 1: vertices are in clockwise order"):
        make([BASE, SQUARE[::-1]], [True, False])


@pytest.mark.parametrize(
    ("poly", "pattern"),
    [
        ([[0, 0], [1, 0], [2, 0]], r"block 1: polygon is degenerate"),
        ([[0, 0], [1, 0]], r"block 1: vertices must have shape \(k, 2\) with k >= 3"),
        ([[0, 0], [1, 0], [1, 1], [1, 1], [0, 1]], r"block 1: two consecutive vertices coincide"),
        ([[0, 0], [1, 0], [1, float("nan")], [0, 1]], r"block 1: vertices contain NaN"),
    ],
)
def test_degenerate_polygons(poly, pattern):
    with pytest.raises(bm.GeometryError, match=pattern):
        make([BASE, poly], [True, False])


def test_overlapping_blocks():
    other = [[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]]
    with pytest.raises(bm.GeometryError, match=r"blocks 1 and 2 overlap"):
        make([BASE, SQUARE, other], [True, False, False])


def test_no_fixed_block():
    with pytest.raises(bm.StructureError, match=r"no block is fixed"):
        make([BASE, SQUARE], [False, False])


def test_free_block_touching_nothing():
    far = [[10, 10], [11, 10], [11, 11], [10, 11]]
    with pytest.raises(bm.StructureError, match=r"block 2 touches no other block"):
        make([BASE, SQUARE, far], [True, False, False])


def test_floating_group_of_blocks():
    a = [[10, 10], [11, 10], [11, 11], [10, 11]]
    b = [[11, 10], [12, 10], [12, 11], [11, 11]]
    with pytest.raises(bm.StructureError, match=r"blocks \[2, 3\] are not connected to any fixed block"):
        make([BASE, SQUARE, a, b], [True, False, False, False])


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"density": -1.0}, r"block 0: density must be a finite number > 0"),
        ({"density": [1.0, float("nan")]}, r"block 1: density must be a finite number > 0"),
        ({"friction": -0.1}, r"friction: must be a finite number >= 0"),
        ({"friction": 0.3, "dilatancy": 0.5}, r"dilatancy: tan\(psi\) = 0.5 exceeds the friction coefficient"),
        ({"live_factor": 0.0}, r"zero live load"),
    ],
)
def test_bad_material_and_loads(kwargs, pattern):
    with pytest.raises(bm.StructureError, match=pattern):
        make([BASE, SQUARE], [True, False], **kwargs)


def test_interface_override_dilatancy_above_friction():
    s = make([BASE, SQUARE], [True, False])
    itf = s.interfaces
    bad = bm.Interfaces(itf.minus, itf.plus, itf.start, itf.end, np.array([0.2]), np.array([0.4]))
    with pytest.raises(bm.StructureError, match=r"interface 0 \(blocks 0-1\): dilatancy tan\(psi\) = 0.4 exceeds"):
        make([BASE, SQUARE], [True, False], interfaces=bad)


@pytest.mark.parametrize(
    ("case", "params", "pattern"),
    [
        ("two-blocks", {"eta": float("nan")}, r"eta: must be a finite number > 0"),
        ("two-blocks", {"eta": -2}, r"eta: must be a finite number > 0"),
        ("single-block", {"width": 0}, r"width: must be a finite number > 0"),
        ("round-arch", {"n_voussoirs": 1}, r"n_voussoirs: must be an integer >= 2"),
        ("round-arch", {"thickness": 3}, r"thickness: must be smaller than twice the radius"),
        ("wall", {"bond": "flemish"}, r"bond: must be 'running' or 'stack'"),
        ("wall", {"courses": 2.5}, r"courses: must be an integer >= 1"),
        ("wall", {"colour": 1}, r"case 'wall' has no parameter 'colour'"),
    ],
)
def test_bad_case_parameters(case, params, pattern):
    with pytest.raises(bm.OptionError, match=pattern):
        bm.build_case(case, **params)


def test_negative_mu_in_case():
    with pytest.raises(bm.StructureError, match=r"friction: must be a finite number >= 0; got -0.2"):
        bm.cases.two_blocks(mu=-0.2)


def _file_dict():
    return bm.structure_to_dict(bm.cases.two_blocks())


@pytest.mark.parametrize(
    ("mutate", "pattern"),
    [
        (lambda d: d.pop("friction"), r"missing required field 'friction'"),
        (lambda d: d.__setitem__("frction", 0.5), r"unknown field 'frction'; did you mean 'friction'\?"),
        (lambda d: d["blocks"][1].__setitem__("fixd", True), r"blocks\[1\]: unknown field 'fixd'; did you mean 'fixed'\?"),
        (lambda d: d["blocks"][2].pop("vertices"), r"blocks\[2\]: missing required field 'vertices'"),
        (lambda d: d["blocks"][1].__setitem__("density", "heavy"), r"blocks\[1\].density: expected a number"),
        (lambda d: d["interfaces"][0].__setitem__("plus", 9), r"interface 0: plus block 9 does not exist"),
        (lambda d: d.__setitem__("format", "other"), r"field 'format' must be 'blockmpec-structure'"),
        (lambda d: d["blocks"][1]["vertices"].__setitem__(0, [0, "a"]), r"blocks\[1\].vertices\[0\]: expected a number"),
    ],
)
def test_bad_structure_file(tmp_path, mutate, pattern):
    d = _file_dict()
    mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(bm.BlockmpecError, match=pattern):
        bm.load_structure(path)


def test_reversed_explicit_interface_is_rejected():
    s = make([BASE, SQUARE], [True, False])
    itf = s.interfaces
    flipped = bm.Interfaces(itf.minus, itf.plus, itf.end, itf.start, itf.friction, itf.dilatancy)
    with pytest.raises(bm.GeometryError, match=r"interface 0: its normal .* points from block 1 into block 0.*swap 'start' and 'end'"):
        make([BASE, SQUARE], [True, False], interfaces=flipped)


def test_explicit_interface_off_the_blocks_is_rejected():
    s = make([BASE, SQUARE], [True, False])
    itf = s.interfaces
    moved = bm.Interfaces(itf.minus, itf.plus, itf.start + [0, 0.3], itf.end + [0, 0.3], itf.friction, itf.dilatancy)
    with pytest.raises(bm.GeometryError, match=r"interface 0: start point .* is not on the boundary of its minus block 0"):
        make([BASE, SQUARE], [True, False], interfaces=moved)


def test_structure_file_not_json(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{ not json")
    with pytest.raises(bm.StructureFileError, match=r"not valid JSON \(line 1"):
        bm.load_structure(path)


def test_unknown_method_and_option():
    s = bm.cases.single_block()
    with pytest.raises(bm.UnknownNameError, match=r"unknown method 'simplex-lp'; available methods: .*static-lp"):
        bm.solve(s, "simplex-lp")
    with pytest.raises(bm.OptionError, match=r"method 'static-lp' has no option 'tolerance'"):
        bm.solve(s, "static-lp", tolerance=1)


# ---------------------------------------------------------------- the committed bad-input corpus

CORPUS = Path(__file__).resolve().parent / "data"
MANIFEST = json.loads((CORPUS / "bad_inputs.manifest.json").read_text())


def test_corpus_has_at_least_100_files_each_in_the_manifest():
    files = sorted(p.name for p in (CORPUS / "bad_inputs").glob("*.json"))
    assert len(MANIFEST) >= 100
    assert files == sorted(e["file"] for e in MANIFEST)
    assert all(e["expect"] for e in MANIFEST)


@pytest.mark.parametrize("entry", MANIFEST, ids=[e["file"][:40] for e in MANIFEST])
def test_corpus_file_gets_one_clear_line_and_exit_code_2(entry, capsys):
    """Every bad file: exit 2, one line on stderr naming what is wrong, nothing on stdout (no result,
    so no success with a wrong lambda), no traceback, no warning lines."""
    from blockmpec.cli import main

    path = CORPUS / "bad_inputs" / entry["file"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning from numpy would be a second line
        code = main(["solve", str(path), "--method", "static-lp"])
    out, err = capsys.readouterr()
    assert code == 2, (code, out, err)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert entry["expect"] in lines[0], lines[0]
    assert "Traceback" not in err


def test_corpus_files_fail_alike_through_the_library():
    for entry in MANIFEST[:: 7]:
        with pytest.raises(bm.BlockmpecError, match=re.escape(entry["expect"])):
            bm.load_structure(CORPUS / "bad_inputs" / entry["file"])


# ---------------------------------------------------------------- point loads and the live-load sign

def test_point_load_on_the_boundary_is_accepted_and_just_outside_is_not():
    on_edge = bm.PointLoad(1, (1.0, 0.5), (0.0, -1.0))
    corner = bm.PointLoad(1, (1.0 + 1e-9, 1.0), (0.0, -1.0))
    make([BASE, SQUARE], [True, False], point_loads=[on_edge, corner])
    outside = bm.PointLoad(1, (1.001, 0.5), (0.0, -1.0))
    with pytest.raises(bm.StructureError, match=r"point load 0: its point \[1.001, 0.5\] lies outside block 1"):
        make([BASE, SQUARE], [True, False], point_loads=[outside])


def test_point_load_check_is_scale_free():
    s = 1e-120
    ok = bm.PointLoad(1, (0.5 * s, 0.5 * s), (0.0, -1e-240))
    make([[[x * s, y * s] for x, y in BASE], [[x * s, y * s] for x, y in SQUARE]], [True, False], point_loads=[ok])
    bad_load = bm.PointLoad(1, (0.5 * s, 1.5 * s), (0.0, -1e-240))
    with pytest.raises(bm.StructureError, match=r"point load 0: its point .* lies outside block 1"):
        make([[[x * s, y * s] for x, y in BASE], [[x * s, y * s] for x, y in SQUARE]], [True, False],
             point_loads=[bad_load])


def test_negative_live_factor_is_rejected_the_sign_is_the_direction():
    with pytest.raises(bm.StructureError, match=r"live_factor: must be a finite number >= 0; got -1.0 "
                                               r"\(the sign of the live load is live_direction"):
        make([BASE, SQUARE], [True, False], live_factor=-1.0)
    left = bm.solve(make([BASE, SQUARE], [True, False], live_direction=-1), "static-lp")
    right = bm.solve(make([BASE, SQUARE], [True, False], live_direction=1), "static-lp")
    assert left.success and right.success and left.multiplier == pytest.approx(right.multiplier, rel=1e-12)


def test_coordinates_far_from_the_origin_warn_that_digits_may_be_lost():
    off = 1e15
    with pytest.warns(bm.PrecisionWarning, match=r"block \d: its coordinates \(up to 1e\+15\) are resolved only to 0.125"):
        make([[[x + off, y] for x, y in BASE], [[x + off, y] for x, y in SQUARE]], [True, False])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        make([[[x + 1e3, y] for x, y in BASE], [[x + 1e3, y] for x, y in SQUARE]], [True, False])
