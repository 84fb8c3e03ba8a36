"""Capacity curves (bm.pushover, blockmpec pushover): closed forms, step-size independence, real
structures, the CLI and bad input."""

import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import blockmpec as bm
from blockmpec.pushover import CURVE_COLUMNS, block_polygons

METHODS = ["static-lp", "fixed-point"]


def _column(h_lower=1.0, h_upper=2.0, mu=0.65):
    """Two 1-wide blocks stacked on a wide base (column height h_lower + h_upper)."""
    base = [[-1, -1], [2, -1], [2, 0], [-1, 0]]
    lower = [[0, 0], [1, 0], [1, h_lower], [0, h_lower]]
    upper = [[0, h_lower], [1, h_lower], [1, h_lower + h_upper], [0, h_lower + h_upper]]
    return bm.make_structure([base, lower, upper], [True, False, False], friction=mu)


def _solved(curve):
    return curve[np.isfinite(curve["multiplier"])]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("height", [2.0, 4.0])
def test_a_block_rocking_on_its_toe_follows_tan_alpha_minus_theta(method, height):
    # b x h block toppling towards +x about its toe: lam(theta) = tan(alpha - theta), tan(alpha) = b / h,
    # at the rotation each step actually reached (rotation is counter-clockwise: theta = -rotation)
    curve = bm.pushover(bm.cases.single_block(1.0, height), method, max_displacement=0.5, steps=20)
    assert list(curve.columns[: len(CURVE_COLUMNS)]) == list(CURVE_COLUMNS)
    assert curve.attrs["control_block"] == 1 and len(curve) == 21
    assert (curve["status"] != "infeasible").all() and curve["multiplier"].notna().all()
    theta = -curve["rotation"].to_numpy()
    expected = np.tan(np.arctan(1.0 / height) - theta)
    np.testing.assert_allclose(curve["multiplier"], expected, rtol=0, atol=1e-9)  # 5.3e-13 measured
    assert np.all(np.diff(theta) > 0) and curve["point_contacts"].iloc[1:].eq(1).all()
    # the toe does not move
    toe = np.array([block_polygons(bm.cases.single_block(1.0, height), curve, k)[1][1] for k in range(len(curve))])
    np.testing.assert_allclose(toe, np.tile([1.0, 0.0], (len(curve), 1)), atol=1e-12)


def test_the_curve_ends_where_lambda_reaches_zero():
    # b/h = 1/2: the centroid is above the toe, lam = 0, when it has moved by b/2
    curve = bm.pushover(bm.cases.single_block(1.0, 2.0), "static-lp", max_displacement=0.8, steps=20)
    assert curve.attrs["stop_reason"] == "the load multiplier reached 0"
    assert curve["multiplier"].iloc[-1] <= 0 < curve["multiplier"].iloc[-2]
    assert curve.attrs["ultimate_displacement"] == pytest.approx(0.5, abs=1e-3)
    assert -curve["rotation"].iloc[-1] >= math.atan(0.5) - 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_a_two_block_column_rocks_as_one_body_with_the_columns_height(method):
    column = _column(1.0, 2.0)
    curve = bm.pushover(column, method, max_displacement=0.4, steps=8)
    assert curve.attrs["control_block"] == 2
    np.testing.assert_allclose(curve["block_1_angle"], curve["block_2_angle"], atol=1e-12)  # one body
    expected = np.tan(np.arctan(1.0 / 3.0) + curve["rotation"].to_numpy())
    np.testing.assert_allclose(curve["multiplier"], expected, rtol=0, atol=1e-9)  # 4.1e-13 measured
    assert curve["rotation"].iloc[-1] < -0.19


@pytest.mark.parametrize("method", METHODS)
def test_a_sliding_block_keeps_lambda_equal_to_mu(method):
    # mu = 0.3 < b/h = 1: the block slides; it stays on its base (the associative flow's dilatancy is a
    # rate of the limit state, not a climb) and lam = mu at every step
    curve = bm.pushover(bm.cases.single_block(1.0, 1.0, mu=0.3), method, max_displacement=0.5, steps=10)
    assert len(curve) == 11 and curve.attrs["stop_reason"] == "max_displacement reached"
    np.testing.assert_allclose(curve["multiplier"], 0.3, rtol=0, atol=1e-12)  # 0 measured
    np.testing.assert_allclose(curve["displacement"], np.linspace(0.0, 0.5, 11), atol=1e-12)  # 5.6e-17 measured
    np.testing.assert_allclose(curve["rotation"], 0.0, atol=1e-12)
    np.testing.assert_allclose(curve["block_1_y"], 0.5, atol=1e-9)  # 3.7e-10 measured (static-lp)


def test_the_curve_does_not_depend_on_the_step_size():
    block = bm.cases.single_block(1.0, 3.0)
    coarse = bm.pushover(block, "static-lp", max_displacement=0.3, steps=5)
    fine = bm.pushover(block, "static-lp", max_displacement=0.3, steps=15)
    common = fine.iloc[::3].reset_index(drop=True)
    np.testing.assert_allclose(coarse["displacement"], common["displacement"], atol=1e-12)
    np.testing.assert_allclose(coarse["rotation"], common["rotation"], atol=1e-9)
    np.testing.assert_allclose(coarse["multiplier"], common["multiplier"], atol=1e-9)


