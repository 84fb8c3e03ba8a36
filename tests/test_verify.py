"""The shared verifier: each of its nine residuals flags the condition of (3) it measures.

For each residual a test starts from an exact solution of (3) (every residual at round-off, ``lam`` at its closed
form), violates exactly the condition that residual measures, and asserts that

* that residual flags it (at least :data:`FLAGGED`, 1e4 times ``solve``'s default ``verify_tol``),
* every residual of the other conditions stays at round-off (:data:`ROUND_OFF`), and
* :func:`blockmpec.run_solver` downgrades the point's claimed success (a dummy method that returns it,
  :class:`ReturnsPoint`) to ``numerical``, naming the residual.

The two admissibility conditions of (3) each have two measures, the paper's global one and the per-interface
``local_admissibility``: a violation of ``N_u^T x <= 0`` or ``N_f^T x <= 0`` raises both, except at a light
interface, where only the local one sees it (its own test).  Forces are changed only by a self-stress
(``E dx = 0``), multipliers and velocities only where the flow rule is unchanged (``N_u dz_u + V_f dz_f = -E^T du``),
so that equilibrium and compatibility stay exact.

The mutation check (tests/README.md): ``python -m pytest --zero-residual NAME`` runs the suite with that residual
always 0; each test below then fails, and ``studies/lab/verifier_mutation.py`` reports it for every residual.
"""

import numpy as np
import pytest
import scipy.linalg

import blockmpec as bm
from blockmpec.result import RunOutput, Solution, Status
from blockmpec.solver import SolverBase
from blockmpec.verify import RESIDUAL_NAMES, positive_part_ratio, residuals

#: the exact points below have residuals of at most 2e-16 (measured); a residual of another condition stays below this
ROUND_OFF = 1e-14
#: each violation below raises its residual to 0.016 .. 1 (measured): at least this, 1e4 x the default verify_tol
FLAGGED = 1e-2


class ReturnsPoint(SolverBase):
    """A method (not registered) that returns the point it was made with as a converged solution of (3): how a test
    hands :func:`blockmpec.run_solver` a point of its own making, to see the shared verifier judge it."""

    name = "test-returns-point"
    problem = "non-associative"
    summary = "returns a given point"

    def __init__(self, point: Solution) -> None:
        super().__init__()
        self.point = point

    def run(self, deadline):
        return RunOutput(Status.CONVERGED, self.point, message="the test's point")


def exact_point(structure: bm.Structure, closed_form: float):
    """``(ops, solution)``: the certified minimum of (4) (``milp``), checked to be an exact solution of (3) at the
    closed-form ``lam``, independently of the method's claims."""
    ops = bm.assemble(structure)
    point = bm.solve(ops, "milp").solution
    assert point.multiplier == pytest.approx(closed_form, abs=1e-15)
    assert max(residuals(ops, point, associative=False).values()) <= ROUND_OFF
    return ops, point


def changed(point: Solution, **fields) -> Solution:
    return Solution(**{**vars(point), **fields})


def self_stress(ops, component: int) -> np.ndarray:
    """A unit self-stress ``dx`` (``E dx = 0``) in one force component (0 shear, 1 normal, 2 moment) of the
    interfaces, when those columns of ``E`` have a one-dimensional null space."""
    columns = 3 * np.arange(ops.n_interfaces) + component
    null = scipy.linalg.null_space(ops.E.toarray()[:, columns])
    assert null.shape[1] == 1, null.shape
    dx = np.zeros(3 * ops.n_interfaces)
    dx[columns] = null[:, 0]
    assert np.abs(ops.E @ dx).max() <= 1e-15
    return dx


def bridge(height: float, scale: float = 1.0, at=(0.0, 0.0)) -> list[np.ndarray]:
    """A ``3 x height`` block on two fixed ``1 x 1`` pedestals 1 apart (polygons, times ``scale``, moved to ``at``):
    its two collinear joints make a self-stress of opposite shears, and one of opposite moments."""
    polygons = [[[0, -1], [1, -1], [1, 0], [0, 0]], [[2, -1], [3, -1], [3, 0], [2, 0]],
                [[0, 0], [3, 0], [3, height], [0, height]]]
    return [np.array(p, float) * scale + at for p in polygons]


# ------------------------------------------------------------------ exact solutions of (3)


@pytest.fixture(scope="module")
def single_block():
    """A 1 x 2 block on a base, mu = 0.65: it rocks about its toe at lam = b/h = 1/2 (closed form, cases.py)."""
    return exact_point(bm.cases.single_block(), bm.cases.closed_form("single-block", "non-associative"))


@pytest.fixture(scope="module")
def two_blocks():
    """The paper's two blocks at eta = 3, mu = 0.65: the minimum 1/eta (Sect. 3, NA2); the blocks rock together and
    their common joint carries no force while its friction multiplier is 1/3 (it slides open)."""
    return exact_point(bm.cases.two_blocks(eta=3, mu=0.65), 1 / 3)


