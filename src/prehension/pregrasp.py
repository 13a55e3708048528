"""The pre-grasp: every participating finger backed off along its contact normal.

A robot closes a hand onto an object from a pose where the fingers are open around it.
:func:`pregrasp` finds one for a solution: the object stays where the grasp has it, each
contact's hand point (the point of the finger that touches, fixed to its link) is aimed
``back_off_mm`` out of the object along the object's outward normal at the contact, and
the joint angles of the dofs that move those points are solved for the targets by damped
least squares on the stacked point Jacobians,

.. math::

    \\Delta q = J^T (J J^T + \\lambda^2 I)^{-1} (p^* - p(q)), \\qquad \\lambda = 1\\ \\text{mm},

the step clipped to the joint limits, a coupled dof following its source, for at most
100 steps or until every point is within 0.01 mm of its target.  Idle fingers stay where
the grasp holds them.  The pre-grasp is then judged by the one residual function
(:func:`~prehension.verification.residuals.evaluate`) at the grasp's object pose: its joint
limits, couplings, self-collision and hand-object collision rows (the contact rows do
not apply: the fingers are meant to be away) must hold with the strict tolerances.
``collision_free`` says whether they do; ``reached_mm`` how far each hand point stands
off the object along its normal (the stated distance unless a joint limit stopped it).
A pre-grasp that collides is tried again at 2/3 and 1/3 of the distance (:func:`pregrasp`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .hands.kinematics import forward_kinematics, point_jacobian
from .tasks.model import Configuration, Task
from .verification.residuals import Tolerances, evaluate

__all__ = ["PreGrasp", "pregrasp", "judge_pregrasp", "approach_entries", "approach_entries_of", "DEFAULT_BACK_OFF_MM", "PREGRASP_KINDS"]

DEFAULT_BACK_OFF_MM = 15.0
PREGRASP_KINDS = ("joint_limit", "coupling", "collision", "object_collision")  # the rows a pre-grasp must pass
_DAMPING_MM = 1.0
_STEPS = 100
_REACHED_MM = 0.01


@dataclass(frozen=True, eq=False)
class PreGrasp:
    """A pre-grasp of a solution (see the module docstring).

    Attributes:
        q: (n_dof,) joint angles [rad].
        back_off_mm: the stated distance.
        reached_mm: (C,) how far each contact's hand point stands off its grasp point
            along the object's outward normal [mm].
        collision_free: joint limits, couplings, self-collision and hand-object
            collision all hold (strict tolerances of the residual function).
        failed: the names of the rows that do not hold (empty when ``collision_free``).
    """

    q: np.ndarray
    back_off_mm: float
    reached_mm: np.ndarray
    collision_free: bool
    failed: tuple[str, ...]

    def to_dict(self, task: Task) -> dict:
        return {"back_off_mm": self.back_off_mm, "joint_angles_rad": dict(zip(task.hand.dof_names, self.q.tolist())),
                "reached_mm": self.reached_mm.tolist(), "collision_free": self.collision_free,
                "failed": list(self.failed)}  # fmt: skip


def _links_and_points(task: Task, q, contacts):
    """Per contact: its hand region's link index and the touching point in that link's frame."""
    pose = forward_kinematics(task.hand, q)
    out = []
    for contact, state in zip(task.contacts, contacts):
        k = task.hand.link_index(task.hand.region(contact.hand_region).link)
        R, r = pose.R_palm_link[0, k], pose.r_palm_link[0, k]
        out.append((k, R.T @ (np.asarray(state.hand_point, float) - r)))
    return out


def pregrasp(task: Task, solution, back_off_mm: float = DEFAULT_BACK_OFF_MM) -> PreGrasp:
    """The pre-grasp of ``solution`` (a grasp of ``task``: ``q``, ``T_palm_object``, ``contacts``).

    When backing off ``back_off_mm`` collides, 2/3 and 1/3 of it are tried in turn (a
    finger backed off far may swing a link into a concave object, or into its idle
    neighbour): the first collision-free one is returned, its ``back_off_mm`` the distance
    that was used; when none is, the pre-grasp of ``back_off_mm`` itself, its ``failed``
    rows named.
    """
    first = None
    for distance in (back_off_mm, back_off_mm * 2.0 / 3.0, back_off_mm / 3.0):
        pre = _backed_off(task, solution, distance)
        if pre.collision_free:
            return pre
        first = first or pre
    return first


def _backed_off(task: Task, solution, back_off_mm: float) -> PreGrasp:
    """Every participating finger aimed ``back_off_mm`` off (the module docstring), judged."""
    hand = task.hand
    q0 = np.asarray(solution.q, dtype=float)
    contacts = solution.contacts
    chains = _links_and_points(task, q0, contacts)
    targets = np.concatenate([np.asarray(s.hand_point, float) + back_off_mm * np.asarray(s.object_normal, float) for s in contacts])
    free = task.active_mask.copy()
    for c in hand.couplings:
        free[hand.dof_index(c.dof)] = False
    q = q0.copy()
    for _ in range(_STEPS):
        pose = forward_kinematics(hand, q)
        points = np.concatenate([pose.points(k, p)[0] for k, p in chains])
        error = targets - points
        if np.max(np.abs(error)) < _REACHED_MM or not free.any():
            break
        J = np.concatenate([point_jacobian(hand, pose, k, pose.points(k, p))[0] for k, p in chains])  # (3C, n_dof)
        for c in hand.couplings:
            J[:, hand.dof_index(c.source)] += c.ratio * J[:, hand.dof_index(c.dof)]
        dq = _dls_step(J, error, free, q, hand.lower, hand.upper)
        for c in hand.couplings:
            dq[hand.dof_index(c.dof)] = c.ratio * dq[hand.dof_index(c.source)]
        q_new = np.clip(q + dq, hand.lower, hand.upper)
        for c in hand.couplings:  # clipping may break a coupling: the coupled dof follows its clipped source
            i = hand.dof_index(c.dof)
            q_new[i] = q0[i] + c.ratio * (q_new[hand.dof_index(c.source)] - q0[hand.dof_index(c.source)])
        if np.allclose(q_new, q, atol=1e-12, rtol=0):
            break
        q = q_new
    return judge_pregrasp(task, q0, q, solution.T_palm_object, contacts, back_off_mm)


def _dls_step(J, error, free, q, lower, upper) -> np.ndarray:
    """The damped least-squares step over the ``free`` dofs, a dof at a limit that the
    step would push past it left out (and the step solved again without it)."""
    use = free.copy()
    dq = np.zeros(len(q))
    for _ in range(len(q) + 1):
        dq[:] = 0.0
        if not use.any():
            return dq
        Ju = J[:, use]
        dq[use] = Ju.T @ np.linalg.solve(Ju @ Ju.T + _DAMPING_MM**2 * np.eye(len(Ju)), error)
        stuck = use & (((q <= lower + 1e-12) & (dq < 0)) | ((q >= upper - 1e-12) & (dq > 0)))
        if not stuck.any():
            return dq
        use &= ~stuck
    return dq


def judge_pregrasp(task: Task, q_grasp, q, T_palm_object, contacts, back_off_mm: float) -> PreGrasp:
    """The :class:`PreGrasp` at angles ``q`` of the grasp at ``q_grasp`` (object at
    ``T_palm_object``, ``contacts`` as solved): how far each hand point stands off, and the
    residual function's rows a pre-grasp must pass (what ``prehension check`` re-derives)."""
    q = np.asarray(q, dtype=float)
    pose = forward_kinematics(task.hand, q)
    reached = np.array([(pose.points(k, p)[0] - np.asarray(s.hand_point, float)) @ np.asarray(s.object_normal, float)
                        for (k, p), s in zip(_links_and_points(task, np.asarray(q_grasp, float), contacts), contacts)])  # fmt: skip
    params = tuple((np.asarray(s.hand_params, float), np.asarray(s.object_params, float)) for s in contacts)
    report = evaluate(task, Configuration(q, np.asarray(T_palm_object, float), params), Tolerances(), pose=pose)
    failed = tuple(dict.fromkeys(f"{c.kind} {c.name}" for c in report.checks if c.kind in PREGRASP_KINDS and not c.ok))
    return PreGrasp(q, float(back_off_mm), reached, not failed, failed)