@pytest.mark.slow
def test_the_arch_curve_does_not_depend_on_the_step_size():
    # the arch snaps through twice (its thrust line reaches a fifth joint between its four pinned
    # hinges); the steps are cut back to where that happens, so the curve is the same for 10 or 40 steps:
    # measured, the snaps' displacements agree to 1.5e-3 and 2e-4, their multipliers to 1.8e-4, the ultimate
    # displacements to 2.3e-3 (relative)
    arch = bm.cases.round_arch()
    coarse = bm.pushover(arch, "static-lp", steps=10)
    fine = bm.pushover(arch, "static-lp", steps=40)
    assert coarse.attrs["ultimate_displacement"] == pytest.approx(fine.attrs["ultimate_displacement"], rel=5e-3)
    snaps = [frame[frame["event"] == "instability"] for frame in (coarse, fine)]
    assert len(snaps[0]) == len(snaps[1]) == 2
    for column in ("displacement", "multiplier"):
        np.testing.assert_allclose(snaps[0][column], snaps[1][column], rtol=5e-3)
    # the first snap comes before a tenth of the ultimate displacement, at a multiplier below the undeformed one
    assert snaps[1]["displacement"].iloc[0] < 0.1 * fine.attrs["ultimate_displacement"]
    assert snaps[1]["multiplier"].iloc[0] < bm.solve(arch, "static-lp").multiplier


def test_the_default_control_is_the_centroid_of_the_block_that_moves_most():
    structure = bm.cases.single_block()
    curve = bm.pushover(structure, "static-lp", max_displacement=0.5, steps=20)
    assert curve.attrs["control_block"] == 1
    assert curve.attrs["control_point"] == pytest.approx(list(structure.centroid[1]))
    assert curve["control_x"].iloc[-1] - curve["control_x"].iloc[0] == pytest.approx(0.5, abs=1e-12)


def test_a_control_point_moves_by_the_steps():
    structure = bm.cases.single_block(1.0, 2.0)
    curve = bm.pushover(structure, "static-lp", control=(0.0, 2.0), max_displacement=0.2, steps=4)  # the top-left corner
    assert curve.attrs["control_block"] == 1
    np.testing.assert_allclose(curve["displacement"], np.linspace(0, 0.2, 5), atol=1e-12)
    np.testing.assert_allclose(curve["control_x"], np.linspace(0, 0.2, 5), atol=1e-12)
    # the corner turns about the toe (1, 0): |q - toe| is constant
    radius = np.hypot(curve["control_x"] - 1.0, curve["control_y"])
    np.testing.assert_allclose(radius, math.hypot(1.0, 2.0), rtol=1e-12)


