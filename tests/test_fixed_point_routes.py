"""studies/fixed_point_routes.py's ``ties`` route: friction lowered at random per interface.

Lowering a friction coefficient keeps every statically admissible field admissible, so a solution of the
perturbed (3) violates the wall's own (3) only in the complementarity of the perturbed friction rows, by
about the perturbation.  The route measures its residuals on the wall itself; an unperturbed run must
match the interior engine's verified answer.
"""

from helpers import load_study


def test_ties_route_measures_perturbed_solutions_on_the_wall_itself(tmp_path, monkeypatch):
    routes = load_study("fixed_point_routes")
    monkeypatch.setattr(routes, "OUT", tmp_path)
    rows = routes.main(["ties", "--wall", "10x10", "--fold", "0.1", "--eps", "0,1e-6,1e-3"])
    plain, small, large = rows
    assert plain["status"] == "optimal" and plain["verified"]  # the wall itself: verified at 1e-8
    # a solution of the perturbed (3) is within about the perturbation of the wall's own (3)
    assert small["status"] == "optimal" and small["worst_value"] <= 1e-6
    assert large["worst_value"] > small["worst_value"]
