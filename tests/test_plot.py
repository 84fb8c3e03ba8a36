"""Figures: the PNG files are written and the mechanism drawing is a rigid motion."""

from __future__ import annotations

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.bench.compare import compare
from blockmpec.bench.plots import (
    METHOD_STYLES,
    comparison_figures,
    convergence,
    displaced_polygons,
    error_vs_time,
    mechanisms,
    method_style,
)


def _png_ok(path):
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def test_comparison_figures_are_written(tmp_path):
    results: dict = {}
    df = compare({"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}, ["static-lp", "fixed-point", "milp"],
                 results=results, progress=False)
    paths = comparison_figures(df, results, tmp_path)
    names = {p.name for p in paths}
    assert names == {"error_vs_time.png", "performance_profile.png", "convergence_two-blocks.png",
                     "mechanism_two-blocks.png"}
    for p in paths:
        assert _png_ok(p), p


def test_figures_cope_with_exact_answers_missing_traces_and_failed_runs(tmp_path):
    import pandas as pd

    df = pd.DataFrame([
        {"case": "a", "method_label": "m1", "rel_error": 0.0, "solve_time_s": 1e-3, "verified": True},
        {"case": "a", "method_label": "m2", "rel_error": float("nan"), "solve_time_s": 0.1, "verified": False},
        {"case": "b", "method_label": "m2", "rel_error": 1e-3, "solve_time_s": 0.0, "verified": False},
    ])
    assert _png_ok(error_vs_time(df, tmp_path / "e.png"))
    assert _png_ok(convergence({"m1": []}, tmp_path / "c.png"))
    s = bm.cases.single_block()
    assert _png_ok(mechanisms(s, [("nothing", None)], tmp_path / "m.png"))


@pytest.mark.parametrize("case", ["two-blocks", "round-arch"])
def test_displaced_blocks_move_rigidly(case):
    s = bm.build_case(case)
    ops = bm.assemble(s)
    rng = np.random.default_rng(0)
    u = rng.normal(size=3 * ops.n_free_blocks)
    moved, scale = displaced_polygons(s, ops, u, amplitude=0.1)
    assert scale > 0 and set(moved) == set(int(j) for j in ops.free_blocks)
    for j, poly in moved.items():
        before = s.polygon(j)
        # rigid: all pairwise vertex distances are kept
        d0 = np.linalg.norm(before[:, None] - before[None], axis=-1)
        d1 = np.linalg.norm(poly[:, None] - poly[None], axis=-1)
        np.testing.assert_allclose(d1, d0, atol=1e-12 * d0.max())


def test_translation_is_scaled_to_the_requested_amplitude():
    s = bm.cases.two_blocks(eta=3.0)
    ops = bm.assemble(s)
    u = np.array([1.0, 0.0, 0.0, 0.5, 0.0, 0.0])  # both blocks slide, the first twice as far
    moved, scale = displaced_polygons(s, ops, u, amplitude=0.1)
    free = [int(j) for j in ops.free_blocks]
    size = np.ptp(np.vstack([s.polygon(j) for j in free]), axis=0).max()
    shift0 = moved[free[0]] - s.polygon(free[0])
    shift1 = moved[free[1]] - s.polygon(free[1])
    np.testing.assert_allclose(shift0, np.tile([0.1 * size, 0.0], (len(shift0), 1)), atol=1e-12)
    np.testing.assert_allclose(shift1, 0.5 * shift0, atol=1e-12)
    assert scale * ops.length_scale == pytest.approx(0.1 * size)


def test_every_method_has_one_fixed_style_in_every_figure():
    registered = bm.list_solvers()
    styles = {m: method_style(m) for m in registered}
    assert set(registered) <= set(METHOD_STYLES)  # every registered method has its own entry
    assert len(set(styles.values())) == len(styles)  # and no two share colour and marker
    assert len({c for c, _ in styles.values()}) == len(styles)  # nor a colour
    # a labelled variant keeps its method's colour; unknown methods get a style that does not change between runs
    assert method_style("fixed-point[relaxation=0.5]")[0] == METHOD_STYLES["fixed-point"][0]
    assert method_style("my-method") == method_style("my-method")


def test_figure_elements_that_reviewers_asked_for(tmp_path):
    """Separate associative/non-associative panels, convergence naming what it cannot show, mechanism legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    df = pd.DataFrame([
        {"case": "a", "method": "static-lp", "method_label": "static-lp", "problem": "associative",
         "rel_error": 0.0, "solve_time_s": 1e-3, "verified": True, "repetition": 0, "reference": 0.5},
        {"case": "a", "method": "milp", "method_label": "milp", "problem": "non-associative",
         "rel_error": 1e-3, "solve_time_s": 0.1, "verified": True, "repetition": 0, "reference": 0.4},
    ])
    trace = [{"iteration": 0, "time_s": 0.01, "bound": 0.1, "incumbent": None},
             {"iteration": 1, "time_s": 0.05, "bound": 0.39, "incumbent": 0.45, "gap_abs": 0.06},
             {"iteration": 2, "time_s": 0.1, "bound": 0.4, "incumbent": 0.4004, "gap_abs": 4e-4}]

    class _Res:
        pass

    res = _Res()
    res.trace = trace
    seen = {}
    orig = plt.Figure.savefig

    def spy(fig, *a, **k):
        seen.setdefault("figs", []).append(fig)
        return orig(fig, *a, **k)

    plt.Figure.savefig = spy
    try:
        assert _png_ok(error_vs_time(df, tmp_path / "e.png", results={("a", "milp", 0): (res, None)}))
        assert _png_ok(convergence({"milp": trace, "static-lp": []}, tmp_path / "c.png", without=["kinematic-lp"]))
        assert _png_ok(mechanisms(bm.cases.two_blocks(), [("x", np.ones(6))], tmp_path / "m.png"))
    finally:
        plt.Figure.savefig = orig
    e, c, m = seen["figs"]
    assert [ax.get_title() for ax in e.axes] == ["associative problem (LP (1)/(2))",
                                                "non-associative problem (MCP (3) / MPEC (4))"]
    assert len(e.axes[1].lines) >= 3  # the marker's reference line, the bound and the incumbent of the trace
    assert "no trace recorded (nothing to plot): kinematic-lp" in c.get_suptitle()
    texts = [t.get_text() for ax in c.axes for t in ax.texts]
    assert any("no such measure: milp" in t for t in texts)
    legend = [t.get_text() for t in m.legends[0].get_texts()]
    assert "undeformed" in legend and any("live load" in t for t in legend)
    panel_texts = [t.get_text() for t in m.axes[0].texts]
    assert any("amplitude" in t for t in panel_texts) and any("lambda f_l" in t for t in panel_texts)
    assert any(type(p).__name__ == "FancyArrowPatch" for p in m.axes[0].patches)
