"""The paper's two-block problem over the (eta, mu) plane (Sect. 3, Figs 5-6), by the public API.

Panels (a) associative (``static-lp``), (b) certified non-associative minimum (``milp``) and (c) certified
non-associative maximum (``milp``, ``sense="max"``).  The closed forms: associative ``lam`` by
:func:`blockmpec.cases.closed_form`; the non-associative minimum ``mu`` (sliding) if ``mu <= 1/eta`` else ``1/eta``
(rocking); the maximum equals the associative multiplier, reached by the non-dilatant counterpart of the
associative mechanism (sliding where the associative mechanism slides).  Mechanisms are read from
``res.mechanism`` (a rotation or none).  The finer classes of the figures (A2-1, A2-2, A3 and their counterparts)
are the study's: ``studies/paper/two_block_maps.py --check`` asserts them (run by ``.ci/run``).
"""

from __future__ import annotations

import numpy as np
import pytest
from references import TWO_BLOCKS_ASSOCIATIVE

import blockmpec as bm

#: a 6 x 6 grid that crosses every boundary of the paper's mechanism regions, plus its example point (3, 0.65)
ETAS = list(np.linspace(1.1, 5.6, 6)) + [3.0]
MUS = list(np.linspace(0.15, 1.4, 6)) + [0.65]
#: a rotation below this share of the largest velocity (rotations times the structure's height) is none
ROTATION_TOL = 1e-6


def _rotates(res: bm.Result, structure: bm.Structure) -> bool:
    """True when the mechanism of ``res`` turns a block (no pure sliding)."""
    mech = res.mechanism
    height = float(np.ptp(structure.vertices[..., 1]))
    turn = np.abs(mech["rotation"].to_numpy()).max() * height
    scale = max(np.abs(mech[["u_x", "u_y"]].to_numpy()).max(), turn)
    return turn > ROTATION_TOL * scale


def _point(eta: float, mu: float) -> dict:
    structure = bm.cases.two_blocks(eta=eta, mu=mu)
    ops = bm.assemble(structure)
    row = {"eta": eta, "mu": mu, "structure": structure,
           "associative": bm.solve(ops, "static-lp"),
           "na_min": bm.solve(ops, "milp"),
           "na_max": bm.solve(ops, "milp", sense="max"),
           "closed_form_associative": bm.cases.closed_form("two-blocks", "associative", eta=eta, mu=mu)}
    return row


@pytest.fixture(scope="module")
def grid() -> list[dict]:
    if "milp" not in bm.list_solvers():
        pytest.skip("milp method not registered")
    return [_point(float(eta), float(mu)) for eta in ETAS for mu in MUS]


def _away_from_boundaries(row) -> bool:
    """The associative closed form holds there and its sliding value ``mu`` is not within 1 % of the least of the
    others (so the mechanism is not a tie)."""
    eta, mu, lam = row["eta"], row["mu"], row["closed_form_associative"]
    if lam is None:
        return False
    others = [2.0 / eta]
    if eta * (1 - mu**2) + mu > 0:
        others.append(1.0 / (eta * (1 - mu**2) + mu))
    if eta * (1 + mu**2) - mu > 0:
        others.append((1 + 2 * mu**2) / (eta * (1 + mu**2) - mu))
    return abs(mu - min(others)) > 0.01 * min(mu, min(others))


@pytest.mark.slow
def test_non_associative_minimum_slides_iff_mu_below_one_over_eta(grid):
    certified = [r for r in grid if r["na_min"].status is bm.Status.OPTIMAL]
    assert len(certified) > 0.9 * len(grid), [(r["eta"], r["mu"]) for r in grid if r not in certified]
    for r in certified:
        assert r["na_min"].verified
        # the closed form (paper Sect. 3), certified by milp: 3.3e-13 at most measured over the 49 points
        assert r["na_min"].multiplier == pytest.approx(min(r["mu"], 1 / r["eta"]), rel=1e-9), (r["eta"], r["mu"])
        if abs(r["mu"] - 1 / r["eta"]) > 1e-6:
            assert _rotates(r["na_min"], r["structure"]) == (r["mu"] > 1 / r["eta"]), (r["eta"], r["mu"])


@pytest.mark.slow
def test_associative_multipliers_follow_the_closed_forms(grid):
    known = [r for r in grid if r["closed_form_associative"] is not None]
    assert len(known) > 25
    for r in known:
        assert r["associative"].status is bm.Status.OPTIMAL and r["associative"].verified
        assert r["associative"].multiplier == pytest.approx(r["closed_form_associative"], rel=1e-9)  # 1.5e-13
    # sliding (A1) exactly where the closed form's least multiplier is mu
    clear = [r for r in known if _away_from_boundaries(r)]
    assert len(clear) > 25
    assert {_rotates(r["associative"], r["structure"]) for r in clear} == {True, False}
    for r in clear:
        slides = r["closed_form_associative"] == pytest.approx(r["mu"], rel=1e-12)
        assert _rotates(r["associative"], r["structure"]) != slides, (r["eta"], r["mu"])


def test_paper_example_point():
    r = _point(3.0, 0.65)
    # paper Sect. 3: A2-1, 1/2.3825 (printed 0.41973): 0 measured
    assert r["associative"].multiplier == pytest.approx(TWO_BLOCKS_ASSOCIATIVE, rel=1e-12)
    assert _rotates(r["associative"], r["structure"])
    assert r["na_min"].status is bm.Status.OPTIMAL
    assert r["na_min"].multiplier == pytest.approx(1 / 3, rel=1e-12) and _rotates(r["na_min"], r["structure"])  # NA2


@pytest.mark.slow
def test_non_associative_maximum_is_the_associative_closed_form(grid):
    """Paper Fig. 6c = Fig. 6a: the certified maximum equals the associative closed form, never below the minimum,
    and its mechanism slides where the associative one does (NA1 where A1; a rotation elsewhere)."""
    assert all(r["na_max"].status is bm.Status.OPTIMAL for r in grid), [
        (r["eta"], r["mu"], r["na_max"].status.value) for r in grid if r["na_max"].status is not bm.Status.OPTIMAL]
    known = [r for r in grid if r["closed_form_associative"] is not None]
    assert len(known) > 25
    for r in known:
        assert r["na_max"].multiplier == pytest.approx(r["closed_form_associative"], rel=1e-9)  # 1.5e-13 measured
    for r in grid:
        assert r["na_max"].multiplier == pytest.approx(r["associative"].multiplier, rel=1e-9)  # 2.2e-16 measured
        assert r["na_max"].multiplier >= r["na_min"].multiplier - 1e-9
    for r in (r for r in known if _away_from_boundaries(r)):
        assert _rotates(r["na_max"], r["structure"]) == _rotates(r["associative"], r["structure"]), (r["eta"], r["mu"])
