"""A grasp as the field's records carry it: one value between prehension's result files and
the peers' formats (:mod:`.dexgraspbench`, :mod:`.dexgraspnet`, :mod:`.json_m`).

A :class:`GraspRecord` holds what every format can say: the object's pose in the palm frame,
the joint angles of the grasp and, when known, of the pre-grasp and the squeeze, and the
object's mesh file with its scale.  :func:`records_from_result` reads them from a result
file's dict; the formats turn them into their own layout and back.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..errors import InvalidTask
from ..hands.model import Hand
from ..hands.qpos import grasp_qpos, qpos_configuration

__all__ = ["GraspRecord", "records_from_result", "record_from_qpos", "object_file", "check_metres", "MAX_BASE_M"]

MAX_BASE_M = 10.0  # a palm farther than this from the object [m] is taken for millimetres written as metres


def check_metres(T_palm_object, source: str) -> None:
    """Refuse a palm more than :data:`MAX_BASE_M` from the object: a record in metres that
    holds millimetres (a hand 1000x too far) is named, not judged as a grasp that misses."""
    far = float(np.linalg.norm(np.asarray(T_palm_object, dtype=float)[:3, 3])) / 1000.0
    if far > MAX_BASE_M:
        raise InvalidTask(f"{source}: the palm stands {far:.4g} m from the object; the record's lengths are metres "
                          "(were millimetres written?)")  # fmt: skip


@dataclass(frozen=True, eq=False)
class GraspRecord:
    """One grasp of ``hand``, format-free.

    Attributes:
        T_palm_object: (4, 4) the object's pose in the palm frame [mm].
        joint_angles: the grasp's angles [rad] by dof name (every dof of the hand).
        pregrasp: the pre-grasp's angles [rad] by dof name, or ``None`` (same base pose).
        squeeze: the squeeze targets [rad] by dof name, or ``None`` (same base pose).
        object_path: the object's mesh file ("" when the object has none).
        object_scale_mm: mm per unit of that file (1000: a file in metres).
        source: where the record was read (for messages).
    """

    T_palm_object: np.ndarray
    joint_angles: Mapping[str, float]
    pregrasp: Mapping[str, float] | None = None
    squeeze: Mapping[str, float] | None = None
    object_path: str = ""
    object_scale_mm: float = 1.0
    source: str = ""

    def qpos(self, hand: Hand, which: str = "grasp") -> np.ndarray | None:
        """``(7 + n_dof,)`` MuJoCo qpos of the grasp, the pre-grasp or the squeeze
        (:func:`~prehension.hands.qpos.grasp_qpos`); ``None`` when the record lacks it."""
        angles = {"grasp": self.joint_angles, "pregrasp": self.pregrasp, "squeeze": self.squeeze}[which]
        return None if angles is None else grasp_qpos(hand, self.T_palm_object, angles)


def object_file(task) -> tuple[str, float]:
    """``(path, mm per unit)`` of the task's object mesh: its solid's file, else its display
    mesh file (mm); ``("", 1.0)`` when the object is made of primitives or regions only."""
    solid = task.object.solid
    path = getattr(solid, "path", None)
    if path:
        return str(path), float(solid.scale)
    return (str(task.object.mesh_file), 1.0) if task.object.mesh_file else ("", 1.0)


def records_from_result(task, data: dict, solution: int | None = None, source: str = "result") -> list[GraspRecord]:
    """The grasps of a result dict (``prehension: result/1``) of ``task``: every solution,
    or only the ``solution``-th.

    Raises:
        InvalidTask: the result holds no solution, or ``solution`` is out of range.
    """
    entries = data.get("solutions") or []
    if not entries:
        raise InvalidTask(f"{source}: the result holds no solution (status {data.get('status')!r}); nothing to export")
    if solution is not None:
        if not 0 <= solution < len(entries):
            raise InvalidTask(f"{source}: --solution {solution} is out of range; the result has solutions 0..{len(entries) - 1}")
        entries = [entries[solution]]
    path, scale = object_file(task)
    return [_record(task, e, path, scale, source) for e in entries]


def _angles(entry, task, what: str, source: str) -> dict[str, float]:
    try:
        return {d: float(entry[d]) for d in task.hand.dof_names}
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidTask(f"{source}: the {what} does not name every dof of hand {task.hand.name!r} ({exc})") from None


def _record(task, entry: dict, path: str, scale: float, source: str) -> GraspRecord:
    T = np.asarray(entry["T_palm_object"], dtype=float)
    grasp = _angles(entry.get("joint_angles_rad"), task, "solution's joint_angles_rad", source)
    pre = entry.get("pregrasp", {}).get("joint_angles_rad")
    squeeze = entry.get("squeeze", {}).get("joint_angles_rad")
    return GraspRecord(
        T, grasp,
        None if pre is None else _angles(pre, task, "pre-grasp", source),
        None if squeeze is None else _angles(squeeze, task, "squeeze", source),
        path, scale, source,
    )  # fmt: skip


def record_from_qpos(hand: Hand, grasp, pregrasp=None, squeeze=None, *, object_path: str = "",
                     object_scale_mm: float = 1.0, source: str = "record") -> GraspRecord:  # fmt: skip
    """A record of ``hand`` from MuJoCo qpos vectors (:func:`~prehension.hands.qpos.qpos_configuration`);
    the pre-grasp and squeeze keep their own angles, the base pose is the grasp's."""
    q, T = qpos_configuration(grasp, hand, f"{source}: grasp qpos")
    check_metres(T, source)
    names = hand.dof_names

    def angles(v, what):
        return None if v is None else dict(zip(names, qpos_configuration(v, hand, f"{source}: {what} qpos")[0].tolist()))

    return GraspRecord(T, dict(zip(names, q.tolist())), angles(pregrasp, "pre-grasp"), angles(squeeze, "squeeze"),
                       object_path, float(object_scale_mm), source)  # fmt: skip