def test_lambda_against_the_live_load_mirrored():
    # live load towards -x: the same curve, displacement measured along the live load, rotation mirrored
    s = bm.cases.single_block(1.0, 2.0)
    mirrored = bm.make_structure([(s.polygon(i) * [-1, 1])[::-1] for i in range(2)], s.fixed, friction=s.friction,
                                 live_direction=-1)
    a = bm.pushover(s, "static-lp", max_displacement=0.3, steps=3)
    b = bm.pushover(mirrored, "static-lp", max_displacement=0.3, steps=3)
    assert b.attrs["direction"] == -1
    np.testing.assert_allclose(b["multiplier"], a["multiplier"], atol=1e-9)
    np.testing.assert_allclose(b["displacement"], a["displacement"], atol=1e-12)
    np.testing.assert_allclose(b["rotation"], -a["rotation"], atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(("name", "build", "method"), [
    ("round-arch", bm.cases.round_arch, "static-lp"),
    ("arch-on-buttresses", bm.cases.arch_on_buttresses, "fixed-point"),
    ("wall-5x4", lambda: bm.cases.wall(5, 4), "static-lp"),
    ("wall-5x4", lambda: bm.cases.wall(5, 4), "fixed-point"),
    ("wall-10x5", lambda: bm.cases.wall(10, 5), "fixed-point"),
])
def test_real_structures_start_at_the_undeformed_lambda_and_decrease(name, build, method):
    structure = build()
    curve = bm.pushover(structure, method, steps=8)
    undeformed = bm.solve(structure, method)
    assert curve["multiplier"].iloc[0] == pytest.approx(undeformed.multiplier, rel=1e-9)
    lam = _solved(curve)["multiplier"].to_numpy()
    assert len(lam) >= 4
    assert np.all(np.diff(lam) <= 1e-9), lam  # every configuration that stands holds less than the last
    assert lam[-1] < lam[0] - 0.01


def test_curve_and_figure_helpers(tmp_path):
    from blockmpec.pushover_plot import animate_pushover, draw_configuration, plot_capacity_curve, save_animation

    block = bm.cases.single_block(1.0, 2.0)
    curves = {m: bm.pushover(block, m, max_displacement=0.2, steps=2) for m in METHODS}
    ax = plot_capacity_curve(curves, length_unit="m")
    assert "[m]" in ax.get_xlabel() and "λ" in ax.get_ylabel()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == METHODS
    ax = plot_capacity_curve(curves["static-lp"], x="rotation")
    assert "[rad]" in ax.get_xlabel() and ax.get_legend().get_texts()[0].get_text() == "static-lp"
    collection = draw_configuration(block, curves["static-lp"], -1)
    assert len(collection.get_paths()) == 2
    animation = animate_pushover(block, curves["static-lp"])
    path = save_animation(animation, tmp_path / "a.gif")
    assert path.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    with pytest.raises(bm.OptionError, match="gif or .mp4"):
        save_animation(animation, tmp_path / "a.avi")
    with pytest.raises(bm.OptionError, match="not a curve from pushover"):
        plot_capacity_curve({"x": pd.DataFrame({"a": [1]})})


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"control": 0}, "control: block 0 is fixed (a support); give a free block"),
    ({"control": 7}, "control: block 7 does not exist (there are 2 blocks, 0 to 1)"),
    ({"control": (5.0, 5.0)}, "control: the point [5.0, 5.0] lies in no block"),
    ({"control": (0.5, -0.5)}, "lies in block 0, which is fixed (a support)"),
    ({"control": "top"}, "control: expected a block index or a point (x, y)"),
    ({"steps": 0}, "steps: must be an integer >= 1; got 0"),
    ({"steps": 2.5}, "steps: must be an integer >= 1"),
    ({"max_displacement": 0.0}, "max_displacement: must be a finite number > 0; got 0.0"),
    ({"max_displacement": -1.0}, "max_displacement: must be a finite number > 0"),
    ({"max_displacement": float("nan")}, "max_displacement: must be a finite number > 0"),
    ({"max_displacement": 10.0, "steps": 2}, "step: max_displacement / steps = 5 is larger than the structure"),
    ({"contact_tolerance": 0.0}, "contact_tolerance: must be a finite number > 0"),
    ({"options": {"nope": 1}}, "method 'static-lp' has no option 'nope'"),
])
def test_bad_input_is_one_clear_line(kwargs, message):
    with pytest.raises(bm.OptionError) as info:
        bm.pushover(bm.cases.single_block(1.0, 2.0), "static-lp", **{"max_displacement": 0.2, **kwargs})
    assert message in str(info.value) and "\n" not in str(info.value)


def test_an_unknown_method_is_named():
    with pytest.raises(bm.UnknownNameError, match="unknown method 'nope'"):
        bm.pushover(bm.cases.single_block(), "nope")


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "blockmpec.cli", "pushover", *args], capture_output=True,
                          text=True, timeout=300, cwd=cwd)


@pytest.mark.slow
def test_cli_writes_the_curve_and_its_figure(tmp_path):
    p = _cli("single-block", "--method", "static-lp,fixed-point", "--steps", "4", "--max-displacement", "0.2",
             "--out", str(tmp_path / "out"), "--length-unit", "m")
    assert p.returncode == 0, p.stderr
    table = pd.read_csv(tmp_path / "out" / "pushover.csv")
    assert list(table.columns[1: 1 + len(CURVE_COLUMNS)]) == list(CURVE_COLUMNS) and table.columns[0] == "method"
    assert table.groupby("method").size().to_dict() == {"fixed-point": 5, "static-lp": 5}
    assert (tmp_path / "out" / "capacity_curve.png").stat().st_size > 10000
    assert "stop: max_displacement reached" in p.stdout


def test_cli_in_process_writes_csv_figure_and_animation(tmp_path, capsys):
    from blockmpec.cli import main

    code = main(["pushover", "single-block", "--steps", "2", "--max-displacement", "0.1", "--out", str(tmp_path),
                 "-o", str(tmp_path / "curve.csv"), "--animation", str(tmp_path / "blocks.gif")])
    assert code == 0, capsys.readouterr().err
    assert len(pd.read_csv(tmp_path / "curve.csv")) == 3
    assert (tmp_path / "capacity_curve.png").exists() and (tmp_path / "blocks.gif").exists()


@pytest.mark.parametrize(("args", "message"), [
    (("--control", "0"), "control: block 0 is fixed"),
    (("--control", "9"), "control: block 9 does not exist"),
    (("--control", "a,b,c"), "--control a,b,c: expected a block index (3) or a point X,Y"),
    (("--steps", "0"), "steps: must be an integer >= 1"),
    (("--max-displacement", "-1"), "max_displacement: must be a finite number > 0"),
    (("--max-displacement", "50", "--steps", "2"), "is larger than the structure"),
    (("--animation", "x.avi"), "--animation x.avi: expected a file ending in .gif or .mp4"),
    (("--method", "nope"), "unknown method 'nope'"),
    (("-O", "milp.time_limit=1"), "-O milp.time_limit=1: no method 'milp' in this run"),
])
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, capsys, args, message):
    from blockmpec.cli import main

    code = main(["pushover", "single-block", *args, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("blockmpec: error: ") and message in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()
