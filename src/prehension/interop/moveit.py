"""A result's grasps as ``moveit_msgs/Grasp`` messages (ROS 2 field layout), in YAML or JSON.

The message definitions (moveit_msgs ``Grasp.msg``, ``GripperTranslation.msg``;
trajectory_msgs ``JointTrajectory.msg``, ``JointTrajectoryPoint.msg``; geometry_msgs
``PoseStamped``, ``Vector3Stamped``; std_msgs ``Header``; builtin_interfaces ``Duration``)
were read from docs.ros.org (moveit_msgs for jazzy) and github.com/moveit/moveit_msgs.
Each grasp is a mapping with exactly the message's fields, so that ROS 2's
``rosidl_runtime_py.set_message_fields(moveit_msgs.msg.Grasp(), entry)`` fills a message:

* ``id``: ``"<task>/<solution number>"``.
* ``grasp_pose`` (``PoseStamped``): with ``frame="object"`` (default), the **palm's** pose
  in the object frame, ``header.frame_id`` the object's name: what MoveIt's pick expects
  (the pose of the end-effector's parent link, here the hand's palm link, relative to
  the object, which MoveIt places in its planning frame).  With ``frame="palm"``, the
  **object's** pose in the palm frame, ``header.frame_id`` the palm link (for tools that
  keep grasps hand-relative).  Metres; quaternions in ROS's ``x, y, z, w`` order.
* ``pre_grasp_posture`` (``JointTrajectory``): the solution's pre-grasp angles
  (``docs/quality.md``), one point at ``time_from_start`` 0.5 s; empty (no joint names,
  no points) when the solution has no pre-grasp.  ``grasp_posture``: the grasp's angles at
  0.5 s, then, when the solution has them, the squeeze targets at 1.0 s (the angles a
  position-controlled hand is sent to so that it presses the object, as DexGraspBench's
  ``squeeze_qpos``).  ``joint_names`` are the hand's joint angles in the hand's order
  (every dof, coupled ones included), radians; ``header.frame_id`` the palm link.
  Velocities, accelerations and efforts are empty (prehension computes none).
* ``grasp_quality``: the solution's epsilon quality (``quality.epsilon``), 0 without one.
* ``pre_grasp_approach`` (``GripperTranslation``): with a pre-grasp, the palm approaches
  along the unit vector from the palm's origin to the centroid of the contacts' hand
  points, in the palm frame (``frame_id`` the palm link), ``desired_distance`` the
  pre-grasp's back-off distance [m] and ``min_distance`` 0.  prehension judges the
  pre-grasp at the grasp's palm pose only (fingers backed off in place): the approach
  motion itself is MoveIt's to check.  Without a pre-grasp, all zero.
* ``post_grasp_retreat``, ``post_place_retreat``: zero; ``max_contact_force``: 0 (MoveIt:
  disabled); ``allowed_touch_objects``: the object's name.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InvalidTask
from ..geometry.rotations import invert_transform
from ..hands.qpos import base_from_transform

__all__ = ["MOVEIT_FRAMES", "moveit_grasps", "moveit_text"]

MOVEIT_FRAMES = ("object", "palm")
_PRE_S, _GRASP_S, _SQUEEZE_S = 0.5, 0.5, 1.0  # time_from_start of each posture's points [s]


def _header(frame_id: str) -> dict:
    return {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id}


def _duration(seconds: float) -> dict:
    sec = int(seconds)
    return {"sec": sec, "nanosec": int(round((seconds - sec) * 1e9))}


def _pose(T_a_b: np.ndarray) -> dict:
    """The ``geometry_msgs/Pose`` of frame ``b`` in frame ``a`` (``T_a_b`` [mm]): metres,
    the quaternion ``x, y, z, w`` with ``w >= 0``."""
    x, y, z, qw, qx, qy, qz = (float(v) for v in base_from_transform(invert_transform(T_a_b)))
    return {"position": {"x": x, "y": y, "z": z}, "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}


def _trajectory(palm: str, names, points) -> dict:
    """A ``trajectory_msgs/JointTrajectory``: ``points`` is ``[(angles by name, seconds)]``."""
    rows = [{"positions": [float(angles[d]) for d in names], "velocities": [], "accelerations": [], "effort": [],
             "time_from_start": _duration(t)} for angles, t in points]  # fmt: skip
    return {"header": _header(palm), "joint_names": list(names) if rows else [], "points": rows}


def _translation(frame_id: str, direction, distance_m: float) -> dict:
    x, y, z = (float(v) for v in direction)
    return {"direction": {"header": _header(frame_id), "vector": {"x": x, "y": y, "z": z}},
            "desired_distance": float(distance_m), "min_distance": 0.0}  # fmt: skip


def _approach(palm: str, entry: dict) -> dict:
    """The palm's approach of a solution with a pre-grasp (see the module docstring)."""
    pre = entry.get("pregrasp")
    points = [c.get("hand_point") for c in entry.get("contacts") or [] if isinstance(c, dict)]
    if not pre or not points:
        return _translation("", (0.0, 0.0, 0.0), 0.0)
    centre = np.mean(np.asarray(points, dtype=float), axis=0)
    norm = float(np.linalg.norm(centre))
    direction = centre / norm if norm > 1e-9 else np.zeros(3)
    return _translation(palm, direction, float(pre.get("back_off_mm", 0.0)) / 1000.0)


