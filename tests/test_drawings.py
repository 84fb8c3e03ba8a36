"""Structures from DXF, SVG and images; bad drawings; results drawn back (issues 42 and 48).

The drawings are written by the tests (ezdxf, SVG text, numpy arrays) into tmp_path.  The two-block
problem of the paper's Sect. 3 drawn in each format must give its closed forms: the associative
multiplier by the static LP, the minimum non-associative one by the fixed point and the MILP.  The
corpus of drawings made the way CAD programs and Inkscape write them (mirrored, rotated, scaled and
nested block references, extrusion -z, loops of lines, bulges, R12 files without handles, Inkscape
layers, <use> clones, transformed <rect>s, viewBox offsets) draws one asymmetric scene whose
multipliers differ for +x and -x (so that a mirror shows) and whose base forces are checked in the
user's units (so that a mis-scale shows).
"""

import json
import re
import warnings
import xml.etree.ElementTree as ET

import ezdxf
import numpy as np
import pytest
import shapely

import blockmpec as bm
from blockmpec.cli import main
from blockmpec.drawings import DrawingWarning, export_drawing, read_structure
from blockmpec.drawings.export import solution_in_structure_frame

CASES = [(3.0, 0.65), (2.0, 0.3)]  # (eta, mu): rocking and sliding governs the non-associative minimum


def closed_forms(eta, mu):
    return (bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu),
            bm.cases.closed_form("two-blocks", "non-associative", eta=eta, mu=mu))


def assert_two_block_closed_forms(s, eta, mu):
    associative, minimum = closed_forms(eta, mu)
    lp = bm.solve(s, "static-lp")
    assert lp.success and lp.multiplier == pytest.approx(associative, rel=1e-9)
    for method in ("fixed-point", "milp"):
        res = bm.solve(s, method)
        assert res.success, (method, res.status, res.message)
        assert res.multiplier == pytest.approx(minimum, rel=1e-7), method


def two_block_dxf(path, eta, b=1000.0, clockwise=False, polyline2d=False, mirror=False, units=4, extra=None):
    """The two-block problem in millimetres (b = 1,000 mm): a base on layer 'fixed', two blocks on 'stones'."""
    doc = ezdxf.new(units=units)
    msp = doc.modelspace()
    h = eta * b
    outlines = [("fixed", [(-b, -b / 2), (3 * b, -b / 2), (3 * b, 0), (-b, 0)]),
                ("stones", [(0, 0), (b, 0), (b, h), (0, h)]),
                ("stones", [(b, 0), (2 * b, 0), (2 * b, h), (b, h)])]
    for layer, pts in outlines:
        if mirror:
            pts = [(-x, y) for x, y in pts]
        if clockwise:
            pts = pts[::-1]
        if polyline2d:
            msp.add_polyline2d(pts, close=True, dxfattribs={"layer": layer})
        else:
            msp.add_lwpolyline(pts, close=True, dxfattribs={"layer": layer})
    msp.add_text("survey 2024", dxfattribs={"layer": "notes"})
    if extra:
        extra(msp)
    doc.saveas(path)
    return path


@pytest.mark.parametrize(("eta", "mu"), CASES)
def test_dxf_two_blocks_gives_the_closed_forms(tmp_path, eta, mu):
    s = read_structure(two_block_dxf(tmp_path / "two.dxf", eta), mu=mu)
    assert s.n_blocks == 3 and s.fixed.tolist() == [True, False, False] and len(s.interfaces) == 3
    assert s.metadata["drawing"]["scale"] == 0.001  # $INSUNITS = mm
    np.testing.assert_allclose(s.polygon(1).max(axis=0), [1.0, eta])
    assert_two_block_closed_forms(s, eta, mu)


def test_dxf_outlines_clockwise_as_old_polylines_and_mirrored(tmp_path):
    eta, mu = CASES[0]
    s = read_structure(two_block_dxf(tmp_path / "cw.dxf", eta, clockwise=True, polyline2d=True), mu=mu, units="m",
                       live_direction=-1, fixed_layer="FIXED")
    assert s.metadata["drawing"]["scale"] == 1.0  # units= overrides $INSUNITS
    mirrored = read_structure(two_block_dxf(tmp_path / "m.dxf", eta, mirror=True), mu=mu)
    for structure in (s, mirrored):
        assert structure.fixed.tolist() == [True, False, False]
    associative, _ = closed_forms(eta, mu)
    assert bm.solve(mirrored, "static-lp").multiplier == pytest.approx(
        bm.solve(read_structure(two_block_dxf(tmp_path / "m2.dxf", eta, mirror=True), mu=mu, live_direction=-1),
                 "static-lp").multiplier)
    # the mirrored drawing with the live load mirrored is the original problem
    assert bm.solve(read_structure(tmp_path / "m.dxf", mu=mu, live_direction=-1), "static-lp").multiplier == \
        pytest.approx(associative, rel=1e-9)


def two_block_svg(eta, mu=None, fixed='class="fixed"'):
    """The two-block problem in an SVG (y down; blocks 10 user units wide) with a group transform."""
    h = 10 * eta
    return f"""<?xml version="1.0"?>
<svg xmlns="http://www.w3.org/2000/svg" viewBox="-20 {-h - 10} 60 {h + 20}">
  <g id="supports" {fixed}><rect x="-10" y="0" width="40" height="5"/></g>
  <g id="stones" transform="translate(5,0)">
    <polygon id="left" points="-5,0 5,0 5,{-h} -5,{-h}"/>
    <path id="right" d="M 5 0 L 15 0 L 15 {-h} L 5 {-h} Z"/>
  </g>
</svg>"""


