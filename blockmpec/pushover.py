r"""Capacity curves by incremental limit analysis: ``bm.pushover`` and ``blockmpec pushover``.

The collapse multiplier of the undeformed structure is one point of a curve: as the blocks move
along their mechanism the multiplier falls (a rocking block's ``lam = tan(alpha - theta)``).
:func:`pushover` traces it.  At each configuration it finds the contacts
(:mod:`blockmpec.contacts`: edge-to-edge interfaces and vertex-to-edge point contacts), solves
the limit problem with any registered method (``static-lp`` for the associative problem,
``fixed-point`` for the non-associative one, ...) through :func:`blockmpec.solve`, whose
verifier checks every configuration, and moves the blocks along the mechanism found, so far
that the control point advances by one step.  Three modules share the work:

* the configuration update (:mod:`blockmpec.pushover_motion`): block poses and the exact rigid motion of the
  mechanism's twists over one parameter ``s``, solved so that the control point's displacement along the live
  load, ``e . (q - q_0)`` with ``e = (+-1, 0)``, reaches the next multiple of the step ``max_displacement / steps``;
* the contact update (:mod:`blockmpec.pushover_contacts`): the second-order correction that keeps hinges closed
  and sliding points on their faces, the cut back to a contact event, the proof that no multiplier holds;
* the step loop (here, :class:`_Curve`): solve, record, move, and decide where the curve ends.

A step whose correction cannot meet the hinges and the advance is halved (``event = "substep"``); one that makes
two blocks overlap is cut back to the moment they touch (``"contact"``).  Either way the next row resumes towards the
same target.

When no multiplier holds a configuration
----------------------------------------
If the solve fails, a small LP looks for a mechanism on which only the dead load works
(:func:`~blockmpec.pushover_contacts.dead_load_mechanism`): by Farkas' lemma it exists exactly when the static LP is
infeasible, and it is the proof.  The structure then falls along it, whatever ``lam`` is, until a contact closes
(``"snap"`` rows, multiplier NaN): an arch whose thrust line leaves a joint between its pinned hinges snaps through,
closing the opened wedge of one hinge, and goes on.  Snaps that move a vertex by more than half the smallest block's
shorter side without reaching a configuration that stands are a collapse: the curve ends.  Without such a proof the
method failed where an answer exists; :data:`RETRY_OPTIONS` are tried, and the curve ends with the failure if none
succeeds.

The curve ends at ``max_displacement``, when ``lam <= 0`` (the displacement where ``lam`` crosses 0
is interpolated into ``attrs["ultimate_displacement"]``), at a collapse, when a solve fails, or when
the control point no longer advances along the live load.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from blockmpec.contacts import CONTACT_LENGTH, CONTACT_TOLERANCE, contact_structure, find_contacts, shorter_sides
from blockmpec.errors import OptionError
from blockmpec.geometry import Structure
from blockmpec.pushover_contacts import (
    VELOCITY_TOL,
    Anchor,
    close_contacts,
    closed_points,
    cut_at_contact,
    cut_at_instability,
    dead_load_mechanism,
    lonely_block,
    overlaps,
)
from blockmpec.pushover_motion import (
    Poses,
    mechanism_twists,
    moved,
    parameter_for,
    place,
    rotate,
    velocity,
    vertex_speed,
    vertices_at,
)
from blockmpec.result import Result, Status
from blockmpec.verify import VERIFY_TOL

#: The columns of the curve before the per-block position columns (a contract: see :func:`pushover`).
CURVE_COLUMNS = ("step", "displacement", "rotation", "multiplier", "status", "event", "control_x", "control_y",
                 "contacts", "point_contacts", "time_s", "retried_with")

#: At most this many solves per requested step (extra rows come from halved steps, steps cut at contact
#: events and at instabilities, and snaps).
MAX_ROWS_PER_STEP = 10

#: Options tried in turn, per method, when a moved configuration's solve fails (those the caller set are
#: not overridden).  The fixed point's default "dead-load" start needs the configuration to stand at
#: lam = 0; a moved one often stands only at its lam > 0 (a block on its toe), and HiGHS then fails
#: without saying "infeasible"; its simplex engine also fails now and then on moved walls where the
#: interior engine converges.  HiGHS's dual simplex (``static-lp``'s choice for small LPs) now and then
#: stops with status "Not Set" on a moved wall that its primal simplex and interior point solve.
RETRY_OPTIONS: dict[str, tuple[dict[str, Any], ...]] = {
    "fixed-point": ({"start": "associative"}, {"engine": "interior"}),
    "static-lp": ({"algorithm": "primal-simplex"}, {"algorithm": "ipm"}),
}

#: Consecutive dead-load moves (snaps) before the curve stops.
MAX_SNAPS = 20

#: A run of snaps that moves a vertex further than this fraction of the smallest free block's shorter side
#: without reaching a configuration that stands is a collapse: the curve stops.
MAX_SNAP_MOTION = 0.5

#: A step whose correction moves a vertex by more than this fraction of the step's largest vertex
#: motion, or whose hard rows are not met, is halved (at most :data:`MAX_HALVINGS` times).
MAX_CORRECTION = 0.25
MAX_HALVINGS = 8


# --------------------------------------------------------------------------- input


def _check_number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise OptionError(f"{name}: expected a number; got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise OptionError(f"{name}: must be a finite number > 0; got {value!r}")
    return v


def _structure_size(structure: Structure) -> float:
    """Bounding-box diagonal of the free blocks."""
    v = structure.vertices[~structure.fixed].reshape(-1, 2)
    return float(np.hypot(*(v.max(axis=0) - v.min(axis=0))))


def _control_block(structure: Structure, control: Any) -> tuple[int | None, np.ndarray | None]:
    """``(block, point)`` of a control given as a block index or a point (None: chosen after the first solve)."""
    if control is None:
        return None, None
    n = structure.n_blocks
    if isinstance(control, (int, np.integer)) and not isinstance(control, bool):
        k = int(control)
        if not 0 <= k < n:
            raise OptionError(f"control: block {k} does not exist (there are {n} blocks, 0 to {n - 1})")
        if structure.fixed[k]:
            raise OptionError(f"control: block {k} is fixed (a support); give a free block")
        return k, structure.centroid[k]
    try:
        point = np.asarray(control, float).reshape(2)
    except (TypeError, ValueError):
        raise OptionError(f"control: expected a block index or a point (x, y); got {control!r}") from None
    if not np.all(np.isfinite(point)):
        raise OptionError(f"control: the point {control!r} must be finite")
    inside = _inward_distance(structure, point)
    k = int(np.argmax(inside))
    size = shorter_sides(structure.vertices)
    if inside[k] < -CONTACT_TOLERANCE * size[k]:
        raise OptionError(f"control: the point {point.tolist()} lies in no block")
    free_inside = np.where(structure.fixed, -np.inf, inside)
    kf = int(np.argmax(free_inside))
    if free_inside[kf] < -CONTACT_TOLERANCE * size[kf]:
        raise OptionError(f"control: the point {point.tolist()} lies in block {k}, which is fixed (a support); "
                          "give a point of a free block")
    return kf, point


def _inward_distance(structure: Structure, point: np.ndarray) -> np.ndarray:
    """Per block, the smallest distance of ``point`` inside its edges' lines (negative: outside)."""
    from blockmpec.contacts import _edges

    start, _, _, normal, _, valid = _edges(structure.vertices, structure.n_vertices)
    d = -np.einsum("nkd,nkd->nk", normal, point[None, None, :] - start)
    return np.where(valid, d, np.inf).min(axis=1)


