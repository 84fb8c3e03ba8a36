"""Figures: the PNG files are written and the mechanism drawing is a rigid motion."""

from __future__ import annotations

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.compare import compare
from blockmpec.plot import comparison_figures, convergence, displaced_polygons, error_vs_time, mechanisms


def _png_ok(path):
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"


def test_comparison_figures_are_written(tmp_path):
    results: dict = {}
    df = compare({"two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65})}, ["static-lp", "fixed-point", "slp"],
                 results=results)
    paths = comparison_figures(df, results, tmp_path)
    names = {p.name for p in paths}
    assert names == {"error_vs_time.png", "convergence_two-blocks.png", "mechanism_two-blocks.png"}
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