@pytest.mark.parametrize(("eta", "mu"), CASES)
def test_svg_two_blocks_gives_the_closed_forms_with_y_turned_up(tmp_path, eta, mu):
    path = tmp_path / "two.svg"
    path.write_text(two_block_svg(eta))
    s = read_structure(path, mu=mu, units="cm")
    assert s.fixed.tolist() == [True, False, False]
    np.testing.assert_allclose(s.polygon(1).min(axis=0), [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(s.polygon(1).max(axis=0), [0.1, 0.1 * eta])  # y up, in metres
    drawing = s.metadata["drawing"]
    assert {k: drawing[k] for k in ("format", "scale", "flip_y", "source", "entities")} == {
        "format": "svg", "scale": 0.01, "flip_y": True, "source": "two.svg",
        "entities": ['<rect> number 1 (no id)', '<polygon id="left">', '<path id="right">']}
    assert drawing["summary"] == "read 2 stones and 1 support; skipped nothing" and drawing["warnings"] == []
    assert_two_block_closed_forms(s, eta, mu)


def test_svg_width_with_a_unit_sets_the_scale(tmp_path):
    text = two_block_svg(3.0).replace('<svg xmlns="http://www.w3.org/2000/svg"',
                                      '<svg xmlns="http://www.w3.org/2000/svg" width="600mm" height="500mm"')
    (tmp_path / "mm.svg").write_text(text)
    s = read_structure(tmp_path / "mm.svg")
    assert s.metadata["drawing"]["scale"] == pytest.approx(0.01)  # 600 mm over a viewBox 60 wide
    np.testing.assert_allclose(s.polygon(1).max(axis=0), [0.1, 0.3], rtol=1e-12)


def two_block_labels(eta, b=20):
    """Labels of the two-block problem: blocks b pixels wide on the image's bottom row."""
    h = int(eta * b)
    labels = np.zeros((h + 5, 3 * b), np.uint16)
    labels[5:, b // 2 : b // 2 + b] = 7
    labels[5:, b // 2 + b : b // 2 + 2 * b] = 3
    return labels


@pytest.mark.parametrize(("eta", "mu"), CASES)
def test_labelled_image_two_blocks_gives_the_closed_forms(tmp_path, eta, mu):
    np.save(tmp_path / "two.npy", two_block_labels(eta))
    s = read_structure(tmp_path / "two.npy", mu=mu, pixel_size=0.05)
    assert s.metadata["drawing"]["entities"] == ["label 3", "label 7", "the base (added under the image)"]
    np.testing.assert_allclose(s.polygon(1).min(axis=0), [0.5, 0.0], atol=1e-15)  # label 7: 10 px in, 1 m wide
    np.testing.assert_allclose(s.polygon(1).max(axis=0), [1.5, eta])
    assert_two_block_closed_forms(s, eta, mu)


def test_png_labels_and_binary_png_with_joints(tmp_path):
    skimage_io = pytest.importorskip("skimage.io")
    labels = two_block_labels(3.0)
    skimage_io.imsave(tmp_path / "two.png", labels, check_contrast=False)
    s = read_structure(tmp_path / "two.png", mu=0.65, pixel_size=0.05)
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(closed_forms(3.0, 0.65)[0], rel=1e-9)
    binary = np.where(labels > 0, 255, 0).astype(np.uint8)
    binary[:, 29:31] = 0  # a joint 2 pixels wide between the blocks
    skimage_io.imsave(tmp_path / "binary.png", binary, check_contrast=False)
    s = read_structure(tmp_path / "binary.png", mu=0.65, pixel_size=0.05)
    assert s.n_blocks == 3 and s.fixed.sum() == 1
    pairs = sorted(zip(s.interfaces.minus.tolist(), s.interfaces.plus.tolist()))
    assert pairs == [(0, 1), (0, 2), (1, 2)]  # the joint closed: the blocks touch
    # the joint is split between the stones; its mouth at the top stays open by a pixel, within 1% of lam
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(closed_forms(3.0, 0.65)[0], rel=1e-2)


@pytest.mark.slow
def test_rasterised_stone_wall_keeps_its_stones_and_contacts(tmp_path):
    """A stone wall drawn as a label image 80 pixels per stone: the same stones, every contact longer
    than 3 pixels found again, and lam within 2 % of the vector wall's (pixel outlines, simplified)."""
    shapely = pytest.importorskip("shapely")
    wall = bm.cases.stone_wall(width=4.0, height=2.0, stone_size=0.4, irregularity=0.8, seed=2)
    px = 0.005
    rows, cols = int(round(2.0 / px)), int(round(4.0 / px))
    yy, xx = np.mgrid[0:rows, 0:cols]
    cx, cy = ((xx + 0.5) * px).ravel(), ((rows - yy - 0.5) * px).ravel()
    labels = np.zeros(rows * cols, np.int32)
    for i in range(1, wall.n_blocks):
        labels[shapely.contains_xy(shapely.Polygon(wall.polygon(i)), cx, cy)] = i
    np.save(tmp_path / "wall.npy", labels.reshape(rows, cols))
    s = read_structure(tmp_path / "wall.npy", pixel_size=px)
    label = [int(n.split()[1]) if n.startswith("label") else 0 for n in s.metadata["drawing"]["entities"]]
    assert sorted(label) == list(range(wall.n_blocks))

    def contacts(structure, names=None):
        out = {}
        for k in range(len(structure.interfaces)):
            a, b = int(structure.interfaces.minus[k]), int(structure.interfaces.plus[k])
            if names:
                a, b = names[a], names[b]
            out[(min(a, b), max(a, b))] = out.get((min(a, b), max(a, b)), 0) + structure.interfaces.length[k]
        return out

    vector, raster = contacts(wall), contacts(s, label)
    assert {k for k, v in vector.items() if v > 3 * px} <= set(raster)
    lam = bm.solve(wall, "static-lp").multiplier
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(lam, rel=2e-2)


def test_image_reader_without_scikit_image_names_the_extra(tmp_path, monkeypatch):
    import sys

    (tmp_path / "wall.png").write_bytes(b"not read")
    monkeypatch.setitem(sys.modules, "skimage", None)
    with pytest.raises(bm.SolverUnavailableError, match=r"pip install 'blockmpec\[image\]'"):
        read_structure(tmp_path / "wall.png")


# ------------------------------------------------------------------------------------- bad drawings


def _dxf(path, outlines, fixed_layer="fixed", open_ones=()):
    doc = ezdxf.new()
    msp = doc.modelspace()
    handles = []
    for k, (layer, pts) in enumerate(outlines):
        handles.append(msp.add_lwpolyline(pts, close=k not in open_ones, dxfattribs={"layer": layer}).dxf.handle)
    doc.saveas(path)
    return handles


BASE = ("fixed", [(-1, -0.5), (3, -0.5), (3, 0), (-1, 0)])
LEFT = ("stones", [(0, 0), (1, 0), (1, 3), (0, 3)])
RIGHT = ("stones", [(1, 0), (2, 0), (2, 3), (1, 3)])


@pytest.mark.parametrize(
    ("outlines", "open_ones", "message"),
    [
        ([BASE, LEFT, RIGHT], (2,), r"LWPOLYLINE #{2} on layer 'stones' is an open polyline \(its ends are 3 drawing "
                                    r"units apart\)"),
        ([BASE, LEFT, ("stones", [(1, 0), (2, 0), (1, 3), (2, 3)])], (),
         r"LWPOLYLINE #{2} on layer 'stones': its outline crosses or touches itself at \[1\.5, 1\.5\]"),
        ([BASE, LEFT, ("stones", [(0.5, 0), (2, 0), (2, 3), (0.5, 3)])], (),
         r"LWPOLYLINE #{1} on layer 'stones' and LWPOLYLINE #{2} on layer 'stones' overlap \(penetration 0\.4"),
        ([BASE, LEFT, ("stones", [(5, 0), (6, 0), (6, 1), (5, 1)])], (),
         r"LWPOLYLINE #{2} on layer 'stones' touches no other block"),
        ([("base", BASE[1]), LEFT, RIGHT], (), r"no support: no closed polyline on layer 'fixed'"),
        ([BASE, LEFT, RIGHT, ("stones", [(5, 0), (6, 0), (6, 1), (5, 1)]), ("stones", [(5, 1), (6, 1), (6, 2), (5, 2)])],
         (), r"stones LWPOLYLINE #{3} on layer 'stones', LWPOLYLINE #{4} on layer 'stones' are not connected to any "
             r"fixed block"),
    ],
    ids=["open", "self-intersecting", "overlapping", "touching-nothing", "no-support", "floating-pair"],
)
def test_bad_dxf_gets_one_line_naming_the_entity(tmp_path, capsys, outlines, open_ones, message):
    path = tmp_path / "bad.dxf"
    handles = _dxf(path, outlines, open_ones=open_ones)
    pattern = message
    for k, handle in enumerate(handles):
        pattern = pattern.replace(f"{{{k}}}", handle)
    code = main(["solve", str(path), "--method", "static-lp"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"blockmpec: error: {path}: ")
    assert re.search(pattern, err), err


def test_dxf_without_polylines_or_not_dxf_is_named(tmp_path):
    doc = ezdxf.new()
    for k in range(4):
        doc.modelspace().add_line((0, k), (1, k))
    doc.saveas(tmp_path / "lines.dxf")
    with pytest.raises(bm.StructureFileError, match=r"no closed polyline \(found 4 LINE\); draw each stone"):
        read_structure(tmp_path / "lines.dxf")
    (tmp_path / "text.dxf").write_text("hello\n")
    with pytest.raises(bm.StructureFileError, match=r"text.dxf: not a (valid|readable) DXF file"):
        read_structure(tmp_path / "text.dxf")
    with pytest.raises(bm.StructureFileError, match=r"missing.dxf: cannot read"):
        read_structure(tmp_path / "missing.dxf")


def test_dxf_layers_option_and_unknown_options(tmp_path):
    path = tmp_path / "two.dxf"
    _dxf(path, [BASE, LEFT, RIGHT, ("frame", [(-5, -5), (5, -5), (5, 5), (-5, 5)])])
    with pytest.raises(bm.GeometryError, match=r"overlap"):  # the drawing frame is read as a stone
        read_structure(path)
    s = read_structure(path, layers=["stones"])
    assert s.n_blocks == 3
    with pytest.raises(bm.OptionError, match=r"unknown option 'fixed_layr'; did you mean 'fixed_layer'\?"):
        read_structure(path, fixed_layr="base")
    with pytest.raises(bm.OptionError, match=r"units: must be one of m, dm, cm, mm, km, in, ft; got 'furlong'"):
        read_structure(path, units="furlong")
    with pytest.raises(bm.OptionError, match=r"live_direction: must be 1 \(towards \+x\) or -1"):
        read_structure(path, layers=["stones"], live_direction=0)


def test_dxf_snaps_a_survey_s_gaps_and_records_them(tmp_path):
    path = tmp_path / "gappy.dxf"
    handles = _dxf(path, [BASE, ("stones", [(0, 0.0008), (1, 0), (1.0005, 3), (0, 3)]),
                          ("stones", [(1, 0.0002), (2, 0), (2, 3), (1, 3)])])
    s = read_structure(path, mu=0.65)
    assert len(s.interfaces) == 3
    moved_blocks = {v[0] for v in s.metadata["snapping"]["vertices"]}
    assert moved_blocks == {0, 2}
    assert s.metadata["drawing"]["entities"][2] == f"LWPOLYLINE #{handles[2]} on layer 'stones'"
    with pytest.raises(bm.GeometryError, match=rf"LWPOLYLINE #{handles[1]} on layer 'stones' and LWPOLYLINE "
                                               rf"#{handles[2]} on layer 'stones' overlap \(penetration 0\.0005\)"):
        read_structure(path, snap=0)


def _svg(path, body, root='xmlns="http://www.w3.org/2000/svg"'):
    path.write_text(f"<svg {root}>{body}</svg>")
    return path


SVG_BASE = '<rect class="fixed" x="-10" y="0" width="40" height="5"/>'
SVG_LEFT = '<polygon id="left" points="0,0 10,0 10,-30 0,-30"/>'


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (SVG_BASE + SVG_LEFT + '<path id="r" d="M 10 0 L 20 0 L 20 -30 L 10 -30"/>',
         r'<path id="r"> is open \(its ends are 30 user units apart\); close it with Z'),
        (SVG_BASE + SVG_LEFT + '<polyline points="10,0 20,0 20,-10"/>',
         r"<polyline> number 3 \(no id\) is open \(its ends are 14.1 user units apart\)"),
        (SVG_BASE + SVG_LEFT + '<polygon id="r" points="10,0 20,0 10,-30 20,-30"/>',
         r'<polygon id="r">: its outline crosses or touches itself at \[15, -15\]'),
        (SVG_BASE + SVG_LEFT + '<polygon id="r" points="5,0 20,0 20,-30 5,-30"/>',
         r'<polygon id="left"> and <polygon id="r"> overlap'),
        (SVG_BASE + SVG_LEFT + '<polygon id="far" points="50,0 60,0 60,-10 50,-10"/>',
         r'<polygon id="far"> touches no other block'),
        (SVG_LEFT + '<polygon id="r" points="10,0 20,0 20,-30 10,-30"/>',
         r"no support: no shape with class 'fixed'"),
        ('<text x="0" y="0">no stones</text><line x1="0" y1="0" x2="1" y2="1"/>',
         r"no closed path, polygon or rect \(found 1 <line>, 1 <text>\)"),
    ],
    ids=["open-path", "open-polyline", "self-intersecting", "overlapping", "touching-nothing", "no-support", "empty"],
)
def test_bad_svg_gets_one_line_naming_the_element(tmp_path, capsys, body, message):
    path = _svg(tmp_path / "bad.svg", body)
    code = main(["solve", str(path), "--method", "static-lp"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert re.search(message, err), err


def test_not_an_svg_is_named(tmp_path):
    (tmp_path / "a.svg").write_text("<html><body/></html>")
    with pytest.raises(bm.StructureFileError, match=r"a.svg: not an SVG file \(its root element is <html>\)"):
        read_structure(tmp_path / "a.svg")
    (tmp_path / "b.svg").write_text("<svg")
    with pytest.raises(bm.StructureFileError, match=r"b.svg: not valid XML"):
        read_structure(tmp_path / "b.svg")


@pytest.mark.parametrize(
    ("labels", "options", "message"),
    [
        ("split", {}, r"label 7: its pixels form 2 separate regions"),
        ("ring", {}, r"label 7 surrounds label 3; a stone must be a simple polygon"),
        ("floating", {"pixel_size": 0.05}, r"label 9 touches no other block"),
        ("two", {"fixed_labels": [9]}, r"fixed_labels: label 9 is not in .* \(its labels: 3 \.\.\. 7\)"),
        ("two", {"fixed_labels": [3, 7]}, r"every stone is a support"),
        ("empty", {}, r"no stone \(every pixel is background\)"),
    ],
)
def test_bad_image_gets_one_line_naming_the_label(tmp_path, labels, options, message):
    image = two_block_labels(3.0)
    if labels == "split":
        image[20:22, :] = np.where(image[20:22, :] == 7, 0, image[20:22, :])
    elif labels == "ring":
        image[:] = 0
        image[5:, 10:40] = 7
        image[15:25, 17:33] = 0
        image[18:22, 20:30] = 3
    elif labels == "floating":
        image[0:3, 0:3] = 9
    elif labels == "empty":
        image[:] = 0
    np.save(tmp_path / "bad.npy", image)
    with pytest.raises(bm.BlockmpecError, match=message):
        read_structure(tmp_path / "bad.npy", **options)


def test_jpeg_is_refused_with_the_reason(tmp_path):
    pytest.importorskip("skimage")
    (tmp_path / "wall.jpg").write_bytes(b"\xff\xd8")
    with pytest.raises(bm.OptionError, match=r"not a drawing or image this version reads"):
        read_structure(tmp_path / "wall.jpg")


# ------------------------------------------------------------------------------------------- export


def _physical_equilibrium_residual(structure, result):
    """Largest residual, over the free blocks, of sum of interface forces + dead + lam * live = 0, in the
    structure's frame and units, from the exported conversion."""
    sol = solution_in_structure_frame(structure, result)
    f = sol["forces"]
    itf = structure.interfaces
    c = structure.centroid
    w = structure.weight
    total = np.zeros((structure.n_blocks, 3))
    total[:, 1] -= w
    total[:, 0] += result.multiplier * structure.live_direction * structure.live_factor * w
    for k in range(len(itf)):
        if not np.all(np.isfinite(f[k])):
            continue
        t, n, m = f[k]
        force = t * itf.tangent[k] + n * itf.normal[k]  # of the plus block on the minus block
        mid = itf.midpoint[k]
        for block, sign in ((itf.minus[k], 1.0), (itf.plus[k], -1.0)):
            arm = mid - c[block]
            total[block, :2] += sign * force
            total[block, 2] += sign * (arm[0] * force[1] - arm[1] * force[0] + m)
    return np.abs(total[~structure.fixed]).max() / w[~structure.fixed].max()


@pytest.mark.parametrize("live_direction", [1, -1])
def test_exported_forces_balance_every_stone_in_the_drawing_frame(live_direction):
    s = bm.cases.stone_wall(width=2.0, height=1.0, stone_size=0.3, irregularity=0.8, seed=3)
    s = bm.make_structure([s.polygon(i) for i in range(s.n_blocks)], s.fixed, friction=0.65,
                          live_direction=live_direction)
    res = bm.solve(s, "static-lp")
    assert res.success
    assert _physical_equilibrium_residual(s, res) < 1e-9


def test_export_dxf_copies_the_survey_and_adds_the_layers(tmp_path):
    src = two_block_dxf(tmp_path / "two.dxf", 3.0)
    s = read_structure(src, mu=0.65)
    res = bm.solve(s, "static-lp")
    out = export_drawing(s, res, tmp_path / "out.dxf", source=src)
    doc = ezdxf.readfile(out)
    layers = {}
    for e in doc.modelspace():
        layers.setdefault(e.dxf.layer, []).append(e.dxftype())
    assert layers["stones"] == ["LWPOLYLINE", "LWPOLYLINE"] and layers["notes"] == ["TEXT"]  # the survey's own
    assert sorted(layers["blockmpec-mechanism"]) == ["LWPOLYLINE", "LWPOLYLINE"]  # both blocks move
    assert sorted(layers["blockmpec-forces"]) == ["CIRCLE"] * 3 + ["LINE"] * 3
    # in the drawing's units (mm): the base joint's force acts at a toe of the left block
    circles = sorted(tuple(e.dxf.center)[:2] for e in doc.modelspace().query('CIRCLE[layer=="blockmpec-forces"]'))
    assert circles[0] == pytest.approx((1000.0, 0.0))
    note = doc.modelspace().query('TEXT[layer=="blockmpec-notes"]')[0].dxf.text
    assert "static-lp" in note and "lambda = 0.419727" in note


def test_export_svg_groups_overlay_the_svg_drawing(tmp_path):
    src = tmp_path / "two.svg"
    src.write_text(two_block_svg(3.0))
    s = read_structure(src, mu=0.65)
    res = bm.solve(s, "fixed-point")
    out = export_drawing(s, res, tmp_path / "out.svg", source=src)
    ns = {"svg": "http://www.w3.org/2000/svg"}
    root = ET.parse(out).getroot()
    assert root.get("viewBox") == ET.parse(src).getroot().get("viewBox")  # a copy of the drawing
    assert root.find(".//svg:polygon[@id='left']", ns) is not None
    forces = root.find("svg:g[@id='blockmpec-forces']", ns)
    centres = [(float(c.get("cx")), float(c.get("cy"))) for c in forces.findall("svg:circle", ns)]
    assert all(abs(y) < 1e-9 or y < 0 for _, y in centres)  # drawn in the SVG's frame (y down: above the base)
    assert all(-10 <= x <= 30 for x, _ in centres)
    titles = [t.text for t in forces.iter("{http://www.w3.org/2000/svg}title")]
    assert titles and all(t.startswith("interface ") and ", n = -" in t for t in titles)
    mechanism = root.find("svg:g[@id='blockmpec-mechanism']", ns)
    assert len(mechanism.findall("svg:polygon", ns)) >= 1


def test_export_refuses_bad_paths_and_empty_results(tmp_path):
    s = bm.cases.two_blocks()
    res = bm.solve(s, "static-lp")
    with pytest.raises(bm.OptionError, match=r"the file must end in \.dxf or \.svg"):
        export_drawing(s, res, tmp_path / "out.pdf")
    with pytest.raises(bm.OptionError, match=r"its folder does not exist"):
        export_drawing(s, res, tmp_path / "nope" / "out.svg")
    empty = bm.Result(method="static-lp", status=bm.Status.INFEASIBLE, problem="associative")
    with pytest.raises(bm.OptionError, match=r"neither a mechanism nor interface forces"):
        export_drawing(s, empty, tmp_path / "out.svg")
    out = export_drawing(s, res, tmp_path / "case.svg")  # a built-in case: a new SVG with the stones
    assert ET.parse(out).getroot().find("{http://www.w3.org/2000/svg}g[@id='blockmpec-stones']") is not None


# ---------------------------------------------------------------------------------------------- CLI


def test_cli_import_then_solve_and_solve_drawing_with_export(tmp_path, capsys):
    src = two_block_dxf(tmp_path / "two.dxf", 3.0)
    assert main(["import", str(src), "-o", str(tmp_path / "two.json"), "-p", "mu=0.65"]) == 0
    assert "wrote" in capsys.readouterr().out
    data = json.loads((tmp_path / "two.json").read_text())
    assert data["metadata"]["drawing"]["format"] == "dxf" and len(data["blocks"]) == 3
    assert main(["solve", str(tmp_path / "two.json"), "--method", "static-lp", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["multiplier"] == pytest.approx(closed_forms(3.0, 0.65)[0], rel=1e-9)
    code = main(["solve", str(src), "--method", "static-lp", "-p", "mu=0.65", "--export-drawing",
                 str(tmp_path / "out.dxf")])
    assert code == 0 and (tmp_path / "out.dxf").exists()
    assert main(["solve", str(src), "--method", "static-lp", "--export-drawing", str(tmp_path / "x.pdf")]) == 2
    assert "the file must end in .dxf or .svg" in capsys.readouterr().err
    assert main(["import", str(tmp_path / "two.json"), "-o", str(tmp_path / "x.json")]) == 2


def test_compare_takes_a_drawing(tmp_path):
    from blockmpec.cli import compare_cases

    src = two_block_dxf(tmp_path / "two.dxf", 3.0)
    (run,) = compare_cases([str(src)])
    assert run.label == "two" and run.structure.n_blocks == 3


# ------------------------------------------------------------------ real-world drawings (issue 48)
#
# One asymmetric scene drawn the ways CAD programs and Inkscape write it, in millimetres: a base on the
# fixed layer and an L-shaped stone with its foot towards +x.  Closed forms (mu = 5): the L (area 1.75 m^2,
# centroid (19/28, 19/28) m by the shoelace sums) rocks about its toe (2, 0) m under a +x load, lam =
# (2 - 19/28) / (19/28) = 37/19, and about its heel (0, 0) under a -x load, lam = 1: statically admissible
# (the whole reaction N = W, T = lam W at the hinge, T/N < mu) and kinematically admissible (rocking about
# the hinge), so exact.  A mirrored stone swaps the two values; a mis-scaled one changes the base's forces
# (N = -density x area, |T| = lam N in the user's units), which lam alone cannot see.

BASE_MM = [(-1000, -500), (3000, -500), (3000, 0), (-1000, 0)]
L_MM = [(0, 0), (2000, 0), (2000, 500), (500, 500), (500, 2000), (0, 2000)]
L_LAMBDA = {1: 37 / 19, -1: 1.0}
L_AREA = 1.75  # m^2
DENSITY = 2.0


def _closed(points):
    return list(points) + [points[0]]


def assert_stones(s, expected, rel=1e-9):
    """The structure's blocks are the ``expected`` outlines (metres; any order, start and orientation) with
    their supports: each matches one block up to a symmetric difference of ``rel`` times its area."""
    got = [shapely.Polygon(s.polygon(i)) for i in range(s.n_blocks)]
    assert len(got) == len(expected), s.metadata["drawing"]["entities"]
    for outline, fixed in expected:
        want = shapely.Polygon(outline)
        match = [i for i, g in enumerate(got) if shapely.symmetric_difference(g, want).area <= rel * want.area]
        assert len(match) == 1, (outline, [g.wkt for g in got])
        assert bool(s.fixed[match[0]]) is fixed


def assert_l_scene(path, **options):
    """``path`` holds the scene: its stones in metres, lam for +x and -x, and the base's forces in the user's units."""
    base = [(x / 1000, y / 1000) for x, y in BASE_MM]
    stone = [(x / 1000, y / 1000) for x, y in L_MM]
    for direction, lam in L_LAMBDA.items():
        s = read_structure(path, mu=5.0, density=DENSITY, live_direction=direction, **options)
        assert_stones(s, [(base, True), (stone, False)])
        res = bm.solve(s, "static-lp")
        assert res.success and res.multiplier == pytest.approx(lam, rel=1e-9), (direction, res.multiplier)
        forces = res.forces
        weight = DENSITY * L_AREA  # N of the base on the L, in the user's units (metres, density per m^2)
        assert forces["normal"].sum() == pytest.approx(-weight, rel=1e-9)
        assert abs(forces["shear"].sum()) == pytest.approx(lam * weight, rel=1e-9)
    return s


def _dxf_doc(version="R2018"):
    doc = ezdxf.new(version, units=4 if version != "R12" else 0)  # $INSUNITS 4: millimetres
    return doc, doc.modelspace()


def dxf_plain(path):
    """LWPOLYLINEs in the model space: the world coordinates as they are."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    msp.add_lwpolyline(L_MM, close=True, dxfattribs={"layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_mirrored_insert(path):
    """The block holds the L mirrored, (x, y) -> (-x, y); its INSERT with xscale -1 mirrors it back."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    doc.blocks.new("L-MIRRORED").add_lwpolyline([(-x, y) for x, y in L_MM], close=True,
                                               dxfattribs={"layer": "stones"})
    msp.add_blockref("L-MIRRORED", (0, 0), dxfattribs={"xscale": -1, "layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_extrusion(path):
    """As AutoCAD's MIRROR writes: extrusion (0, 0, -1), whose object coordinates (u, v) are the world's (-u, v)
    (arbitrary axis algorithm: Ax = (0, 1, 0) x N = (-1, 0, 0), Ay = N x Ax = (0, 1, 0))."""
    doc, msp = _dxf_doc()
    for layer, outline in (("fixed", BASE_MM), ("stones", L_MM)):
        msp.add_lwpolyline([(-x, y) for x, y in outline], close=True,
                           dxfattribs={"layer": layer, "extrusion": (0, 0, -1)})
    doc.saveas(path)
    return {}


def dxf_layer_zero(path):
    """Block content on layer 0 takes its INSERT's layer (CAD's convention): the base block's polyline is on
    layer 0, its INSERT on layer 'Fixed' (layer names compared without case)."""
    doc, msp = _dxf_doc()
    doc.blocks.new("BASE").add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "0"})
    msp.add_blockref("BASE", (0, 0), dxfattribs={"layer": "Fixed"})
    msp.add_lwpolyline(L_MM, close=True, dxfattribs={"layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_rotated_scaled_insert(path):
    """An INSERT at i = (300, 400), rotation 90 degrees, scale 2, of a block with base point b = (100, 200):
    block point q goes to i + R90 (2 (q - b)); the block holds q = b + R-90 (p - i) / 2 for the L's points p."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    block = doc.blocks.new("L-LYING", base_point=(100, 200))
    block.add_lwpolyline([(100 + (y - 400) / 2, 200 - (x - 300) / 2) for x, y in L_MM], close=True)
    msp.add_blockref("L-LYING", (300, 400), dxfattribs={"rotation": 90, "xscale": 2, "yscale": 2,
                                                         "layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_non_uniform_insert(path):
    """An INSERT scaled 2 in x and 1/3 in y: the block holds (x / 2, 3 y) for the L's (x, y)."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    doc.blocks.new("L-SQUASHED").add_lwpolyline([(x / 2, 3 * y) for x, y in L_MM], close=True)
    msp.add_blockref("L-SQUASHED", (0, 0), dxfattribs={"xscale": 2, "yscale": 1 / 3, "layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_nested(path):
    """OUTER inserted at (1000, 0) with xscale -1 and rotation 180 maps (x, y) to (x + 1000, -y); INNER inserted
    in OUTER with yscale -1 maps (x, y) to (x, -y): INNER's (x, y) is the world's (x + 1000, y), so INNER holds
    the L moved by -1000 in x.  Everything inside is on layer 0, the outer INSERT on 'stones'."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    doc.blocks.new("INNER").add_lwpolyline([(x - 1000, y) for x, y in L_MM], close=True)
    doc.blocks.new("OUTER").add_blockref("INNER", (0, 0), dxfattribs={"yscale": -1})
    msp.add_blockref("OUTER", (1000, 0), dxfattribs={"xscale": -1, "rotation": 180, "layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_lines(path):
    """Both outlines drawn with LINEs, one per edge, the base's top line running under the L's bottom one."""
    doc, msp = _dxf_doc()
    for layer, outline in (("fixed", BASE_MM), ("stones", L_MM)):
        for a, b in zip(outline, outline[1:] + outline[:1]):
            msp.add_line(a, b, dxfattribs={"layer": layer})
    doc.saveas(path)
    return {}


def dxf_exploded(path):
    """The polylines exploded into LINEs by ezdxf (what EXPLODE leaves in a drawing)."""
    doc, msp = _dxf_doc()
    for layer, outline in (("fixed", BASE_MM), ("stones", L_MM)):
        msp.add_lwpolyline(outline, close=True, dxfattribs={"layer": layer}).explode()
    doc.saveas(path)
    return {}


def dxf_polyline2d(path):
    """Old-style POLYLINE entities, drawn clockwise."""
    doc, msp = _dxf_doc()
    for layer, outline in (("fixed", BASE_MM), ("stones", L_MM)):
        msp.add_polyline2d(outline[::-1], close=True, dxfattribs={"layer": layer})
    doc.saveas(path)
    return {}


def dxf_spline(path):
    """The L as a SPLINE of degree 1, which is the polygon through its control points (its last one repeating
    the first: closed)."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    msp.add_open_spline(L_MM + L_MM[:1], degree=1, dxfattribs={"layer": "stones"})
    doc.saveas(path)
    return {}


def dxf_r12_without_handles(path):
    """An R12 file as ezdxf's r12writer writes it: no header, no handles, so no unit (units='mm' given)."""
    from ezdxf.addons import r12writer

    with r12writer(str(path)) as dxf:
        dxf.add_polyline_2d(BASE_MM, closed=True, layer="fixed")
        dxf.add_polyline_2d(L_MM, closed=True, layer="stones")
    return {"units": "mm"}


def dxf_r12(path):
    """An R12 file with a header and handles (R12 has no $INSUNITS: units='mm' given)."""
    doc, msp = _dxf_doc("R12")
    msp.add_polyline2d(BASE_MM, close=True, dxfattribs={"layer": "fixed"})
    msp.add_polyline2d(L_MM, close=True, dxfattribs={"layer": "stones"})
    doc.saveas(path)
    return {"units": "mm"}


DXF_VARIANTS = [dxf_plain, dxf_mirrored_insert, dxf_extrusion, dxf_layer_zero, dxf_rotated_scaled_insert,
                dxf_non_uniform_insert, dxf_nested, dxf_lines, dxf_exploded, dxf_polyline2d, dxf_spline,
                dxf_r12_without_handles, dxf_r12]


@pytest.mark.parametrize("write", DXF_VARIANTS, ids=[w.__name__[4:] for w in DXF_VARIANTS])
def test_dxf_corpus_places_the_asymmetric_scene_in_world_coordinates(tmp_path, write):
    path = tmp_path / "scene.dxf"
    options = write(path)
    s = assert_l_scene(path, **options)
    assert s.metadata["drawing"]["scale"] == 0.001


def test_dxf_lines_are_joined_and_counted_and_the_rest_is_skipped_by_kind(tmp_path):
    path = tmp_path / "lines.dxf"
    dxf_lines(path)
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    msp.add_line((5000, 0), (6000, 0), dxfattribs={"layer": "notes"})  # a decorative line
    msp.add_text("survey 2024", dxfattribs={"layer": "notes"})
    msp.add_circle((4000, 1000), 50)  # a survey point's marker
    doc.saveas(path)
    s = read_structure(path)
    drawing = s.metadata["drawing"]
    # 4 base lines + 6 L lines joined; the decorative line, the text and the circle left out
    assert drawing["summary"] == "read 1 stone and 1 support (2 joined from 10 LINE); skipped 1 CIRCLE, 1 LINE, 1 TEXT"
    assert drawing["read"] == {"stones": 1, "supports": 1, "joined": {"LINE": 10},
                               "skipped": {"LINE": 1, "TEXT": 1, "CIRCLE": 1}}
    assert drawing["entities"][1].startswith("loop of LINE #") and drawing["entities"][1].endswith("on layer 'stones'")
    s = read_structure(path, layers=["stones"])  # layers not read are counted as such
    assert "1 LINE on layers not read" in s.metadata["drawing"]["summary"]


def _rect_lines(msp, x0, y0, x1, y1, over=0.0, under=0.0):
    """A rectangle drawn with four LINEs as a draughtsman might: each one `over` past its far corner, or
    ending `under` short of it."""
    for a, b, d in [((x0, y0), (x1, y0), (1, 0)), ((x1, y0), (x1, y1), (0, 1)), ((x1, y1), (x0, y1), (-1, 0)),
                    ((x0, y1), (x0, y0), (0, -1))]:
        start = (a[0] - over * d[0], a[1] - over * d[1])
        end = (b[0] + (over - under) * d[0], b[1] + (over - under) * d[1])
        msp.add_line(start, end, dxfattribs={"layer": "stones"})


@pytest.mark.parametrize(("over", "under", "rel"), [(0.0, 0.0, 1e-9), (50.0, 0.0, 1e-9), (0.0, 0.1, 1e-4)],
                         ids=["exact", "overshooting", "undershooting"])
def test_dxf_two_blocks_drawn_with_lines_as_drafted(tmp_path, over, under, rel):
    """The two-block problem (mm) with each block drawn with its own four LINEs: exactly, past the corners by
    50 mm (the pieces past a corner are loose ends, or lie on the neighbour's outline: drawn twice there),
    and 0.1 mm short (the end joined with the corner's: the corner moves by 0.05 mm, which moves lam by
    less than 1e-4; measured 6.6e-5)."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline([(-1000, -500), (3000, -500), (3000, 0), (-1000, 0)], close=True,
                       dxfattribs={"layer": "fixed"})
    _rect_lines(msp, 0, 0, 1000, 3000, over, under)
    _rect_lines(msp, 1000, 0, 2000, 3000, over, under)
    doc.saveas(tmp_path / "drafted.dxf")
    s = read_structure(tmp_path / "drafted.dxf", mu=0.65)
    assert s.metadata["drawing"]["summary"] == "read 2 stones and 1 support (2 joined from 8 LINE); skipped nothing"
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(closed_forms(3.0, 0.65)[0], rel=rel)


def test_dxf_space_enclosed_by_stones_drawn_with_lines_is_not_a_stone(tmp_path):
    """A window: a sill, two jambs and a lintel, each drawn with its own lines, enclose a space whose edges
    are each drawn once (by the stone beside it): four stones, not five."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline([(-1000, -500), (4000, -500), (4000, 0), (-1000, 0)], close=True,
                       dxfattribs={"layer": "fixed"})
    for box in [(0, 0, 3000, 500), (0, 500, 1000, 1500), (2000, 500, 3000, 1500), (0, 1500, 3000, 2000)]:
        _rect_lines(msp, *box)
    doc.saveas(tmp_path / "window.dxf")
    s = read_structure(tmp_path / "window.dxf")
    assert_stones(s, [([(-1, -0.5), (4, -0.5), (4, 0), (-1, 0)], True)] + [
        ([(x0 / 1000, y0 / 1000), (x1 / 1000, y0 / 1000), (x1 / 1000, y1 / 1000), (x0 / 1000, y1 / 1000)], False)
        for x0, y0, x1, y1 in [(0, 0, 3000, 500), (0, 500, 1000, 1500), (2000, 500, 3000, 1500), (0, 1500, 3000, 2000)]])


def test_dxf_stone_wall_exploded_into_lines_reads_back_the_same_wall(tmp_path):
    """A rubble wall of the built-in generator (stones of 5 to 9 edges sharing corners and T-junctions) with
    every outline exploded by ezdxf into LINEs: the same stones, hence the same lam as the wall itself."""
    wall = bm.cases.stone_wall(width=4.0, height=2.0, stone_size=0.3, irregularity=0.8, seed=2)
    doc = ezdxf.new(units=6)  # metres
    for i in range(wall.n_blocks):
        layer = "fixed" if wall.fixed[i] else "stones"
        doc.modelspace().add_lwpolyline(wall.polygon(i), close=True, dxfattribs={"layer": layer}).explode()
    doc.saveas(tmp_path / "wall.dxf")
    s = read_structure(tmp_path / "wall.dxf", mu=0.65)
    assert s.metadata["drawing"]["read"]["joined"]["LINE"] == sum(len(wall.polygon(i)) for i in range(wall.n_blocks))
    assert_stones(s, [(wall.polygon(i), bool(wall.fixed[i])) for i in range(wall.n_blocks)])
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(bm.solve(wall, "static-lp").multiplier, rel=1e-9)


def arched_stone_lambda(sx, sy):
    """lam of a stone 1000 mm wide with walls 1000 mm high and a semicircular top (radius 500 mm), scaled by sx
    and sy, rocking on a base (mu = 5).  Unscaled: area A0 = 1000^2 + pi 500^2 / 2, centroid height
    y0 = (1000^2 500 + pi 500^2 / 2 (1000 + 4 500 / (3 pi))) / A0; an affine map moves the centroid with it,
    so lam = (half the width) / (centroid height) = sx 500 / (sy y0) either way."""
    half_disc = np.pi * 500**2 / 2
    y0 = (1000**2 * 500 + half_disc * (1000 + 4 * 500 / (3 * np.pi))) / (1000**2 + half_disc)
    return sx * 500 / (sy * y0)


ARCHED = [(0, 0, 0), (1000, 0, 0), (1000, 1000, 1), (0, 1000, 0)]  # x, y, bulge: 1 is a half circle to the left


@pytest.mark.parametrize("how", ["lwpolyline", "polyline2d", "non-uniform-insert", "exploded-insert"])
def test_dxf_bulges_stay_arcs_under_non_uniform_scaling(tmp_path, how):
    """A stone with a semicircular top: as a bulge, and inserted with xscale 2, yscale 1/2 (the arc an elliptic
    one), also exploded by ezdxf into LINE and ELLIPSE entities, which are joined back."""
    doc, msp = _dxf_doc()
    scaled = how in ("non-uniform-insert", "exploded-insert")
    sx, sy = (2.0, 0.5) if scaled else (1.0, 1.0)
    msp.add_lwpolyline([(-1000, -500), (3000, -500), (3000, 0), (-1000, 0)], close=True,
                       dxfattribs={"layer": "fixed"})
    if how == "lwpolyline":
        msp.add_lwpolyline(ARCHED, format="xyb", close=True)
    elif how == "polyline2d":
        msp.add_polyline2d([(x, y) for x, y, _ in ARCHED], close=True).vertices[2].dxf.bulge = 1
    else:
        doc.blocks.new("ARCHED").add_lwpolyline(ARCHED, format="xyb", close=True)
        insert = msp.add_blockref("ARCHED", (0, 0), dxfattribs={"xscale": sx, "yscale": sy})
        if how == "exploded-insert":
            kinds = sorted(e.dxftype() for e in insert.explode())
            assert kinds == ["ELLIPSE", "LINE", "LINE", "LINE"]  # what ezdxf makes of it
    doc.saveas(tmp_path / "arched.dxf")
    for direction in (1, -1):
        # snap=0: chords this fine are shorter than the snapping distance, which would merge their vertices
        s = read_structure(tmp_path / "arched.dxf", mu=5.0, arc_tolerance=1e-5, snap=0, live_direction=direction)
        assert s.n_blocks == 2
        area = (1.0 + np.pi * 0.5**2 / 2) * sx * sy  # m^2
        # chords of sagitta d = 1e-5 x the size (~1600 mm) cut (2/3) d x the arc (1571 mm): 1.2e-5 of the area
        assert s.area[1] == pytest.approx(area, rel=2e-5)
        res = bm.solve(s, "static-lp")
        assert res.multiplier == pytest.approx(arched_stone_lambda(sx, sy), rel=2e-5)
        assert res.forces["normal"].sum() == pytest.approx(-area, rel=2e-5)


def test_dxf_minsert_copies_are_the_two_block_problem(tmp_path):
    """A MINSERT of one 1000 x 3000 mm block in two columns 1000 mm apart is the paper's two-block problem."""
    doc, msp = _dxf_doc()
    msp.add_lwpolyline([(-1000, -500), (3000, -500), (3000, 0), (-1000, 0)], close=True,
                       dxfattribs={"layer": "fixed"})
    doc.blocks.new("BLOCK").add_lwpolyline([(0, 0), (1000, 0), (1000, 3000), (0, 3000)], close=True)
    msp.add_blockref("BLOCK", (0, 0)).grid(size=(1, 2), spacing=(3000, 1000))
    doc.saveas(tmp_path / "minsert.dxf")
    s = read_structure(tmp_path / "minsert.dxf", mu=0.65)
    assert s.n_blocks == 3
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(closed_forms(3.0, 0.65)[0], rel=1e-9)


SVG_HEAD = ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" ')


def _points(outline, mirror_x=False):
    """SVG points of a world outline (y down: (x, y) -> (x, -y)), optionally mirrored in x."""
    return " ".join(f"{-x if mirror_x else x},{-y}" for x, y in outline)


def svg_inkscape(path):
    """Inkscape's way: layers (groups with inkscape:groupmode="layer" and a label, 'Fixed' in another case
    than fixed_class), a translated layer, relative path commands, a viewBox with an offset scaled into
    8000 x 3000 mm: preserveAspectRatio's default fits it, min(8000/4000, 3000/3000) = 1 mm per user unit."""
    path.write_text(SVG_HEAD + 'width="8000mm" height="3000mm" viewBox="-1000 -2500 4000 3000">'
                    '<g inkscape:groupmode="layer" inkscape:label="Fixed" transform="translate(0,100)">'
                    '<path d="M -1000,-100 h 4000 v 500 h -4000 z"/></g>'
                    '<g inkscape:groupmode="layer" inkscape:label="Stones">'
                    '<path d="m 0,0 h 2000 v -500 h -1500 v -1500 h -500 z"/></g></svg>')
    return {}


def svg_use(path):
    """<use> clones: the L defined mirrored, (x, y) -> (-x, y), cloned with scale(-1, 1); the base a <rect>
    of class fixed cloned with x, y attributes (a translation)."""
    path.write_text(SVG_HEAD + 'viewBox="-2000 -3000 6000 4000"><defs>'
                    f'<polygon id="l-mirrored" points="{_points(L_MM, mirror_x=True)}"/>'
                    '<rect id="slab" class="fixed" width="4000" height="500"/></defs>'
                    '<use href="#l-mirrored" transform="scale(-1,1)"/>'
                    '<use xlink:href="#slab" x="-1000" y="0"/></svg>')
    return {"units": "mm"}


def svg_transformed_rect(path):
    """A <rect> rotated by its own transform: rotate(90) maps (x, y) to (-y, x), so x in [0, 500], y in
    [-3000, 1000] covers the base's [-1000, 3000] x [0, 500]; the L in a group mirrored with scale(-1, 1)."""
    path.write_text(SVG_HEAD + 'viewBox="-2000 -3000 6000 4000">'
                    '<rect class="fixed" x="0" y="-3000" width="500" height="4000" transform="rotate(90)"/>'
                    f'<g transform="scale(-1,1)"><polygon points="{_points(L_MM, mirror_x=True)}"/></g></svg>')
    return {"units": "mm"}


def svg_lines(path):
    """The L drawn with six <line> elements (as CAD exports write SVG), joined into a loop."""
    lines = "".join(f'<line x1="{a[0]}" y1="{-a[1]}" x2="{b[0]}" y2="{-b[1]}"/>'
                    for a, b in zip(L_MM, L_MM[1:] + L_MM[:1]))
    path.write_text(SVG_HEAD + f'viewBox="-2000 -3000 6000 4000"><polygon class="fixed" points="{_points(BASE_MM)}"/>'
                    f'{lines}<text x="0" y="100">elevation</text></svg>')
    return {"units": "mm"}


SVG_VARIANTS = [svg_inkscape, svg_use, svg_transformed_rect, svg_lines]


@pytest.mark.parametrize("write", SVG_VARIANTS, ids=[w.__name__[4:] for w in SVG_VARIANTS])
def test_svg_corpus_places_the_asymmetric_scene_in_world_coordinates(tmp_path, write):
    path = tmp_path / "scene.svg"
    options = write(path)
    s = assert_l_scene(path, **options)
    assert s.metadata["drawing"]["scale"] == pytest.approx(0.001, rel=1e-12)


def test_svg_mirrored_and_rotated_rect_stones_give_the_closed_forms(tmp_path):
    """The two-block problem with its stones as transformed <rect>s: the left one mirrored (scale(-1,1) of
    x in [-10, 0]), the right one turned by 180 degrees about its centre (15, -15)."""
    path = _svg(tmp_path / "rects.svg", SVG_BASE + '<rect x="-10" y="-30" width="10" height="30" '
                'transform="scale(-1,1)"/><rect x="10" y="-30" width="10" height="30" transform="rotate(180 15 -15)"/>')
    s = read_structure(path, mu=0.65)
    assert_stones(s, [([(-10, -5), (30, -5), (30, 0), (-10, 0)], True), ([(0, 0), (10, 0), (10, 30), (0, 30)], False),
                      ([(10, 0), (20, 0), (20, 30), (10, 30)], False)], rel=1e-12)
    assert_two_block_closed_forms(s, 3.0, 0.65)


def test_svg_skips_decorations_hidden_layers_and_counts_them(tmp_path):
    path = _svg(tmp_path / "deco.svg", SVG_BASE + SVG_LEFT + '<polygon id="r" points="10,0 20,0 20,-30 10,-30"/>'
                '<line x1="0" y1="-40" x2="20" y2="-40"/><text x="0" y="-45">elevation</text>'
                '<image href="photo.png" width="10" height="10"/>'
                '<g style="display:none"><rect x="100" y="0" width="5" height="5"/></g>')
    s = read_structure(path, mu=0.65)
    assert s.n_blocks == 3
    assert s.metadata["drawing"]["read"]["skipped"] == {"<line>": 1, "<text>": 1, "<image>": 1,
                                                        "hidden (display:none)": 1}


def test_svg_names_are_compared_without_case(tmp_path):
    path = _svg(tmp_path / "case.svg", '<rect class="Fixed Base" x="-10" y="0" width="40" height="5"/>' + SVG_LEFT)
    assert read_structure(path).fixed.tolist() == [True, False]
    path = _svg(tmp_path / "layer.svg", '<g inkscape:label="FIXED"><rect x="-10" y="0" width="40" height="5"/></g>'
                + SVG_LEFT, root=SVG_HEAD[5:])
    assert read_structure(path).fixed.tolist() == [True, False]


# ------------------------------------------------------- drawings that cannot be read: one line each


def _two_rects_one_joint(msp):
    """Two stones drawn as one network: the joint between them drawn once for both."""
    for a, b in [((0, 0), (2, 0)), ((2, 0), (2, 3)), ((2, 3), (0, 3)), ((0, 3), (0, 0)), ((1, 0), (1, 3))]:
        msp.add_line(a, b, dxfattribs={"layer": "stones"})


def _block_inserting_itself(msp):
    block = msp.doc.blocks.new("SELF")
    block.add_lwpolyline([(0, 0), (1, 0), (1, 1)], close=True)
    block.add_blockref("SELF", (1, 0))
    msp.add_blockref("SELF", (0, 0))


@pytest.mark.parametrize(
    ("draw", "message"),
    [
        (_block_inserting_itself, r"block 'SELF' inserts itself \(SELF > SELF\)"),
        (_two_rects_one_joint,
         r"LINE #\w+ on layer 'stones': cannot tell the stones from the spaces between them along \[1, 0\] - \[1, 3\] "
         r"\(drawn once there, between two faces\)"),
        (lambda msp: [msp.add_line(a, b, dxfattribs={"layer": "stones"}) for a, b in
                      [((0, 0), (1, 0)), ((1, 0), (1, 3)), ((1, 3), (0, 3)), ((0, 3), (0, 0)), ((-1, 1), (2, 1))]],
         r"cannot tell the stones from the spaces between them along \[0, 1\] - \[1, 1\]"),
        (lambda msp: msp.add_lwpolyline([(0, 0), (1, 0), (1, 1)], close=True,
                                        dxfattribs={"layer": "stones", "extrusion": (0, 1, 0)}),
         r"LWPOLYLINE #\w+ on layer 'stones' does not lie in a plane parallel to x-y \(its z runs from 0 to 1\)"),
    ],
    ids=["block-inserting-itself", "joint-drawn-once", "line-across-a-stone", "outside-the-x-y-plane"],
)
def test_dxf_that_cannot_be_read_gets_one_line_naming_the_entities(tmp_path, capsys, draw, message):
    doc = ezdxf.new()
    msp = doc.modelspace()
    msp.add_lwpolyline(BASE[1], close=True, dxfattribs={"layer": "fixed"})
    draw(msp)
    doc.saveas(tmp_path / "bad.dxf")
    code = main(["solve", str(tmp_path / "bad.dxf"), "--method", "static-lp"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert re.search(message, err), err


def test_r12_without_handles_names_entities_by_number(tmp_path):
    from ezdxf.addons import r12writer

    with r12writer(str(tmp_path / "r12.dxf")) as dxf:
        dxf.add_polyline_2d(BASE[1], closed=True, layer="fixed")
        dxf.add_polyline_2d(LEFT[1], closed=True, layer="stones")
        dxf.add_polyline_2d([(5, 0), (6, 0), (6, 1), (5, 1)], closed=True, layer="stones")
    with pytest.raises(bm.StructureError, match=r"POLYLINE number 3 on layer 'stones' touches no other block"):
        read_structure(tmp_path / "r12.dxf")


def test_not_connected_says_how_many_stones_in_all(tmp_path):
    floating = [("stones", [(10 + k, 0), (11 + k, 0), (11 + k, 1), (10 + k, 1)]) for k in range(12)]
    _dxf(tmp_path / "many.dxf", [BASE, LEFT, *floating])
    with pytest.raises(bm.StructureError, match=r"#\w+ on layer 'stones' and 2 more \(12 in all\) are not connected"):
        read_structure(tmp_path / "many.dxf")


def test_svg_stretched_unequally_is_refused_unless_the_unit_is_given(tmp_path):
    root = ('xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="-20 -40 60 30" '
            'preserveAspectRatio="none"')
    path = _svg(tmp_path / "stretched.svg", SVG_BASE + SVG_LEFT, root=root)
    with pytest.raises(bm.StructureFileError, match=r"stretched unequally \(preserveAspectRatio=\"none\": 2 times"):
        read_structure(path)
    assert read_structure(path, units="mm").metadata["drawing"]["scale"] == 0.001


def test_svg_nested_viewbox_is_refused_not_misplaced(tmp_path):
    # svgelements 1.9 places a nested <svg>'s content without its viewBox's scaling: refused, with the element
    path = _svg(tmp_path / "nested.svg", SVG_BASE + '<svg id="inner" x="0" y="-30" width="10" height="30" '
                'viewBox="0 0 1 3"><rect width="1" height="3"/></svg>')
    with pytest.raises(bm.StructureFileError, match=r'<svg id="inner"> has a viewBox of its own'):
        read_structure(path)


@pytest.mark.parametrize("content", [b"not an image", b"\x89PNG\r\n\x1a\nbroken"])
def test_unreadable_image_is_one_line_without_install_advice(tmp_path, capsys, content):
    pytest.importorskip("skimage")
    (tmp_path / "stones.png").write_bytes(content)
    code = main(["import", str(tmp_path / "stones.png"), "-o", str(tmp_path / "s.json")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "pip" not in err, err
    assert re.match(r"blockmpec: error: .*stones.png: not a readable PNG image \(", err), err


# ------------------------------------------------------- units: drawings that look like millimetres


def _square_stones_dxf(path, size, units=0):
    """A base and two square stones of side ``size`` drawing units; $INSUNITS ``units`` (0: none)."""
    doc = ezdxf.new(units=units)
    msp = doc.modelspace()
    msp.add_lwpolyline([(-size, -size), (3 * size, -size), (3 * size, 0), (-size, 0)], close=True,
                       dxfattribs={"layer": "fixed"})
    for k in range(2):
        msp.add_lwpolyline([(k * size, 0), ((k + 1) * size, 0), ((k + 1) * size, size), (k * size, size)],
                           close=True)
    doc.saveas(path)
    return path


def test_a_drawing_without_unit_whose_stones_look_like_millimetres_is_warned_about(tmp_path, capsys):
    # the median stone size is the square root of the median area over the base (4 size^2) and the two
    # squares (size^2): `size` itself; 20 or more read as metres "looks like millimetres"
    with pytest.warns(DrawingWarning, match=r"mm.dxf: no length unit \(\$INSUNITS\) in the drawing, so read in "
                                            r"metres, its stones are 400 m across \(median\); that looks like "
                                            r"millimetres: give -p units=mm"):
        s = read_structure(_square_stones_dxf(tmp_path / "mm.dxf", 400.0))
    assert len(s.metadata["drawing"]["warnings"]) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", DrawingWarning)
        read_structure(_square_stones_dxf(tmp_path / "m.dxf", 19.9))  # below the threshold: metres
        read_structure(tmp_path / "mm.dxf", units="mm")  # the unit given
        read_structure(_square_stones_dxf(tmp_path / "insunits.dxf", 400.0, units=4))  # the unit in the file
    with pytest.warns(DrawingWarning, match=r"its stones are 20 m across"):
        read_structure(_square_stones_dxf(tmp_path / "twenty.dxf", 20.0))
    assert main(["import", str(tmp_path / "mm.dxf"), "-o", str(tmp_path / "mm.json")]) == 0
    out, err = capsys.readouterr()
    assert err.startswith("blockmpec: warning: ") and err.count("\n") == 1, err
    assert out.startswith(f"{tmp_path / 'mm.dxf'}: read 2 stones and 1 support; skipped nothing\n")
    svg = _svg(tmp_path / "px.svg", SVG_BASE.replace("40", "400") + SVG_LEFT.replace("10", "100").replace("30", "300"))
    with pytest.warns(DrawingWarning, match=r"no length unit \(a width or height in mm"):
        read_structure(svg)


# ------------------------------------------------------------------------------- command line lines


def test_solve_and_import_print_what_the_reader_read_and_skipped(tmp_path, capsys):
    src = two_block_dxf(tmp_path / "two.dxf", 3.0)
    summary = "read 2 stones and 1 support; skipped 1 TEXT"
    assert main(["solve", str(src), "--method", "static-lp"]) == 0
    assert capsys.readouterr().out.startswith(f"{src}: {summary}\n")
    assert main(["solve", str(src), "--method", "static-lp", "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["success"] and f"{src}: {summary}" in err  # stdout keeps only the JSON
    assert main(["import", str(src), "-o", str(tmp_path / "two.json")]) == 0
    assert capsys.readouterr().out.startswith(f"{src}: {summary}\n")
    assert json.loads((tmp_path / "two.json").read_text())["metadata"]["drawing"]["summary"] == summary


def test_argparse_errors_are_one_line_and_help_stays_whole(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["solve", "two-blocks"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1
    assert err.startswith("blockmpec: error: solve: the following arguments are required: --method/-m")
    with pytest.raises(SystemExit) as exit_:
        main(["sovle"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.count("\n") == 1 and "invalid choice: 'sovle'" in err
    with pytest.raises(SystemExit) as exit_:
        main(["solve", "--help"])
    out = capsys.readouterr().out
    assert exit_.value.code == 0 and out.startswith("usage: blockmpec solve") and "--export-drawing" in out


def test_pushover_prints_no_negative_zero(tmp_path, capsys):
    """A parallelogram whose centroid (1, 1) stands over its toe (1, 0) has lam = 0, which the LP returns as
    -0.0: the table prints 0."""
    from blockmpec.structure_file import save_structure

    s = bm.make_structure([[[-2, -1], [4, -1], [4, 0], [-2, 0]], [[0, 0], [1, 0], [2, 2], [1, 2]]], [True, False],
                          friction=5.0)
    save_structure(s, tmp_path / "leaning.json")
    assert main(["pushover", str(tmp_path / "leaning.json"), "--no-figure", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^\s+0\s+0\s+0\s+0 optimal start$", out, re.M), out
    assert not re.search(r"(?<![\w.])-0(?![.\d])", out), out
