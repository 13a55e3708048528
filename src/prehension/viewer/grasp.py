"""What a picture shows: every link's pose, the object's pose and the contacts, in the palm frame.

A :class:`GraspPose` comes from one of four places:

* a solution in memory (:func:`pose_from_solution`) or any configuration
  (:func:`pose_from_configuration`, which evaluates the contacts);
* a solution stored in a result file (:func:`pose_from_result`: the file's own link
  poses, object pose and contact points, as written);
* a task alone (``None`` here; :func:`prehension.viewer.scene.build_scene` makes it): the
  hand in its *reference pose* (:func:`reference_angles`: every joint angle at the task's
  idle value, zero for the dofs that take part, clamped into its limits and coupled) and
  the object beside it (:func:`beside_the_hand`), with no contacts made.

:func:`load_grasp` turns whatever a user names on the command line into a task and a pose.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import InvalidTask, PrehensionError, not_a_file
from ..frozen import FrozenMap
from ..hands.kinematics import forward_kinematics
from ..tasks.model import Configuration, Task

__all__ = [
    "ContactMarker", "Stage", "GraspPose", "LoadedGrasp", "link_poses", "reference_angles", "beside_the_hand",
    "pose_from_configuration", "pose_from_solution", "pose_from_result", "load_grasp",
]  # fmt: skip

REFERENCE = "reference"  # GraspPose.status of a task shown without a solution


@dataclass(frozen=True, eq=False)
class ContactMarker:
    """A contact as made by a grasp: points (3,) [mm] and unit normals (3,), palm frame."""

    name: str
    hand_point: np.ndarray
    hand_normal: np.ndarray
    object_point: np.ndarray
    object_normal: np.ndarray


@dataclass(frozen=True, eq=False)
class Stage:
    """A stage of an executable grasp other than the grasp itself: the hand at other joint
    angles, the object where the grasp holds it.

    Attributes:
        name: ``"pregrasp"`` (every participating finger backed off along its contact
            normal) or ``"squeeze"`` (the physics test's squeeze targets); see
            :mod:`prehension.pregrasp`.
        q: (n_dof,) joint angles [rad].
        note: one line for people (distances, collision-free or not).
    """

    name: str
    q: np.ndarray
    note: str


@dataclass(frozen=True, eq=False)
class GraspPose:
    """Where everything is.

    Attributes:
        T_palm_link: every link's pose (4, 4) [mm], by link name.
        T_palm_object: (4, 4) object pose in the palm frame [mm].
        contacts: the contacts made (empty for a task shown without a solution).
        status: ``"solved"``, ``"infeasible"``, ``"gave_up"`` (a result file's status) or
            ``"reference"`` (a task alone).
        note: one line for people ("solution 1 of 3, local solver", "reference pose").
        max_distance_mm: largest contact distance of the solution (``None`` without one).
        max_angle_deg: largest contact normal misalignment (``None`` without one).
        stages: the pre-grasp and squeeze a result file stores with the solution
            (:class:`Stage`; empty when it stores none or the grasp is not from a file).
    """

    T_palm_link: Mapping[str, np.ndarray]
    T_palm_object: np.ndarray
    contacts: tuple[ContactMarker, ...] = ()
    status: str = REFERENCE
    note: str = "reference pose"
    max_distance_mm: float | None = None
    max_angle_deg: float | None = None
    stages: tuple[Stage, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "T_palm_link", FrozenMap({k: np.asarray(v, float) for k, v in self.T_palm_link.items()}))
        object.__setattr__(self, "T_palm_object", np.asarray(self.T_palm_object, dtype=float))
        object.__setattr__(self, "contacts", tuple(self.contacts))
        object.__setattr__(self, "stages", tuple(self.stages))

    @property
    def has_solution(self) -> bool:
        return bool(self.contacts)


def link_poses(task: Task, q: np.ndarray) -> dict[str, np.ndarray]:
    """Every link's pose ``T_palm_link`` (4, 4) [mm] at joint angles ``q (n_dof,)`` [rad], by name."""
    T = forward_kinematics(task.hand, q).T_palm_link[0]  # (n_links, 4, 4)
    return {name: T[i] for i, name in enumerate(task.hand.link_names)}


def reference_angles(task: Task) -> np.ndarray:
    """(n_dof,) [rad]: the task's idle vector clamped into the limits, couplings applied."""
    hand = task.hand
    q = np.clip(task.idle_vector, hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return np.clip(q, hand.lower, hand.upper)


def beside_the_hand(hand_lo_mm, hand_hi_mm, object_lo_mm, object_hi_mm, gap_mm: float = 30.0) -> np.ndarray:
    """(4, 4) object pose that puts the object's box beside the hand's box.

    The object is not rotated; it is moved along the palm's +x axis until its box (object
    frame) lies ``gap_mm`` beyond the hand's box (palm frame), centred on it in y and z.
    Boxes are ``(3,)`` lower and upper corners [mm].
    """
    hand_lo, hand_hi = np.asarray(hand_lo_mm, float), np.asarray(hand_hi_mm, float)
    obj_lo, obj_hi = np.asarray(object_lo_mm, float), np.asarray(object_hi_mm, float)
    t = (hand_lo + hand_hi) / 2 - (obj_lo + obj_hi) / 2
    t[0] = hand_hi[0] + gap_mm - obj_lo[0]
    T = np.eye(4)
    T[:3, 3] = t
    return T


def pose_from_configuration(task: Task, config: Configuration, note: str = "configuration") -> GraspPose:
    """Any configuration: forward kinematics, and the contacts as the residual function finds them."""
    from ..verification.residuals import evaluate

    report = evaluate(task, config)
    contacts = tuple(
        ContactMarker(s.name, s.hand_point, s.hand_normal, s.object_point, s.object_normal) for s in report.contacts
    )
    return GraspPose(
        link_poses(task, config.joint_angles), config.T_palm_object, contacts,
        "solved" if report.ok else "unverified", note,
        max(s.distance_mm for s in report.contacts), max(s.normal_angle_deg for s in report.contacts),
    )  # fmt: skip


def pose_from_solution(solution, note: str = "solution") -> GraspPose:
    """A :class:`~prehension.results.Solution` (in memory)."""
    contacts = tuple(
        ContactMarker(c.name, c.hand_point, c.hand_normal, c.object_point, c.object_normal) for c in solution.contacts
    )
    return GraspPose(
        solution.link_poses, solution.T_palm_object, contacts, "solved", note,
        max(c.distance_mm for c in solution.contacts), max(c.normal_angle_deg for c in solution.contacts),
    )  # fmt: skip


def pose_from_result(task: Task, data: dict, index: int) -> GraspPose:
    """Solution ``index`` (0-based) of a result file's dict, exactly as the file states it."""
    solutions = data.get("solutions") or []
    if not 0 <= index < len(solutions):
        raise PrehensionError(_index_message(index, len(solutions), data.get("status")))
    sol = solutions[index]
    try:
        links = {name: _array(sol["link_poses"][name], (4, 4)) for name in task.hand.link_names}
        contacts = tuple(
            ContactMarker(str(c["name"]), *(_array(c[k], (3,)) for k in _CONTACT_KEYS)) for c in sol["contacts"]
        )
        T_palm_object = _array(sol["T_palm_object"], (4, 4))
        dist = max(float(c["distance_mm"]) for c in sol["contacts"])
        angle = max(float(c["normal_angle_deg"]) for c in sol["contacts"])
        stages = _stages(task, sol)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        reason = f"missing {exc}" if isinstance(exc, KeyError) else str(exc)
        raise InvalidTask(f"solution {index} of the result is malformed or from a different task: {reason}") from None
    note = f"solution {index + 1} of {len(solutions)}, {data.get('method', '?')} solver"
    return GraspPose(links, T_palm_object, contacts, data.get("status", "solved"), note, dist, angle, stages)


def _stages(task: Task, sol: dict) -> tuple[Stage, ...]:
    """The pre-grasp and squeeze a stored solution carries (:mod:`prehension.pregrasp`), with their notes."""
    out = []
    for name, entry in (("pregrasp", sol.get("pregrasp")), ("squeeze", sol.get("squeeze"))):
        if entry is None:
            continue
        q = _array([entry["joint_angles_rad"][d] for d in task.hand.dof_names], (task.hand.n_dof,))
        out.append(Stage(name, q, _pregrasp_note(entry) if name == "pregrasp" else _squeeze_note(entry)))
    return tuple(out)


def _pregrasp_note(entry: dict) -> str:
    reached = [float(r) for r in entry["reached_mm"]]
    judged = "collision-free" if entry["collision_free"] else "collides: " + ", ".join(map(str, entry["failed"]))
    return f"pre-grasp: fingers backed off {float(entry['back_off_mm']):g} mm (reached {min(reached):.1f}-{max(reached):.1f}), {judged}"


def _squeeze_note(entry: dict) -> str:
    depths = [float(d) for d in entry["depths_mm"]]
    return f"squeeze: {entry['kind']} {float(entry['squeeze_mm']):g} mm targets, contacts {min(depths):.1f}-{max(depths):.1f} mm deep"


_CONTACT_KEYS = ("hand_point", "hand_normal", "object_point", "object_normal")


def _array(value, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a finite float array of ``shape`` (``ValueError`` otherwise)."""
    arr = np.array(value, dtype=float)
    if arr.shape != shape or not np.all(np.isfinite(arr)):
        raise ValueError(f"expected {shape} finite numbers, got shape {arr.shape}")
    return arr


def _index_message(index: int, n: int, status) -> str:
    if n == 0:
        return f"--solution {index}: the result holds no solution (status {status}); leave --solution out to view its task"
    return f"--solution {index} is out of range: the result holds {n} solution(s), numbered 0 to {n - 1}"


@dataclass(frozen=True, eq=False)
class LoadedGrasp:
    """What the command line names: a task, and a pose to show (``None``: the reference pose)."""

    task: Task
    pose: GraspPose | None
    status: str
    source: str


def load_grasp(spec: str | Path, solution: int | None = None) -> LoadedGrasp:
    """A result file (``.json``: its solution ``solution``, default 0) or a task (built-in
    name, ``.yaml`` or ``.world``: no pose, shown in the reference pose).

    A result without a solution (infeasible, gave up) is shown as its task, with its status.
    """
    path = Path(str(spec))
    if path.suffix.lower() != ".json":
        if solution is not None:
            raise PrehensionError(f"--solution picks a solution of a result file (.json); {str(spec)!r} is a task")
        from ..tasks.library import resolve_task

        return LoadedGrasp(resolve_task(spec), None, REFERENCE, str(spec))
    if not path.is_file():
        raise InvalidTask(not_a_file("result file", path))
    from ..results import read_result

    task, data = read_result(path)
    status = str(data.get("status", "?"))
    if not data.get("solutions") and solution is None:
        return LoadedGrasp(task, None, status, str(path))
    return LoadedGrasp(task, pose_from_result(task, data, 0 if solution is None else solution), status, str(path))