@pytest.fixture(scope="module")
def sliding_bridge():
    """The bridge of height 1 with mu = 0.2 slides on both pedestals at lam = mu (it would rock at 3/h = 3):
    no unilateral multiplier."""
    ops, point = exact_point(bm.make_structure(bridge(1.0), [True, True, False], friction=0.2), 0.2)
    assert not point.z_u.any()
    return ops, point


@pytest.fixture(scope="module")
def rocking_bridge():
    """The bridge of height 6 with mu = 0.65 rocks about its outer toe at lam = 3/h = 1/2 (below mu): no friction
    multiplier."""
    ops, point = exact_point(bm.make_structure(bridge(6.0), [True, True, False], friction=0.65), 0.5)
    assert not point.z_f.any()
    return ops, point


@pytest.fixture(scope="module")
def tiny_bridge_beside_a_block():
    """A 1 x 2 block on a base (it rocks at lam = 1/2) and, beside it, a bridge 1e-4 times smaller on its own
    pedestals (it would slide at mu = 0.65): the bridge stays at rest, its loads 1e-8 of the block's."""
    polygons = [np.array([[-3.0, -1], [3, -1], [3, 0], [-3, 0]]), np.array([[-2.0, 0], [-1, 0], [-1, 2], [-2, 2]]),
                *bridge(1.0, scale=1e-4, at=(1.0, 1e-4))]
    ops, point = exact_point(bm.make_structure(polygons, [True, False, True, True, False], friction=0.65), 0.5)
    return ops, point


# ------------------------------------------------------------------ one violation per residual


def violate_equilibrium(cases):
    ops, p = cases("single_block")
    return ops, changed(p, multiplier=p.multiplier + 0.05), {"equilibrium"}


def violate_compatibility(cases):
    ops, p = cases("single_block")
    du = np.zeros_like(p.u)
    du[2] = 0.1  # a rotation: no work of the live load (applied at the centroid), so f_l^T u stays 1
    assert ops.f_l @ du == 0
    return ops, changed(p, u=p.u + du), {"compatibility"}


def violate_normalisation(cases):
    ops, p = cases("single_block")  # the whole flow doubled: compatible, complementary, f_l^T u = 2
    return ops, changed(p, u=2 * p.u, z_u=2 * p.z_u, z_f=2 * p.z_f), {"normalisation"}


def violate_unilateral_admissibility(cases):
    ops, p = cases("sliding_bridge")  # opposite moments on the two joints: each resultant leaves its joint
    dx = self_stress(ops, 2)
    # on every joint the moment change exceeds 1.5 (|m| + |n| L / 2), whatever moments the exact point carries
    # (the solution of (3) is not unique in them): |m + a dm| >= a |dm| - |m| > |n| L / 2
    m, n, dm = p.x[2::3], p.x[1::3], dx[2::3]
    moved = dm != 0
    a = 1.5 * float(np.max((np.abs(m) + np.abs(n) * ops.length / 2)[moved] / np.abs(dm[moved])))
    return ops, changed(p, x=p.x + a * dx), {"unilateral_admissibility", "local_admissibility"}


def violate_friction_admissibility(cases):
    ops, p = cases("rocking_bridge")  # opposite shears: beyond mu |n| on the joint the bridge lifts off
    return ops, changed(p, x=p.x + 0.1 * self_stress(ops, 0)), {"friction_admissibility", "local_admissibility"}


def violate_local_admissibility(cases):
    """Opposite shears on the tiny bridge's joints, three times their normal force: beyond mu |n| there, and 1e-8 of
    the slacks of the whole structure, which the paper's global measure reads (1.3e-8, below verify_tol)."""
    ops, p = cases("tiny_bridge_beside_a_block")
    dx = self_stress(ops, 0)
    k = int(np.flatnonzero(dx)[0]) // 3
    # the global measure of the same condition stays below verify_tol (1.3e-8 measured), not at round-off
    return ops, changed(p, x=p.x + 3 * abs(p.x[3 * k + 1]) * dx), {"local_admissibility"}, {"friction_admissibility": 1e-7}


def violate_multiplier_sign(cases):
    """The joint between the two blocks carries no force: lowering both its friction multipliers by 1/2 (one becomes
    -1/2, the other -1/6) leaves the flow V_f z_f unchanged (psi = 0: the pair enters only as z+ - z-) and the works
    zero."""
    ops, p = cases("two_blocks")
    k = next(k for k in range(ops.n_interfaces) if not p.x[3 * k:3 * k + 3].any())
    dz = np.zeros_like(p.z_f)
    dz[2 * k:2 * k + 2] = -0.5
    assert not (ops.V_f @ dz).any()
    return ops, changed(p, z_f=p.z_f + dz), {"multiplier_sign"}


