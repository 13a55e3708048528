"""Which local solutions are solutions: the checks after each wave of the local solver.

A local solution of the kernel (its contacts within ``d_min``) is judged with the
foundation's own batch functions (:func:`~prehension.hands.kinematics.forward_kinematics`,
:func:`~prehension.hands.collision.max_penetration` -- the paper's Check_Collisions --,
:func:`~prehension.verification.residuals.limit_violations`,
:func:`~prehension.verification.residuals.coupling_violations` and the contact residuals of
:mod:`prehension.verification.residuals`): :func:`check` for point problems (contact residuals
vectorised over problems, :func:`contact_checks_points`), :func:`check_tasks` for tasks
(the residual function itself, through :func:`~prehension.results.make_solution`).
Both return :class:`Verdicts`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...geometry.rotations import angle_between
from ...hands.collision import max_penetration
from ...hands.kinematics import HandPose, forward_kinematics
from ...results import first_solution
from ...tasks.model import Configuration, Task
from ...verification.residuals import Tolerances, contact_residuals, coupling_violations, limit_violations
from ._layout import Group
from .options import STRICT, LocalOptions
from .problems import PointProblems

__all__ = ["Verdicts", "check", "check_tasks", "contact_checks_points", "contact_checks_tasks"]


class Verdicts(NamedTuple):
    """The judgement of ``S`` local solutions.

    Attributes:
        level: (S,) 2 strict, 1 only the acceptance tolerances, 0 failed.
        q: (S, n_dof) joint angles; T: (S, 4, 4) palm-to-object transforms; params: per
            contact ``(hand, object)`` parameter arrays (S, k).
        dmax, amax: (S,) largest contact distance [mm] and normal misalignment [deg]
            (``inf`` where :func:`check_tasks` made no solution).
        solutions: per local solution the strict :class:`~prehension.results.Solution`
            made by the residual function, else ``None``.
    """

    level: np.ndarray
    q: np.ndarray
    T: np.ndarray
    params: list
    dmax: np.ndarray
    amax: np.ndarray
    solutions: list

    def select(self, mask: np.ndarray) -> "Verdicts":
        """The verdicts where ``mask`` holds (the parameters are left out: ``None``)."""
        return Verdicts(self.level[mask], self.q[mask], self.T[mask], None, self.dmax[mask], self.amax[mask],
                        [s for s, m in zip(self.solutions, mask) if m])  # fmt: skip


def contact_checks_points(problems: PointProblems, idx, pose: HandPose, T, params):
    """Contact residuals of point problems (as :func:`contact_residuals`, vectorised over problems)."""
    hand = problems.hand
    dist, ang, hreg_v = [], [], []
    for c, name in enumerate(problems.hand_regions):
        h = hand.region(name)
        hp = params[c][0]
        p_link, n_link = h.region.evaluate(hp)
        li = hand.link_index(h.link)
        ph, nh = pose.points(li, p_link), pose.directions(li, n_link)
        po = np.einsum("bij,bj->bi", T[:, :3, :3], problems.points[idx, c]) + T[:, :3, 3]
        no = np.einsum("bij,bj->bi", T[:, :3, :3], problems.normals[idx, c])
        dist.append(np.linalg.norm(ph - po, axis=1))
        ang.append(np.degrees(angle_between(nh, -no)))
        hreg_v.append(h.region.domain_violation(hp))
    z = np.zeros((len(idx), len(problems.hand_regions)))
    return np.stack(dist, 1), np.stack(ang, 1), np.stack(hreg_v, 1), z


def contact_checks_tasks(tasks, idx, pose: HandPose, T, params):
    """Contact residuals of tasks: the foundation's :func:`contact_residuals`, one task at a
    time, and the object penetration of the links that move with the task (idle fingers are
    cleared afterwards by :func:`~prehension.tasks.idle.settle_idle_fingers`) [mm]."""
    out = [[], [], [], [], []]
    for s, i in enumerate(idx):
        sub = HandPose(pose.R_palm_link[s : s + 1], pose.r_palm_link[s : s + 1], pose.axis_palm[s : s + 1], pose.origin_palm[s : s + 1])
        prm = [(h[s : s + 1], o[s : s + 1]) for h, o in params]
        res = contact_residuals(tasks[i], sub, T[s : s + 1], prm)
        for k, key in enumerate(("distance_mm", "normal_angle_deg", "hand_region", "object_region")):
            out[k].append(res[key][0])
        out[4].append(_object_depth(tasks[i], sub, T[s], res["hand_point"][0]))
    return tuple(np.array(v) for v in out)


def check_tasks(group: Group, tasks, idx, x, R, t, options: LocalOptions):
    """As :func:`check`, for tasks, with the one residual function itself: each local
    solution goes through :func:`~prehension.results.make_solution` (strict, else with the
    acceptance tolerances; idle fingers moved clear of the object there).  Also returns
    the strict solutions made (``None`` elsewhere), which the records keep."""
    S = len(idx)
    q = group.q_of(x)
    T = np.zeros((S, 4, 4))
    T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, t, 1.0
    params = group.params_of(x)
    level, dmax, amax, sols = np.zeros(S, dtype=np.int64), np.zeros(S), np.zeros(S), [None] * S
    for s, i in enumerate(idx):
        config = Configuration(q[s], T[s], tuple((h[s], o[s]) for h, o in params))
        k, held = first_solution(tasks[i], config, (STRICT, options.acceptance))  # evaluated once for both
        sols[s] = held if k == 0 else None
        level[s] = 2 if k == 0 else (1 if k == 1 else 0)
        if held is not None:
            dmax[s], amax[s] = held.report.worst("contact_distance"), held.report.worst("contact_normal")
        else:
            dmax[s] = amax[s] = np.inf
    return Verdicts(level, q, T, params, dmax, amax, sols)


def _object_depth(task: Task, pose: HandPose, T, hand_points_palm) -> float:
    """The deepest moving link or pad in the object [mm] (as the residual function measures them)."""
    if not task.object.collides:
        return 0.0
    from ...tasks.object_collision import link_penetrations, moving_links, pad_penetrations

    points = (hand_points_palm - T[:3, 3]) @ T[:3, :3]
    links = link_penetrations(task, pose, T, points, moving_links(task)).values()
    return max(max(links, default=0.0), max(pad_penetrations(task, pose, T, points).values(), default=0.0))


def check(group: Group, contact_fn, idx, x, R, t, options: LocalOptions):
    """Which local solutions pass, judged with the foundation's batch functions: their
    :class:`Verdicts` (no solutions made: ``None`` for each)."""
    hand = group.hand
    S = len(idx)
    q = group.q_of(x)
    T = np.zeros((S, 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = t
    T[:, 3, 3] = 1.0
    params = group.params_of(x)
    pose = forward_kinematics(hand, q)
    depth = max_penetration(hand, pose)
    lim = np.degrees(np.max(limit_violations(hand, q), axis=1))
    cpl = coupling_violations(hand, q)
    cpl = np.degrees(np.max(cpl, axis=1)) if cpl.shape[1] else np.zeros(S)
    dist, ang, hreg, oreg, *rest = contact_fn(idx, pose, T, params)
    odepth = rest[0] if rest else np.zeros(S)  # object penetration (tasks with a solid)
    dmax, amax = dist.max(axis=1), ang.max(axis=1)
    region = np.maximum(hreg.max(axis=1), oreg.max(axis=1))

    def passes(tol: Tolerances):
        return (
            (dmax <= tol.contact_mm) & (amax <= tol.normal_deg) & (region <= tol.region)
            & (lim <= tol.limit_deg) & (cpl <= tol.coupling_deg)
            & ((depth <= tol.penetration_mm) | (not options.check_collisions))
            & ((odepth <= tol.object_penetration_mm) | (not options.check_collisions))
        )  # fmt: skip

    level = np.where(passes(STRICT), 2, np.where(passes(options.acceptance), 1, 0))
    return Verdicts(level, q, T, params, dmax, amax, [None] * S)
