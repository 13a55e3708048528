"""The one result type both solvers return, and the result file anyone can re-check.

A :class:`SolveResult` is shaped like scipy's ``OptimizeResult`` (``success``, ``status``,
``message``, counters) plus what a grasp needs.  Each :class:`Solution` holds the joint
angles by name, the object pose, **every link's pose in the palm frame** and each
contact's points, normals and region parameters, and the residual report that verified
it (:func:`prehension.verification.residuals.evaluate`): a solver never returns a configuration
that has not passed it.

Result files are JSON (``prehension: result/1``) and embed the task (as in a task file),
so that ``prehension check`` -- or any other program -- can re-verify them alone.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .atomic import read_json, to_plain, write_json_atomic
from .errors import InvalidTask, PrehensionError
from .hands.kinematics import forward_kinematics
from .tasks.geometry_record import collision_geometry
from .tasks.idle import settle_idle_fingers
from .tasks.model import Configuration, Task
from .verification.residuals import ResidualReport, Tolerances, _evaluate

__all__ = [
    "Status",
    "ContactResult",
    "Solution",
    "SolveResult",
    "make_solution",
    "first_solution",
    "result_to_dict",
    "write_result",
    "read_result",
    "result_task",
    "RESULT_TAG",
]

RESULT_TAG = "result/1"


class Status:
    """``SolveResult.status`` values (also the CLI's exit codes, see ``prehension.cli``)."""

    SOLVED = "solved"  # every constraint within the strict default Tolerances
    INFEASIBLE = "infeasible"  # proven: every box pruned (complete solver only)
    GAVE_UP = "gave_up"  # limits reached without a verified solution or a proof
    APPROXIMATE = "approximate"  # only when asked for: within looser tolerances, never "solved"

    ALL = (SOLVED, INFEASIBLE, GAVE_UP, APPROXIMATE)


@dataclass(frozen=True, eq=False)
class ContactResult:
    """One contact of a solution, in the palm frame (mm, unit normals)."""

    name: str
    hand_point: np.ndarray
    hand_normal: np.ndarray
    object_point: np.ndarray
    object_normal: np.ndarray
    hand_params: np.ndarray
    object_params: np.ndarray
    distance_mm: float
    normal_angle_deg: float


@dataclass(frozen=True, eq=False)
class Solution:
    """A verified grasp configuration.

    Attributes:
        joint_angles: every joint angle of the hand [rad], by name (hand order).
        T_palm_object: (4, 4) object pose in the palm frame [mm].
        link_poses: every link's pose ``T_palm_link`` (4, 4) [mm], by link name.
        contacts: per contact, where it is made.
        report: the residual report that verified it.
        tolerances: the tolerances it was verified with (the strict defaults for a
            solution of a ``"solved"`` result).
        idle_moved: dofs of fingers that do not take part whose angle differs from the
            task's idle value (moved within their limits to clear a collision); every
            other idle dof is at its idle value.
    """

    joint_angles: Mapping[str, float]
    T_palm_object: np.ndarray
    link_poses: Mapping[str, np.ndarray]
    contacts: tuple[ContactResult, ...]
    report: ResidualReport
    tolerances: Tolerances = Tolerances()
    idle_moved: tuple[str, ...] = ()

    @property
    def q(self) -> np.ndarray:
        """(n_dof,) joint angles [rad] in hand order."""
        return np.array(list(self.joint_angles.values()))

    def qpos(self, model) -> np.ndarray:
        """The MuJoCo ``qpos`` ``(7 + n_dof,)`` of this grasp for ``model`` (the
        :class:`~prehension.hands.model.Hand`, or a task): the palm's pose in the object frame
        (``x, y, z`` [m], quaternion ``w, x, y, z``), then the joint angles [rad] in the MJCF's
        order.  The inverse is :func:`prehension.hands.qpos.qpos_configuration`; frames and
        order: :mod:`prehension.hands.qpos`, docs/interop.md."""
        from .hands.qpos import solution_qpos

        return solution_qpos(self, model)

    def configuration(self) -> Configuration:
        return Configuration(
            self.q, self.T_palm_object, tuple((c.hand_params, c.object_params) for c in self.contacts)
        )


@dataclass(frozen=True, eq=False)
class SolveResult:
    """What a solver answers (``OptimizeResult``-like).

    Attributes:
        task: the task solved.
        method: ``"complete"`` or ``"local"``.
        status: a :class:`Status` value; ``success`` is ``status == "solved"``.
        message: one sentence for people.
        solutions: verified solutions (empty unless solved).
        seconds: wall-clock time.
        stats: solver counters (boxes, LPs, initial poses, iterations...).
        unverified_boxes: complete solver: boxes below sigma holding no verified point,
            as ``(lower, upper)`` arrays over the system's variables.  Never solutions.
    """

    task: Task
    method: str
    status: str
    message: str
    solutions: tuple[Solution, ...] = ()
    seconds: float = 0.0
    stats: Mapping[str, Any] = field(default_factory=dict)
    unverified_boxes: tuple[tuple[np.ndarray, np.ndarray], ...] = ()

    @property
    def success(self) -> bool:
        return self.status == Status.SOLVED


def make_solution(task: Task, config: Configuration, tolerances: Tolerances = Tolerances()) -> Solution | None:
    """Verify ``config`` against ``task``; the :class:`Solution` if it passes, else ``None``.

    This is the only way solvers build solutions, so every returned configuration has been
    re-checked against the original constraints.  Idle fingers that pass through the
    object are first moved clear of it (:func:`~prehension.tasks.idle.settle_idle_fingers`):
    they make no contact, so only collisions depend on them.
    """
    return first_solution(task, config, (tolerances,))[1]


def first_solution(task: Task, config: Configuration, levels) -> tuple[int, Solution | None]:
    """``(k, make_solution(task, config, levels[k]))`` for the first of the tolerances
    ``levels`` that ``config`` passes; ``(-1, None)`` when it passes none.

    The configuration is evaluated once for all the levels that settle idle fingers alike
    (the same ``object_penetration_mm``): the residual values do not depend on the
    tolerances, only the verdict does (:meth:`ResidualReport.judged`).
    """
    config.check_against(task)
    evaluated: dict = {}  # object_penetration_mm -> (settled configuration, pose, report)
    for k, tol in enumerate(levels):
        key = tol.object_penetration_mm
        if key not in evaluated:
            settled = settle_idle_fingers(task, config, key)
            pose = forward_kinematics(task.hand, settled.joint_angles)
            evaluated[key] = (settled, pose, _evaluate(task, settled, tol, pose), tol)  # evaluate(): shapes checked above
        settled, pose, report, judged_with = evaluated[key]
        if tol != judged_with:
            report = report.judged(tol)
        if report.ok:
            return k, _solution(task, settled, pose, report, tol)
    return -1, None


def _solution(task: Task, config: Configuration, pose, report: ResidualReport, tolerances: Tolerances) -> Solution:
    T = pose.T_palm_link[0]
    contacts = tuple(
        ContactResult(
            s.name, s.hand_point, s.hand_normal, s.object_point, s.object_normal,
            s.hand_params, s.object_params, s.distance_mm, s.normal_angle_deg,
        )  # fmt: skip
        for s in report.contacts
    )
    q = config.joint_angles
    moved_mask = (~task.active_mask & (q != task.idle_vector)).tolist()  # idle dofs that settling moved
    moved = tuple(d for d, m in zip(task.hand.dof_names, moved_mask) if m)
    return Solution(
        dict(zip(task.hand.dof_names, q.tolist())),  # Python floats, the same values
        config.T_palm_object.copy(),
        dict(zip(task.hand.link_names, T)),  # T[i] per link, in order
        contacts,
        report,
        tolerances,
        moved,
    )


# -- files ------------------------------------------------------------------------------
def _solution_to_dict(sol: Solution, quality: dict, approach: dict) -> dict:
    return {
        "joint_angles_deg": {k: float(np.degrees(v)) for k, v in sol.joint_angles.items()},
        "joint_angles_rad": dict(sol.joint_angles),
        "T_palm_object": sol.T_palm_object.tolist(),
        "link_poses": {k: v.tolist() for k, v in sol.link_poses.items()},
        "contacts": [
            {
                "name": c.name,
                "hand_point": c.hand_point.tolist(),
                "hand_normal": c.hand_normal.tolist(),
                "object_point": c.object_point.tolist(),
                "object_normal": c.object_normal.tolist(),
                "hand_params": c.hand_params.tolist(),
                "object_params": c.object_params.tolist(),
                "distance_mm": c.distance_mm,
                "normal_angle_deg": c.normal_angle_deg,
            }
            for c in sol.contacts
        ],
        "worst": {k: sol.report.worst(k) for k in sorted(sol.report.kinds)},
        **_object_depths(sol.report),
        "tolerances": asdict(sol.tolerances),
        "idle_moved": list(sol.idle_moved),
        "quality": quality,
        **approach,
    }


def _object_depths(report: ResidualReport) -> dict:
    """``{"object_depths_mm": {"links": {link: depth}, "pads": {contact: depth}}}`` of a
    report whose object collides (its ``object_collision`` and ``pad_collision`` checks
    [mm]), else ``{}``."""
    links = {c.name: c.value for c in report.checks if c.kind == "object_collision"}
    pads = {c.name: c.value for c in report.checks if c.kind == "pad_collision"}
    return {"object_depths_mm": {"links": links, "pads": pads}} if links or pads else {}


def result_to_dict(
    result: SolveResult, qualities: Sequence[Mapping], approaches: Sequence[Mapping] | None = None, *,
    embed_task: bool = True, physics=None,
) -> dict:  # fmt: skip
    """A JSON-ready dict: units in keys, the task embedded (unless ``embed_task`` is false:
    a batch stores each distinct task once and its records refer to it); the collision
    geometry that judged it (:func:`~prehension.tasks.geometry_record.collision_geometry`,
    without the per-link table when the task is not embedded).

    Args:
        qualities: each solution's ``"quality"`` entry, measured by the caller
            (:func:`prehension.quality.quality_entries`; a result file stores what was
            measured, it measures nothing itself).
        physics: per solution, its physics verdict (``solve --hold``,
            :class:`~prehension.sim.PhysicsReport` as a dict, or ``None``), stored as
            ``"physics"``.
        approaches: each solution's pre-grasp and squeeze targets (``"pregrasp"``,
            ``"squeeze"``), made by the caller
            (:func:`prehension.pregrasp.approach_entries_of`); ``None``: none stored (a batch
            record leaves them out: 3-19 ms a solution on the built-ins, more than a warm
            local solve; docs/batch.md).
    """
    from .tasks.format.embedded import embedded_files
    from .tasks.yaml_io import task_to_dict

    head = {
        "prehension": RESULT_TAG,
        "units": {"length": "mm", "angle": "rad unless the key ends in _deg"},
        "frames": "poses are T_palm_X (x_palm = T x_X); points and normals in the palm frame",
    }
    if embed_task:
        head["task"] = task_to_dict(result.task, hand_inline=True)  # a result file is re-checkable alone
        files = embedded_files(head["task"])  # ... also elsewhere: the object's mesh travels with it
        if files:
            head["files"] = files
    _one_per_solution(qualities, result, "quality entries", "prehension.quality.quality_entries")
    if approaches is None:
        approaches = [{}] * len(result.solutions)
    _one_per_solution(approaches, result, "pre-grasp and squeeze entries", "prehension.pregrasp.approach_entries_of")
    if physics is None:
        physics = [None] * len(result.solutions)
    _one_per_solution(physics, result, "physics verdicts")
    return {
        **head,
        "method": result.method,
        "status": result.status,
        "success": result.success,
        "message": result.message,
        "seconds": result.seconds,
        "stats": to_plain(dict(result.stats)),
        "collision_geometry": collision_geometry(result.task, compact=not embed_task),
        "solutions": [_with_physics(_solution_to_dict(s, q, a), p) for s, q, a, p in zip(result.solutions, qualities, approaches, physics)],
        "unverified_boxes": [{"lower": lo.tolist(), "upper": hi.tolist()} for lo, hi in result.unverified_boxes],
    }


def _one_per_solution(entries, result: SolveResult, what: str, maker: str = "") -> None:
    """Raise unless ``entries`` is a sequence of one entry per solution of ``result``
    (``maker``: the function that makes them, named in the message)."""
    if isinstance(entries, (list, tuple)) and len(entries) == len(result.solutions):
        return
    given = f"{len(entries)} {what}" if isinstance(entries, (list, tuple)) else f"{type(entries).__name__} as {what}"
    made = f"; {maker}(result) makes them" if maker else ""
    raise PrehensionError(f"result_to_dict: {given} given for {len(result.solutions)} solutions (a list: one per "
                          f"solution{made})")  # fmt: skip


def _with_physics(entry: dict, physics) -> dict:
    if physics is not None:
        entry["physics"] = physics
    return entry


def write_result(
    result: SolveResult, path, qualities: Sequence[Mapping], approaches: Sequence[Mapping] | None = None, physics=None,
) -> None:  # fmt: skip
    """Write the result file atomically (never a half-written file); ``qualities`` (each
    solution's quality entry, e.g. :func:`prehension.quality.quality_entries`),
    ``approaches`` (e.g. :func:`prehension.pregrasp.approach_entries_of`) and ``physics``
    as in :func:`result_to_dict`: the file stores what the caller measured."""
    write_json_atomic(path, result_to_dict(result, qualities, approaches, physics=physics))


def read_result(path) -> tuple[Task, dict]:
    """The task embedded in a result file and the file's dict (for re-checking)."""
    path = Path(path)
    return result_task(read_json(path, "result file"), str(path), path.parent)


def result_task(data, source: str, base_dir: Path) -> tuple[Task, dict]:
    """The task embedded in a result dict (read from ``source``) and the dict itself; the
    files it names are read from the copies the result carries (``files``, see
    :mod:`prehension.tasks.format.embedded`)."""
    from .tasks.format.embedded import task_with_files
    from .tasks.yaml_io import task_from_dict

    if not isinstance(data, dict) or data.get("prehension") != RESULT_TAG:
        raise InvalidTask(f"{source}: not a prehension result file (expected 'prehension: {RESULT_TAG}')")
    if not isinstance(data.get("task"), dict):
        raise InvalidTask(f"{source}: the result file has no 'task' (the task it answers is embedded there); "
                          "nothing can be checked or drawn without it")  # fmt: skip
    task_dict = task_with_files(data["task"], data.get("files"), source)  # the object's mesh as the result carries it
    return task_from_dict(task_dict, base_dir=base_dir, source=f"{source} (embedded task)"), data