def violate_unilateral_complementarity(cases):
    """Both unilateral multipliers of the block's joint raised by 1/2: a lift, compensated by lifting the block
    (``E^T du = -N_u dz_u``, no work of the horizontal live load); the heel's row is slack, so its work is not 0."""
    ops, p = cases("single_block")
    dz = np.full_like(p.z_u, 0.5)
    du = np.linalg.solve(ops.E.toarray().T, -(ops.N_u @ dz))
    assert abs(ops.f_l @ du) <= 1e-15
    return ops, changed(p, u=p.u + du, z_u=p.z_u + dz), {"unilateral_complementarity"}


def violate_friction_complementarity(cases):
    """Both friction multipliers of the block's joint raised by 1/2: with psi = 0 the pair's flow z+ - z- does not
    change, but neither friction row is active (the block rocks), so their works are not 0."""
    ops, p = cases("single_block")
    dz = np.full_like(p.z_f, 0.5)
    assert not (ops.V_f @ dz).any()
    return ops, changed(p, z_f=p.z_f + dz), {"friction_complementarity"}


VIOLATIONS = {name: globals()[f"violate_{name}"] for name in RESIDUAL_NAMES}


@pytest.fixture
def cases(request):
    return lambda name: request.getfixturevalue(name)


@pytest.mark.parametrize("name", RESIDUAL_NAMES)
def test_each_residual_flags_exactly_its_violation_and_solve_downgrades(name, cases):
    ops, point, measures, *below = VIOLATIONS[name](cases)
    bounds = below[0] if below else {}
    res = residuals(ops, point, associative=False)
    assert res.keys() == set(RESIDUAL_NAMES)
    for measure in measures:
        assert res[measure] >= FLAGGED, (measure, res)
    for other in set(res) - measures:
        assert res[other] <= bounds.get(other, ROUND_OFF), (other, res)
    result = bm.run_solver(ReturnsPoint(point), ops)
    assert result.status is Status.NUMERICAL and not result.verified and not result.success
    worst = max(measures, key=res.get)
    assert f"verifier disagrees: {worst} residual" in result.message, result.message


@pytest.mark.parametrize("name", ["single_block", "two_blocks", "sliding_bridge", "rocking_bridge",
                                  "tiny_bridge_beside_a_block"])
def test_the_exact_points_are_verified(name, cases):
    """The control: unchanged, each starting point keeps its claimed success."""
    ops, point = cases(name)
    result = bm.run_solver(ReturnsPoint(point), ops)
    assert result.status is Status.CONVERGED and result.success and result.multiplier == point.multiplier
    assert result.max_residual <= ROUND_OFF


def test_a_violation_just_below_verify_tol_passes_and_just_above_fails(cases):
    """The tolerance is the one given: lam moved so that equilibrium's residual is 0.5 and 2 times verify_tol."""
    ops, p = cases("single_block")
    unit = residuals(ops, changed(p, multiplier=p.multiplier + 1e-3), associative=False)["equilibrium"] / 1e-3
    for factor, verified in ((0.5, True), (2.0, False)):
        moved = changed(p, multiplier=p.multiplier + factor * 1e-6 / unit)
        result = bm.run_solver(ReturnsPoint(moved), ops, verify_tol=1e-6)
        assert result.verified is verified and result.success is verified


def test_exact_lp_solution_has_round_off_residuals():
    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.65))
    sol = bm.solve(ops, "static-lp").solution
    assert max(residuals(ops, sol, associative=True).values()) < 1e-15  # 7e-17 measured


def test_associative_mechanism_fails_non_associative_compatibility():
    # at eta=3, mu=0.65 the associative mechanism (A2-1) dilates by friction: with psi = 0 flow it is incompatible
    ops = bm.assemble(bm.cases.two_blocks(eta=3, mu=0.65))
    sol = bm.solve(ops, "static-lp").solution
    assert residuals(ops, sol, associative=True)["compatibility"] < 1e-15
    assert residuals(ops, sol, associative=False)["compatibility"] > 1e-2  # 0.10 measured


def test_positive_part_ratio():
    assert positive_part_ratio(np.array([-1.0, -2.0])) == 0.0
    assert positive_part_ratio(np.array([3.0, -4.0])) == 0.6  # 3 / 5
    assert positive_part_ratio(np.zeros(3)) == 0.0


def test_missing_fields_leave_their_residuals_out():
    """A point without a mechanism has only the force residuals; one without anything has none and is not verified."""
    ops = bm.assemble(bm.cases.single_block())
    sol = bm.solve(ops, "static-lp").solution
    forces_only = residuals(ops, Solution(sol.multiplier, sol.x), associative=False)
    assert forces_only.keys() == {"equilibrium", "unilateral_admissibility", "friction_admissibility",
                                  "local_admissibility"}
    assert residuals(ops, Solution(), associative=False) == {}
    result = bm.run_solver(ReturnsPoint(Solution(sol.multiplier)), ops)
    assert result.status is Status.NUMERICAL and not result.verified