def approach_entries(task: Task, solution, back_off_mm: float = DEFAULT_BACK_OFF_MM) -> dict:
    """A solution's ``"pregrasp"`` and ``"squeeze"`` as a result file stores them: the
    pre-grasp (:func:`pregrasp`) and the squeeze targets of the physics test's default
    protocol (:func:`~prehension.sim.push.squeeze_for`, the ``"push"`` squeeze, 10 mm,
    friction 0.6), the hand closing from the first through the grasp to the second."""
    from .sim.options import SimOptions
    from .sim.push import squeeze_for

    o = SimOptions()
    q_squeeze, depths = squeeze_for(task, solution.q, solution.T_palm_object, solution.contacts, o)
    squeeze = {"kind": o.squeeze, "squeeze_mm": o.squeeze_mm, "friction": o.friction, "depths_mm": depths.tolist(),
               "joint_angles_rad": dict(zip(task.hand.dof_names, q_squeeze.tolist()))}  # fmt: skip
    return {"pregrasp": pregrasp(task, solution, back_off_mm).to_dict(task), "squeeze": squeeze}


def approach_entries_of(result, back_off_mm: float = DEFAULT_BACK_OFF_MM) -> list[dict]:
    """:func:`approach_entries` of every solution of ``result`` (a
    :class:`~prehension.results.SolveResult`): what
    :func:`~prehension.results.write_result` stores with each solution."""
    return [approach_entries(result.task, s, back_off_mm) for s in result.solutions]