def _grasp(task, record, entry: dict, k: int, frame: str) -> dict:
    hand, names = task.hand, task.hand.dof_names
    T_palm_object = np.asarray(record.T_palm_object, dtype=float)
    if frame == "object":  # the palm in the object frame
        pose, frame_id = _pose(invert_transform(T_palm_object)), task.object.name
    else:  # the object in the palm frame
        pose, frame_id = _pose(T_palm_object), hand.palm
    grasp_points = [(record.joint_angles, _GRASP_S)] + ([(record.squeeze, _SQUEEZE_S)] if record.squeeze else [])
    quality = entry.get("quality") if isinstance(entry.get("quality"), dict) else {}
    return {
        "id": f"{task.name}/{k}",
        "pre_grasp_posture": _trajectory(hand.palm, names, [(record.pregrasp, _PRE_S)] if record.pregrasp else []),
        "grasp_posture": _trajectory(hand.palm, names, grasp_points),
        "grasp_pose": {"header": _header(frame_id), "pose": pose},
        "grasp_quality": float(quality.get("epsilon") or 0.0),
        "pre_grasp_approach": _approach(hand.palm, entry),
        "post_grasp_retreat": _translation("", (0.0, 0.0, 0.0), 0.0),
        "post_place_retreat": _translation("", (0.0, 0.0, 0.0), 0.0),
        "max_contact_force": 0.0,
        "allowed_touch_objects": [task.object.name],
    }


def moveit_grasps(task, records, entries, first: int = 0, frame: str = "object") -> list[dict]:
    """The ``moveit_msgs/Grasp`` mappings of ``records`` (:class:`~.records.GraspRecord`) and
    their result ``entries`` (the solutions' dicts), numbered from ``first``."""
    if frame not in MOVEIT_FRAMES:
        raise InvalidTask(f"unknown grasp_pose frame {frame!r}; use one of {list(MOVEIT_FRAMES)}")
    return [_grasp(task, r, e, first + i, frame) for i, (r, e) in enumerate(zip(records, entries))]


def moveit_text(grasps: list[dict], path: Path) -> str:
    """The file's text: YAML for ``.yaml``/``.yml``, else JSON; a list of grasps."""
    if path.suffix.lower() in (".yaml", ".yml"):
        import yaml

        head = "# moveit_msgs/Grasp[] written by prehension (ROS 2 field layout; metres, quaternions x, y, z, w)\n"
        return head + yaml.safe_dump(grasps, sort_keys=False, default_flow_style=None)
    return json.dumps(grasps, indent=1, allow_nan=False) + "\n"
