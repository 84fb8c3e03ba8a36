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


def test_hybrid_route_ends_on_a_solution_of_the_walls_own_mcp(tmp_path, monkeypatch):
    """The hybrid problem keeps the dilatancy gap only on a set S; where an interface outside S slides, its flow is
    associative, so the wall's own (3) fails there.  The route grows S until nothing slides outside it: that answer
    must solve the wall's (3) at 1e-8, and (Radenkovic) lie at or below the associative multiplier."""
    routes = load_study("fixed_point_routes")
    monkeypatch.setattr(routes, "OUT", tmp_path)
    associative, *rounds = routes.main(["hybrid", "--wall", "10x10", "--share", "0.1"])
    first, last = rounds[0], rounds[-1]
    assert first["sliding_outside"] > 0 and not first["verified"]  # S too small: associative sliding outside it
    assert last["sliding_outside"] == 0 and last["status"] == "optimal" and last["verified"]
    assert last["multiplier"] <= associative["multiplier"] + 1e-9
