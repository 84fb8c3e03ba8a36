"""Figures: composable drawings (``ax=``), what they mark (hinges, sliding joints, new bests, bounds), the
collapse-multiplier map against the closed forms, and the comparator's PNG files."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import blockmpec as bm  # noqa: E402
from blockmpec.bench.compare import add_references, compare  # noqa: E402
from blockmpec.bench.plots import (  # noqa: E402
    METHOD_STYLES,
    comparison_figures,
    convergence,
    error_vs_time,
    mechanisms,
    method_style,
)
from blockmpec.plot import displaced_polygons, joints  # noqa: E402

TWO_BLOCKS = {"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _png_ok(path):
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def _frame(structure, motions):
    """A mechanism frame: block -> (u_x, u_y, rotation)."""
    return pd.DataFrame([{"block": b, "u_x": u[0], "u_y": u[1], "rotation": u[2]} for b, u in motions.items()])


def _rotation_about(structure, block, point, omega=1.0):
    """(u_x, u_y, theta) of ``block`` rotating at rate ``omega`` about ``point``: v(c) = omega k x (c - point)."""
    c = structure.centroid[block]
    return (-omega * (c[1] - point[1]), omega * (c[0] - point[0]), omega)


def _in_view(ax, x, y):
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    return min(x0, x1) <= x <= max(x0, x1) and min(y0, y1) <= y <= max(y0, y1)


# --------------------------------------------------------------------------- joints: hinges and sliding


def test_joints_of_rigid_motions_with_known_answers():
    s = bm.cases.single_block(width=1.0, height=2.0)  # block 1 on the fixed base block 0
    base = [k for k in range(len(s.interfaces.minus)) if {int(s.interfaces.minus[k]), int(s.interfaces.plus[k])} == {0, 1}]
    assert len(base) == 1
    k = base[0]
    start, end = np.asarray(s.interfaces.start[k]), np.asarray(s.interfaces.end[k])
    right = start if start[0] > end[0] else end
    # rocking about the right toe: a hinge there, no slip
    st = joints(_frame(s, {1: _rotation_about(s, 1, right, omega=-0.7)}), s).iloc[k]
    assert st["state"] == "hinge" and not st["sliding"] and abs(st["slip"]) < 1e-12
    assert st["hinge"] == ("start" if right is start else "end")
    np.testing.assert_allclose([st["hinge_x"], st["hinge_y"]], right, atol=1e-12)
    # sliding to the right: the slip is the translation along the tangent, the opening zero
    st = joints(_frame(s, {1: (0.3, 0.0, 0.0)}), s).iloc[k]
    tau = (end - start) / np.linalg.norm(end - start)
    sign = 1.0 if int(s.interfaces.plus[k]) == 1 else -1.0  # the plus block's motion relative to the minus block
    assert st["state"] == "sliding" and st["slip"] == pytest.approx(sign * 0.3 * tau[0], rel=1e-12)
    assert st["opening_start"] == pytest.approx(0.0, abs=1e-12) and st["opening_end"] == pytest.approx(0.0, abs=1e-12)
    # lifting off: opening at both ends
    st = joints(_frame(s, {1: (0.0, 0.2, 0.0)}), s).iloc[k]
    assert st["state"] == "opening" and st["opening_start"] == pytest.approx(0.2) and st["hinge"] == ""
    # no motion beyond the tolerance: at rest
    assert joints(_frame(s, {1: (1e-12, 0.0, 0.0)}), s, tol=1e-6).iloc[k]["state"] == "sliding"  # relative to itself
    assert joints(_frame(s, {1: (0.0, 0.0, 0.0)}), s).iloc[k]["state"] == "rest"


def test_joints_of_the_two_block_mechanisms():
    """Sect. 3 of the seed paper: the non-associative minimum for eta = 3, mu = 0.65 > 1/eta is the single rocking
    NA2 (both blocks rock on their right toes, the joint between them slides); for mu = 0.2 < 1/eta the sliding
    NA1 (both bases slide, the blocks move together)."""
    for mu, expect in ((0.65, "rocking"), (0.2, "sliding")):
        s = bm.cases.two_blocks(eta=3.0, mu=mu)
        res = bm.solve(s, "milp")
        assert res.success and res.multiplier == pytest.approx(min(mu, 1 / 3), rel=1e-7)
        st = joints(res, s)
        itf = s.interfaces
        kinds = {}
        for k in range(len(itf.minus)):
            pair = {int(itf.minus[k]), int(itf.plus[k])}
            kinds["shared" if not (pair & {int(j) for j in np.flatnonzero(s.fixed)}) else f"base{k}"] = st.iloc[k]
        bases = [v for key, v in kinds.items() if key.startswith("base")]
        assert len(bases) == 2
        if expect == "rocking":
            assert all(b["state"] == "hinge" for b in bases)
            assert all(b["hinge_x"] == pytest.approx(max(b_x for b_x in (itf.start[int(b["interface"])][0],
                                                                      itf.end[int(b["interface"])][0]))) for b in bases)
            assert kinds["shared"]["state"] == "sliding"
        else:
            assert all(b["state"] == "sliding" for b in bases)
            assert kinds["shared"]["state"] == "rest"


@pytest.mark.parametrize("case", ["two-blocks", "round-arch"])
def test_displaced_blocks_move_rigidly(case):
    s = bm.build_case(case)
    free = [i for i in range(s.n_blocks) if not s.fixed[i]]
    rng = np.random.default_rng(0)
    frame = _frame(s, {i: tuple(rng.normal(size=3)) for i in free})
    moved, scale = displaced_polygons(s, frame, amplitude=0.1)
    assert scale > 0 and set(moved) == set(free)
    for j, poly in moved.items():
        before = s.polygon(j)
        d0 = np.linalg.norm(before[:, None] - before[None], axis=-1)
        d1 = np.linalg.norm(poly[:, None] - poly[None], axis=-1)
        np.testing.assert_allclose(d1, d0, atol=1e-12 * d0.max())  # rigid: pairwise distances kept


def test_translation_is_scaled_to_the_requested_amplitude():
    s = bm.cases.two_blocks(eta=3.0)
    free = [i for i in range(s.n_blocks) if not s.fixed[i]]
    moved, scale = displaced_polygons(s, _frame(s, {free[0]: (1.0, 0.0, 0.0), free[1]: (0.5, 0.0, 0.0)}),
                                      amplitude=0.1)
    size = np.ptp(np.vstack([s.polygon(j) for j in free]), axis=0).max()
    shift0, shift1 = moved[free[0]] - s.polygon(free[0]), moved[free[1]] - s.polygon(free[1])
    np.testing.assert_allclose(shift0, np.tile([0.1 * size, 0.0], (len(shift0), 1)), atol=1e-12)
    np.testing.assert_allclose(shift1, 0.5 * shift0, atol=1e-12)
    assert scale == pytest.approx(0.1 * size)


# --------------------------------------------------------------------------- composable drawings


def test_mechanism_draws_into_the_given_axes_and_marks_hinges_and_sliding_joints():
    s = bm.cases.two_blocks(eta=3.0, mu=0.65)
    res = bm.solve(s, "milp")
    fig, (ax0, ax) = plt.subplots(1, 2)
    out = bm.plot.mechanism(res, s, ax=ax)
    assert out is ax and not ax0.patches  # nothing outside the axes given
    st = joints(res, s)
    hinges = [line for line in ax.lines if line.get_marker() == "o"]
    sliding = [line for line in ax.lines if line.get_linewidth() > 2]
    assert len(hinges) == (st["hinge"] != "").sum() == 2
    assert len(sliding) == st["sliding"].sum() == 1
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "hinge: relative rotation centre" in labels and "sliding joint: relative tangential motion" in labels
    assert "amplitude" not in " ".join(t.get_text() for t in ax.texts)  # the amplitude is stated in the legend
    assert "12%" in ax.get_legend().get_title().get_text()
    assert "1/3" not in ax.get_title() and "0.333333" in ax.get_title()
    # every legend entry is drawn: a sliding-only mechanism has no hinge entry
    s2 = bm.cases.two_blocks(eta=3.0, mu=0.2)
    ax2 = bm.plot.mechanism(bm.solve(s2, "milp"), s2)
    labels = [t.get_text() for t in ax2.get_legend().get_texts()]
    assert "hinge: relative rotation centre" not in labels and "sliding joint: relative tangential motion" in labels
    # no mechanism: the structure alone, said so
    ax3 = bm.plot.mechanism(pd.DataFrame(columns=["block", "u_x", "u_y", "rotation"]), s2)
    assert any("no mechanism" in t.get_text() for t in ax3.texts)


def test_convergence_panels_keep_every_legend_entry_in_view():
    trace = [{"iteration": 0, "time_s": 0.01, "bound": -1e-8, "incumbent": None},
             {"iteration": 1, "time_s": 0.05, "bound": 0.39, "incumbent": 0.45},
             {"iteration": 2, "time_s": 0.1, "bound": 0.4, "incumbent": 0.4004}]
    fp = [{"iteration": i, "time_s": 0.001 * i, "multiplier": 0.40 + 0.01 / i, "n_change": 10.0 ** -i,
           "lp_iterations": 3} for i in range(1, 6)]
    lp = bm.solve(bm.cases.two_blocks(), "static-lp")  # no trace: drawn as the point of its answer
    ax = bm.plot.convergence({"milp": trace, "fixed-point": fp, "static-lp": lp})
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["milp", "fixed-point", "static-lp (no trace: answer)", "milp: lower bound"]
    for line in ax.lines:  # every point drawn is inside the view: nothing in the legend is off the axes
        for x, y in zip(*line.get_data()):
            assert _in_view(ax, x, y), (line.get_label(), x, y)
    assert not ax.convergence_missing
    # the first bound (-1e-8, the LP relaxation) is left out, the others drawn
    bound = [line for line in ax.lines if line.get_linestyle() == "--"]
    assert len(bound) == 1 and list(bound[0].get_ydata()) == [0.39, 0.4]
    # a bound that never comes near the answers is left out, and said so
    far = [dict(r, bound=0.0 if r["bound"] > 0 else r["bound"]) for r in trace]
    ax = bm.plot.convergence({"milp": far, "fixed-point": fp})
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["milp", "fixed-point"]
    assert ax.convergence_missing == [("milp's lower bound", "stayed below 0.2002, far below the answers")]
    ax = bm.plot.convergence({"milp": trace, "fixed-point": fp, "static-lp": lp}, y="n_change", x="lp_step")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["fixed-point"]
    assert dict(ax.convergence_missing) == {"milp": "its iterations are not LP steps", "static-lp": "no trace"}
    assert ax.get_yscale() == "log" and "LP step" in ax.get_xlabel()
    with pytest.raises(ValueError, match="y must be one of"):
        bm.plot.convergence({}, y="nope")


def test_error_vs_time_into_the_researchers_axes_marks_new_bests():
    df = add_references(pd.DataFrame([
        {"case": "c", "problem": "non-associative", "method": m, "method_label": m, "multiplier": lam,
         "verified": True, "certified": False, "closed_form": None, "solve_time_s": t, "repetition": 0}
        for m, lam, t in (("fixed-point", 0.5061, 0.1), ("nlp", 0.505299, 9.7), ("milp", 0.505815, 60.0))]))
    fig, ax = plt.subplots()
    assert error_vs_time(df, ax=ax) is ax
    arrows = [line for line in ax.lines if line.get_marker() == r"$\downarrow$"]
    assert len(arrows) == 1 and arrows[0].get_ydata()[0] == pytest.approx(abs(df["rel_error"].iloc[1]))
    legend = {t.get_text() for t in ax.get_legend().get_texts()}
    assert legend == {"fixed-point", "nlp", "milp", "new best (below the reference)"}  # nothing not drawn
    mixed = pd.concat([df, df.assign(problem="associative")])
    with pytest.raises(ValueError, match="never mixed"):
        error_vs_time(mixed, ax=ax)
    fig = error_vs_time(mixed)
    assert [a.get_title() for a in fig.axes if a.get_title()] == ["associative problem (LP (1)/(2))",
                                                                 "non-associative problem (MCP (3) / MPEC (4))"]


def test_performance_profile_into_the_given_axes():
    from blockmpec.bench.plots import performance_profile

    df = pd.DataFrame([
        {"case": c, "problem": "non-associative", "method": m, "method_label": m, "multiplier": 0.5,
         "verified": True, "reference": 0.5, "reference_source": "certified", "solve_time_s": t,
         "wall_limit_s": 100.0, "repetition": 0}
        for c, m, t in (("p1", "A", 1.0), ("p1", "B", 2.0), ("p2", "A", 4.0), ("p2", "B", 1.0))])
    fig, ax = plt.subplots()
    assert performance_profile(df, ax=ax) is ax
    steps = {line.get_label(): line for line in ax.lines}
    assert set(steps) == {"A", "B"}
    x, y = steps["A"].get_data()
    assert y[0] == pytest.approx(0.5) and y[-1] == pytest.approx(1.0)  # fastest on one case of two, solves both


def test_multiplier_map_is_the_closed_form_and_splits_the_mechanisms():
    """The seed's Sect. 3 over (eta, mu): static-lp gives the associative closed form at every point, milp the
    non-associative minimum mu (sliding, mu < 1/eta) or 1/eta (rocking), and the mechanism classes split
    exactly on mu = 1/eta."""
    etas, mus = [1.5, 2.5, 4.0], [0.2, 0.5, 0.9]
    data, ax = bm.plot.multiplier_map("two-blocks", x=("eta", etas), y=("mu", mus), method="static-lp")
    assert list(data.columns[:3]) == ["eta", "mu", "multiplier"] and len(data) == 9
    for _, r in data.iterrows():
        assert r["multiplier"] == pytest.approx(bm.cases.closed_form("two-blocks", "associative", eta=r["eta"],
                                                                     mu=r["mu"]), rel=1e-7)
    assert ax.get_xlabel() == "eta" and ax.get_ylabel() == "mu" and len(ax.figure.axes) == 2  # map + colour bar
    fig, ax = plt.subplots()
    result = bm.plot.multiplier_map("two-blocks", x=("eta", etas), y=("mu", mus), method="milp", show="mechanism",
                                    ax=ax)
    assert result.ax is ax and result.fig is fig
    data = result.data
    np.testing.assert_allclose(data["multiplier"], [min(mu, 1 / eta) for mu, eta in zip(data["mu"], data["eta"])],
                               rtol=1e-7)
    sliding = data["mu"] < 1 / data["eta"]
    assert data.loc[sliding, "mechanism"].nunique() == 1 and data.loc[~sliding, "mechanism"].nunique() == 1
    assert set(data.loc[sliding, "mechanism"]) != set(data.loc[~sliding, "mechanism"])
    assert "slide" in data.loc[sliding, "mechanism_name"].iloc[0]
    assert "hinge" in data.loc[~sliding, "mechanism_name"].iloc[0]
    assert len(ax.get_legend().get_texts()) == 2
    with pytest.raises(bm.OptionError):
        bm.plot.multiplier_map("two-blocks", x=("eta", etas), y=("mu", mus), options={"time_limit": "abc"})


def test_multiplier_map_of_a_users_structure_function():
    def block(width, height):
        return bm.cases.single_block(width=width, height=height, mu=0.65)

    data, _ = bm.plot.multiplier_map(block, x=("width", [1.0, 2.0]), y=("height", [4.0, 8.0]))
    np.testing.assert_allclose(data["multiplier"], [min(0.65, w / h) for w, h in zip(data["width"], data["height"])],
                               rtol=1e-8)


# --------------------------------------------------------------------------- the comparator's PNG files


def test_every_method_has_one_fixed_style_in_every_figure():
    registered = bm.list_solvers()
    styles = {m: method_style(m) for m in registered}
    assert set(registered) <= set(METHOD_STYLES)  # every registered method has its own entry
    assert len(set(styles.values())) == len(styles)  # and no two share colour and marker
    assert len({c for c, _ in styles.values()}) == len(styles)  # nor a colour
    assert method_style("fixed-point[relaxation=0.5]")[0] == METHOD_STYLES["fixed-point"][0]
    assert method_style("my-method") == method_style("my-method")


def test_figures_cope_with_exact_answers_missing_traces_and_failed_runs(tmp_path):
    df = pd.DataFrame([
        {"case": "a", "method_label": "m1", "rel_error": 0.0, "solve_time_s": 1e-3, "verified": True},
        {"case": "a", "method_label": "m2", "rel_error": float("nan"), "solve_time_s": 0.1, "verified": False},
        {"case": "b", "method_label": "m2", "rel_error": 1e-3, "solve_time_s": 0.0, "verified": False},
    ])
    assert _png_ok(error_vs_time(df, tmp_path / "e.png"))
    assert _png_ok(convergence({"m1": []}, tmp_path / "c.png"))
    assert _png_ok(mechanisms(bm.cases.single_block(), [("nothing", None)], tmp_path / "m.png"))


def test_comparator_figures_put_notes_and_legends_outside_the_panels(tmp_path):
    s = bm.cases.two_blocks()
    res = {m: bm.solve(s, m) for m in ("static-lp", "fixed-point", "milp")}
    fig = convergence(res, title="t", without=["kinematic-lp"], methods={m: m for m in res})
    panels = [a for a in fig.axes if a.axison]
    assert len(panels) == 3
    for ax in panels:  # no note inside a panel, and every line drawn lies within the panel's view
        assert not ax.texts and ax.get_legend() is None
        for line in ax.lines:
            for x, y in zip(*line.get_data()):
                assert _in_view(ax, x, y), (line.get_label(), x, y)
    notes = " ".join(t.get_text() for a in fig.axes if not a.axison for t in a.texts)
    assert "nothing to draw (no trace, no multiplier): kinematic-lp" in notes
    assert "static-lp (no trace)" in notes  # not in the n_change panels, and said so
    legend = [t.get_text() for a in fig.axes if a.get_legend() for t in a.get_legend().get_texts()]
    assert "static-lp (no trace: answer)" in legend and "fixed-point" in legend
    fig = mechanisms(s, [("associative", res["static-lp"]), ("non-associative", res["milp"]),
                         ("internal u", res["fixed-point"].solution.u)])
    assert len(fig.legends) == 1 and all(a.get_legend() is None for a in fig.axes)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "hinge: relative rotation centre" in labels and "sliding joint: relative tangential motion" in labels


@pytest.mark.slow
def test_comparison_figures_are_written(tmp_path):
    results: dict = {}
    df = compare(TWO_BLOCKS, ["static-lp", "fixed-point", "milp"], results=results, progress=False, isolate=False)
    paths = comparison_figures(df, results, tmp_path)
    assert {p.name for p in paths} == {"error_vs_time.png", "performance_profile.png", "convergence_two-blocks.png",
                                       "mechanism_two-blocks.png"}
    for p in paths:
        assert _png_ok(p), p
    assert not plt.get_fignums()  # the PNG writers leave no pyplot figure behind
    assert math.isfinite(df["budget_s"].iloc[0])