def check_approach(task: Task, q_grasp, T_palm_object, contacts, stored: dict) -> list[tuple[str, bool, str]]:
    """Re-derive a stored ``"pregrasp"`` and ``"squeeze"``: ``(what, ok, detail)`` each.

    The pre-grasp's angles are judged again (:func:`judge_pregrasp`): the stated
    ``reached_mm``, ``collision_free`` and ``failed`` must be what they are, and a
    pre-grasp claimed collision-free must pass the residual function's rows.  The squeeze
    targets are recomputed from the contacts with the stated kind, depth and friction.
    """
    from .sim.options import SimOptions
    from .sim.push import as_good_a_push_squeeze, squeeze_for
    from .sim.squeeze import as_good_a_squeeze

    out = []
    if "pregrasp" in stored:
        what = "pre-grasp (collision-free with the object and itself)"
        try:
            pre = stored["pregrasp"]
            q = np.array([float(pre["joint_angles_rad"][d]) for d in task.hand.dof_names])
            again = judge_pregrasp(task, q_grasp, q, T_palm_object, contacts, float(pre["back_off_mm"]))
            same = (bool(pre["collision_free"]) == again.collision_free and list(pre["failed"]) == list(again.failed)
                    and np.allclose(pre["reached_mm"], again.reached_mm, atol=1e-6, rtol=0))  # fmt: skip
            detail = ("collision-free" if again.collision_free else "NOT collision-free: " + ", ".join(again.failed)) + (
                f"; fingers backed off {', '.join(f'{r:.1f}' for r in again.reached_mm)} mm (stated {again.back_off_mm:g} mm)")
            out.append((what, same, detail if same else f"differs from the file: {detail}"))
        except (KeyError, TypeError, ValueError) as exc:
            out.append((what, False, f"malformed ({type(exc).__name__}: {exc})"))
    if "squeeze" in stored:
        what = "squeeze targets"
        try:
            sq = stored["squeeze"]
            o = SimOptions(squeeze_mm=float(sq["squeeze_mm"]), squeeze=str(sq["kind"]), friction=float(sq["friction"]))
            q_sq, depths = squeeze_for(task, q_grasp, T_palm_object, contacts, o)
            given = np.array([float(sq["joint_angles_rad"][d]) for d in task.hand.dof_names])
            same = np.allclose(depths, sq["depths_mm"], atol=1e-6, rtol=0) and (
                np.allclose(q_sq, given, atol=1e-6, rtol=0)  # else an equally good step (not unique: squeeze_targets)
                or (sq["kind"] in ("balanced", "uniform") and as_good_a_squeeze(task, q_grasp, contacts, float(sq["squeeze_mm"]), depths, given)))
            same = same or (sq["kind"] == "push" and as_good_a_push_squeeze(task, q_grasp, T_palm_object, contacts, o, given, sq["depths_mm"]))
            out.append((what, bool(same), f"{sq['kind']}, depths {', '.join(f'{d:.1f}' for d in depths)} mm"
                                          + ("" if same else ": differ from the recomputed ones")))  # fmt: skip
        except (KeyError, TypeError, ValueError) as exc:
            out.append((what, False, f"malformed ({type(exc).__name__}: {exc})"))
    return out