# --------------------------------------------------------------------------- the curve


def pushover(
    structure: Structure,
    method: str = "static-lp",
    *,
    control: int | tuple[float, float] | None = None,
    max_displacement: float | None = None,
    steps: int = 20,
    contact_tolerance: float = CONTACT_TOLERANCE,
    contact_length: float = CONTACT_LENGTH,
    verify_tol: float = VERIFY_TOL,
    options: dict[str, Any] | None = None,
):
    r"""The capacity curve of a structure: its load multiplier as it moves along its mechanism.

    Parameters
    ----------
    structure : Structure
    method : str
        A registered method (``static-lp``: associative; ``fixed-point``: non-associative; any
        method whose result has a mechanism).
    control : int or (x, y), optional
        The control point: a free block's index (its centroid) or a point of a free block.
        Default: the centroid of the free block whose centroid moves fastest along the live load
        in the first mechanism.
    max_displacement : float, optional
        Displacement of the control point along the live load at which the curve stops, in the
        structure's length unit.  Default: half the median shorter side of the free blocks'
        bounding boxes (a single ``b x h`` block: ``b/2`` when ``b <= h``, where it topples).
    steps : int
        Number of equal increments of the control displacement up to ``max_displacement``.
    contact_tolerance, contact_length : float
        Contact tolerance and point-contact length, relative to the shorter side of the smaller
        block of each pair (:mod:`blockmpec.contacts`).
    verify_tol : float
        Passed to :func:`blockmpec.solve`: a step succeeds only when its residuals are at most this.
    options : dict, optional
        The method's options.

    Returns
    -------
    pandas.DataFrame
        One row per solve (``steps + 1`` rows unless the curve stops early, plus one per step cut
        at a contact event), columns:

        ``step``
            row number, 0 for the undeformed structure;
        ``displacement``
            control point's displacement along the live load from the start (structure length unit;
            positive in the sense of the live load);
        ``rotation``
            the control block's rotation from the start (radians, counter-clockwise positive in the
            structure's axes: a block toppling towards ``+x`` has a negative rotation);
        ``multiplier``
            the load multiplier ``lam`` of the configuration (NaN when the solve failed);
        ``status``
            the solve's status (``optimal``, ``converged``, ... or why it failed);
        ``control_x, control_y``
            the control point's position;
        ``contacts, point_contacts``
            number of contacts and how many of them are vertex-to-edge points;
        ``time_s``
            wall time of the step (contacts, assembly, model building and solve);
        ``block_<i>_x, block_<i>_y, block_<i>_angle``
            centroid and rotation from the start of every block ``i`` (structure indices, fixed
            blocks included): block ``i``'s vertices at a step are
            ``R(angle) (V_i - c_i) + (x, y)``, with ``V_i`` its vertices and ``c_i`` its centroid in
            ``structure`` (:func:`block_polygons` does this).

        ``attrs`` holds ``method``, ``problem``, ``control_block``, ``control_point`` (undeformed),
        ``direction`` (+1 or -1: the sense of the live load along ``x``), ``max_displacement``,
        ``steps``, ``step_size``, ``contact_tolerance``, ``contact_length``, ``stop_reason`` and
        ``ultimate_displacement`` (where ``lam`` crosses 0, linearly interpolated, or None).
        Plot ``multiplier`` against ``displacement`` for the capacity curve
        (:func:`blockmpec.pushover_plot.plot_capacity_curve`).

    Raises
    ------
    OptionError
        A control block that is fixed or absent, a control point in no free block, a
        non-positive ``max_displacement`` or ``steps``, a step larger than the structure (the
        bounding-box diagonal of its free blocks), a bad tolerance or option.
    UnknownNameError
        An unknown method.
    """
    import pandas as pd

    if not isinstance(structure, Structure):
        raise OptionError(f"structure: expected a blockmpec Structure; got {type(structure).__name__}")
    options = dict(options or {})
    solver_cls = _checked_method(method, options)
    steps = _checked_steps(steps)
    verify_tol = _check_number("verify_tol", verify_tol)
    contact_tolerance, contact_length = _checked_contact(contact_tolerance, contact_length)
    size = _structure_size(structure)
    side = shorter_sides(structure.vertices)
    if max_displacement is None:
        max_displacement = 0.5 * float(np.median(side[~structure.fixed]))
    max_displacement = _check_number("max_displacement", max_displacement)
    step_size = max_displacement / steps
    if step_size > size:
        raise OptionError(f"step: max_displacement / steps = {step_size:.6g} is larger than the structure "
                          f"(its free blocks span {size:.6g}); take more steps or a smaller max_displacement")
    curve = _Curve(structure, method, solver_cls.problem, options, verify_tol, steps, step_size,
                   _control_block(structure, control), contact_tolerance, contact_length)
    curve.trace()
    frame = pd.DataFrame(curve.rows)
    frame.attrs.update(
        method=method, problem=curve.problem, control_block=curve.control_block,
        control_point=None if curve.control_point is None else [float(v) for v in curve.control_point],
        direction=curve.direction, max_displacement=max_displacement, steps=steps, step_size=step_size,
        contact_tolerance=contact_tolerance, contact_length=contact_length, stop_reason=curve.stop_reason,
        ultimate_displacement=_ultimate(frame),
    )
    return frame


