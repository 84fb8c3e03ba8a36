"""Structures from DXF, SVG and images; bad drawings; results drawn back (issue 42).

The drawings are written by the tests (ezdxf, SVG text, numpy arrays) into tmp_path.  The two-block
problem of the paper's Sect. 3 drawn in each format must give its closed forms: the associative
multiplier by the static LP, the minimum non-associative one by the fixed point and the MILP.
"""

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.cli import main
from blockmpec.drawings import export_drawing, read_structure
from blockmpec.drawings.export import solution_in_structure_frame

ezdxf = pytest.importorskip("ezdxf")

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
    assert s.metadata["drawing"] == {"format": "svg", "scale": 0.01, "flip_y": True, "source": "two.svg",
                                     "entities": ['<rect> number 1 (no id)', '<polygon id="left">',
                                                  '<path id="right">']}
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
    s = read_structure(tmp_path / "two.png", mu=0.65)
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(closed_forms(3.0, 0.65)[0], rel=1e-9)
    binary = np.where(labels > 0, 255, 0).astype(np.uint8)
    binary[:, 29:31] = 0  # a joint 2 pixels wide between the blocks
    skimage_io.imsave(tmp_path / "binary.png", binary, check_contrast=False)
    s = read_structure(tmp_path / "binary.png", mu=0.65)
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
    assert __import__("re").search(pattern, err), err


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
        (SVG_BASE + SVG_LEFT + '<polyline points="10,0 20,0"/>', r"<polyline> number 3 \(no id\) is an open line"),
        (SVG_BASE + SVG_LEFT + '<polygon id="r" points="10,0 20,0 10,-30 20,-30"/>',
         r'<polygon id="r">: its outline crosses or touches itself at \[15, -15\]'),
        (SVG_BASE + SVG_LEFT + '<polygon id="r" points="5,0 20,0 20,-30 5,-30"/>',
         r'<polygon id="left"> and <polygon id="r"> overlap'),
        (SVG_BASE + SVG_LEFT + '<polygon id="far" points="50,0 60,0 60,-10 50,-10"/>',
         r'<polygon id="far"> touches no other block'),
        (SVG_LEFT + '<polygon id="r" points="10,0 20,0 20,-30 10,-30"/>',
         r"no support: no shape with class 'fixed'"),
        ('<text x="0" y="0">no stones</text>', r"no closed path, polygon or rect \(found 0 shapes\)"),
    ],
    ids=["open-path", "open-polyline", "self-intersecting", "overlapping", "touching-nothing", "no-support", "empty"],
)
def test_bad_svg_gets_one_line_naming_the_element(tmp_path, capsys, body, message):
    path = _svg(tmp_path / "bad.svg", body)
    code = main(["solve", str(path), "--method", "static-lp"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert __import__("re").search(message, err), err


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
        ("floating", {}, r"label 9 touches no other block"),
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