def _checked_method(method: str, options: dict[str, Any]):
    """The method's class; a bad option raises :class:`OptionError` before anything runs."""
    from blockmpec.registry import get_solver

    solver_cls = get_solver(method)
    solver_cls(**options)
    return solver_cls


def _checked_steps(steps: Any) -> int:
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise OptionError(f"steps: must be an integer >= 1; got {steps!r}")
    return int(steps)


def _checked_contact(contact_tolerance: Any, contact_length: Any) -> tuple[float, float]:
    contact_tolerance = _check_number("contact_tolerance", contact_tolerance)
    contact_length = _check_number("contact_length", contact_length)
    if contact_tolerance > 0.1:
        raise OptionError(f"contact_tolerance: must be at most 0.1 (of the smaller block's shorter side); "
                          f"got {contact_tolerance:g}")
    if contact_length > 0.5:
        raise OptionError(f"contact_length: must be at most 0.5 (of the smaller block's shorter side); "
                          f"got {contact_length:g}")
    return contact_tolerance, contact_length


class _Curve:
    """One capacity curve being traced: the configuration (:class:`~blockmpec.pushover_motion.Poses`), the rows so
    far and the loop's state; :meth:`trace` runs the step loop (module docstring)."""

    def __init__(self, structure: Structure, method: str, problem: str, options: dict[str, Any], verify_tol: float,
                 steps: int, step_size: float, control: tuple, contact_tolerance: float,
                 contact_length: float) -> None:
        self.structure, self.method, self.problem, self.options = structure, method, problem, options
        self.verify_tol, self.steps, self.step_size = verify_tol, steps, step_size
        self.contact_tolerance, self.contact_length = contact_tolerance, contact_length
        self.control_block, self.control_point = control
        self.c0 = structure.centroid
        self.n = structure.n_blocks
        self.fixed = structure.fixed
        self.poses = Poses(np.zeros(self.n), np.zeros((self.n, 2)))
        self.associative = problem == "associative"
        self.side = shorter_sides(structure.vertices)
        self.length_tol = contact_tolerance * float(np.min(self.side[~self.fixed]))
        self.block_size = np.maximum(self.side, np.finfo(float).tiny)
        self.rows: list[dict[str, Any]] = []
        self.direction = None
        self.e = None
        self.stop_reason = "max_displacement reached"
        self.displacement = 0.0
        self.target_step = 0
        self.event = "start"
        self.snaps, self.snap_motion = 0, 0.0
        self.last_push = None  # (poses of a step as a function of s, the s taken) of the last push step
        self.pending = None  # poses just past an instability, to go to after recording the last ones that stand
        self.falling = False  # the next configuration follows an instability or a snap: check for a fall first

    # ------------------------------------------------------------------ the loop
    def trace(self) -> None:
        """Solve, record and move until the curve ends (:attr:`stop_reason`)."""
        while True:
            t0 = time.perf_counter()
            vertices = vertices_at(self.structure, self.poses, self.c0)
            contacts = find_contacts(vertices, self.structure.n_vertices, self.fixed,
                                     tolerance=self.contact_tolerance, contact_length=self.contact_length)
            deformed = contact_structure(self.structure, vertices, contacts)
            ops = _assemble(deformed)
            res, fall, retried = self._solve(ops, contacts)
            if fall is not None and self.last_push is not None:
                self._cut_back()  # the step went past the configuration where the structure stops standing
                continue
            self.last_push = None
            if self.direction is None:
                self.direction = float(ops.mirror)
                self.e = np.array([self.direction, 0.0])
            if self.control_block is None and res.success and res.solution.u is not None:
                twist = mechanism_twists(ops, res.solution.u, self.n)
                self.control_block = int(np.argmax(np.where(self.fixed, -np.inf, self.direction * twist[:, 0])))
                self.control_point = self.c0[self.control_block].copy()
            self._record(res, contacts, time.perf_counter() - t0, retried)
            if len(self.rows) > MAX_ROWS_PER_STEP * self.steps + 10:
                self.stop_reason = f"more than {MAX_ROWS_PER_STEP} solves per step (contact events, snaps)"
                return
            move = self._next_move(res, fall, ops, contacts, deformed, vertices)
            if move == "again":
                continue
            if move is None or not self._take(*move, vertices):
                return

    def _solve(self, ops, contacts) -> tuple[Result, np.ndarray | None, str]:
        """The configuration's result, the dead-load mechanism that proves no ``lam`` holds it (or None), and the
        retry options that solved it (``""``: none)."""
        from blockmpec.solver import solve

        method, problem = self.method, self.problem
        lonely = lonely_block(self.structure, contacts)
        retried, checked = "", self.falling
        # just past an instability or after a snap: the proof that no lam holds first, it costs one small LP
        fall = dead_load_mechanism(ops) if checked else None
        if lonely is not None:  # it cannot stand: no solve (its equilibrium rows would read 0 = weight)
            res = Result(method=method, status=Status.INFEASIBLE, problem=problem,
                         message=f"block {lonely} touches no other block")
        elif fall is not None:  # proven: no lam holds it (a method would spend its starts and fallbacks on it)
            res = Result(method=method, status=Status.INFEASIBLE, problem=problem,
                         message="no lam holds this configuration: a mechanism on which only the dead load works")
        else:
            res = solve(ops, method, verify_tol=self.verify_tol, **self.options)
        self.falling = False
        if not res.success and self.rows:
            # a mechanism on which the dead load works and the live load does not proves that no lam holds
            # this configuration (Farkas); without one, the method failed where a solution exists: retry
            if not checked:
                fall = dead_load_mechanism(ops)
            for retry in RETRY_OPTIONS.get(method, ()) if fall is None else ():
                if res.success or set(retry) & set(self.options):
                    continue
                res = solve(ops, method, verify_tol=self.verify_tol, **{**self.options, **retry})
                retried = ",".join(f"{k}={v}" for k, v in retry.items())
        return res, fall, retried

    def _cut_back(self) -> None:
        """Cut the last step back to the last configuration that stands (``"instability"``), the one just past it
        pending."""
        before, after = cut_at_instability(self.structure, self.fixed, self.last_push, self.c0,
                                           self.contact_tolerance, self.contact_length)
        self.last_push = None
        if before is not None:
            self.poses, self.pending, self.event = before, after, "instability"
        else:
            self.poses = after
        self._moved_to(self.poses)

    def _moved_to(self, poses: Poses) -> None:
        self.poses = poses
        self.displacement = self._control_at(poses)
        self.target_step = self._reached(self.displacement)

    def _reached(self, d: float) -> int:
        """The steps completed at the control displacement ``d`` (the next row aims at the next one)."""
        return min(self.steps, max(0, int(math.floor(d / self.step_size + 1e-6))))

    def _control_at(self, p: Poses) -> float:
        q = place(self.control_point[None, :], np.array([self.control_block]), p, self.c0)[0]
        return float(self.e @ (q - self.control_point))

    def _record(self, res, contacts, elapsed: float, retried: str = "") -> None:
        poses, block = self.poses, self.control_block
        q = None if block is None else place(self.control_point[None, :], np.array([block]), poses, self.c0)[0]
        row = {
            "step": len(self.rows),
            "displacement": self.displacement,
            "rotation": np.nan if block is None else float(poses.angle[block]),
            "multiplier": float(res.multiplier) if res.success else np.nan,
            "status": res.status.value,
            "event": self.event,
            "control_x": np.nan if q is None else float(q[0]),
            "control_y": np.nan if q is None else float(q[1]),
            "contacts": len(contacts),
            "point_contacts": contacts.n_points,
            "time_s": elapsed,
            "retried_with": retried,
        }
        centre = self.c0 + poses.shift
        for i in range(self.n):
            row[f"block_{i}_x"] = float(centre[i, 0])
            row[f"block_{i}_y"] = float(centre[i, 1])
            row[f"block_{i}_angle"] = float(poses.angle[i])
        self.rows.append(row)

    # ------------------------------------------------------------------ the next move
    def _next_move(self, res, fall, ops, contacts, deformed, vertices):
        """``(twist, s, closed points)`` of the next move (a push along the mechanism, or a snap along the
        dead-load mechanism), ``"again"`` to solve the configuration reached, or None when the curve ends."""
        if res.success and res.solution.u is not None:
            self.snaps, self.snap_motion = 0, 0.0
            if res.multiplier <= 0:
                self.stop_reason = "the load multiplier reached 0"
                return None
            if self.pending is not None:  # just past the instability, where the structure falls
                pending, self.pending, self.event = self.pending, None, "step"
                self.falling = True
                self._moved_to(pending)
                return "again"
            if self.target_step >= self.steps:
                return None
            return self._push(ops, contacts, deformed, vertices, res.solution.u)
        if (fall is not None and self.control_block is not None and self.snaps < MAX_SNAPS
                and self.snap_motion <= MAX_SNAP_MOTION * float(np.min(self.side[~self.fixed]))):
            # no lam holds this configuration: it falls along the dead-load mechanism until a contact closes
            twist = mechanism_twists(ops, fall, self.n)
            s_full = self.step_size / vertex_speed(twist, vertices, self.c0 + self.poses.shift)
            closed = closed_points(contacts, deformed, twist, self.poses, self.c0, True)
            self.event = "snap"
            self.snaps += 1
            self.falling = True
            return twist, s_full, closed
        self.stop_reason = f"{self.method} did not succeed: {res.status.value}" + (
            f" ({res.message})" if res.message else "")
        if fall is not None and self.snaps:
            self.stop_reason = (f"the structure collapses: no lam holds it, and {self.snaps} moves under its dead "
                                f"load (up to {self.snap_motion:.3g}) reached no configuration that stands")
        return None

    def _push(self, ops, contacts, deformed, vertices, u):
        """The move along the mechanism ``u`` that takes the control point to the next step, or None."""
        poses, block = self.poses, self.control_block
        twist = mechanism_twists(ops, u, self.n)
        rate = float(self.e @ velocity(twist, self.c0 + poses.shift, np.array([block]),
                                       place(self.control_point[None, :], np.array([block]), poses, self.c0))[0])
        if not rate > VELOCITY_TOL * vertex_speed(twist, vertices, self.c0 + poses.shift):
            self.stop_reason = (f"the control point (block {block}) does not move along the live load in "
                                "the mechanism of this configuration")
            return None
        target = (self.target_step + 1) * self.step_size
        s_full = parameter_for(lambda s: self._control_at(moved(poses, twist, s)) - target,
                               max(target - self.displacement, 1e-3 * self.step_size) / rate)
        if s_full is None:
            self.stop_reason = f"the control point (block {block}) cannot advance by a step along this mechanism"
            return None
        self.event = "step"
        return twist, s_full, closed_points(contacts, deformed, twist, poses, self.c0, self.associative)

    def _take(self, twist, s_full, closed, vertices) -> bool:
        """Move by ``s_full`` along ``twist`` with the contact correction, halved while the correction fails and
        cut back at a contact event; False when the curve ends."""
        structure, c0, poses = self.structure, self.c0, self.poses
        push = self.event == "step"

        def trial(s):
            new_poses = moved(poses, twist, s)
            anchor = Anchor(self.control_block, self.control_point, self.e, float(self.e @ place(
                self.control_point[None, :], np.array([self.control_block]), new_poses, c0)[0])) if push else None
            out, met = close_contacts(closed, new_poses, c0, self.fixed, self.block_size, self.length_tol, anchor)
            return out, met, new_poses

        halvings = 0
        while True:
            new, met, unclosed = trial(s_full)
            motion = np.max(np.linalg.norm(vertices_at(structure, unclosed, c0) - vertices, axis=-1))
            correction = np.max(np.linalg.norm(vertices_at(structure, new, c0) - vertices_at(structure, unclosed, c0),
                                               axis=-1))
            if (met and (push or correction <= MAX_CORRECTION * motion)) or halvings >= MAX_HALVINGS:
                break
            s_full *= 0.5
            halvings += 1
        if halvings:
            self.event = "substep" if self.event == "step" else self.event
        cut_trial = lambda s: trial(s)[0]  # noqa: E731
        overlap = overlaps(structure, new, c0, self.contact_tolerance)
        if overlap is not None:
            new, s_full = cut_at_contact(structure, cut_trial, s_full, overlap, c0, self.contact_tolerance)
            if new is None:
                self.stop_reason = "blocks overlap and the step could not be cut back to their contact"
                return False
            self.event = "contact" if self.event in ("step", "substep") else self.event
        if self.event == "snap":
            self.snap_motion += float(np.max(np.linalg.norm(vertices_at(structure, new, c0) - vertices, axis=-1)))
        else:
            self.last_push = (cut_trial, s_full)
        self._moved_to(new)
        return True


def _assemble(structure: Structure):
    from blockmpec.operators import assemble

    return assemble(structure)


def _ultimate(curve) -> float | None:
    """Displacement where the multiplier crosses 0 (linear between the last two rows), or None."""
    lam = curve["multiplier"].to_numpy(float) if len(curve) else np.zeros(0)
    if lam.size >= 2 and np.isfinite(lam[-1]) and lam[-1] <= 0 < lam[-2]:
        d = curve["displacement"].to_numpy(float)
        return float(d[-2] + (d[-1] - d[-2]) * lam[-2] / (lam[-2] - lam[-1]))
    return None


def block_polygons(structure: Structure, curve, row: int) -> list[np.ndarray]:
    """The blocks' vertices (each (k_i, 2)) at row ``row`` of a curve from :func:`pushover`."""
    r = curve.iloc[row]
    c0 = structure.centroid
    out = []
    for i in range(structure.n_blocks):
        v = structure.polygon(i) - c0[i]
        angle = float(r[f"block_{i}_angle"])
        out.append(rotate(v, np.float64(angle)) + [float(r[f"block_{i}_x"]), float(r[f"block_{i}_y"])])
    return out


__all__ = ["pushover", "block_polygons", "CURVE_COLUMNS"]
