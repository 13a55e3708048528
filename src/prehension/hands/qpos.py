"""The MuJoCo ``qpos`` of a grasp: a floating base, then the hand's joints (metres, w-x-y-z).

Frames (docs/interop.md draws them):

* prehension stores a grasp as ``T_palm_object`` (4, 4) [mm]: the object's pose in the
  palm frame, ``x_palm = T_palm_object @ x_object``, and the joint angles by name [rad];
* the field's records (DexGraspBench, BODex, DexGraspNet) store the hand's **base** pose in
  the **object** frame (the object at the identity, or at a stated ``obj_pose`` in a world
  frame), in metres.  The base is the palm link's frame: the root body of the MJCF that
  ``prehension export-hand`` writes, and the palm body of an MJCF hand prehension read.

So the base pose is ``T_object_palm = inv(T_palm_object)``, its translation divided by 1000.
A ``qpos`` is ``(7 + n_dof,)``: ``x, y, z`` [m] and the unit quaternion ``w, x, y, z`` of
``T_object_palm`` (a free joint's layout in MuJoCo), then every joint angle [rad] in the
MJCF's order (:func:`qpos_joint_order`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InvalidConfiguration
from ..mujoco_log import import_mujoco
from .mjcf import compile_mjcf
from .model import Hand

__all__ = [
    "BASE_SIZE", "MM_PER_M", "QUATERNION_TOLERANCE", "qpos_joint_order", "base_from_transform", "transform_from_base",
    "grasp_qpos", "solution_qpos", "qpos_configuration",
]  # fmt: skip

BASE_SIZE = 7  # x, y, z [m], then the quaternion w, x, y, z
MM_PER_M = 1000.0
QUATERNION_TOLERANCE = 1e-6  # largest | |q| - 1 | accepted for a base quaternion read from a file


def qpos_joint_order(hand: Hand) -> tuple[str, ...]:
    """The hand's dof names in the order of its MJCF's ``qpos``.

    A hand read from an MJCF file (``hand.source.format == "mjcf"``) takes the order of
    MuJoCo's joints when it compiles the file (:func:`_mjcf_joint_names`: includes,
    defaults and all; without MuJoCo, the ``<joint>`` elements under ``<worldbody>`` as
    written, which is the same order for a file without includes); its dofs the file does
    not name follow in the hand's order.  Any other hand takes the hand's own dof order,
    the order of the MJCF that ``prehension export-hand`` writes for it.  Only hinge
    joints are dofs of a hand (slide, ball and free joints are not modelled,
    :mod:`prehension.hands.mjcf`), so they have no place in the record.
    """
    names = hand.dof_names
    source = hand.source
    if source is None or source.format != "mjcf":
        return names
    known = set(names)
    order = [n for n in dict.fromkeys(_mjcf_joint_names(source.path, source.sha256)) if n in known]
    return tuple(order) + tuple(n for n in names if n not in set(order))


@lru_cache(maxsize=16)
def _mjcf_joint_names(path: str, sha256: str) -> tuple[str, ...]:
    """Joint names of an MJCF file in MuJoCo's order (``()`` when the file cannot be read:
    the hand's own order is then used).  ``sha256`` keys the cache to the file's bytes."""
    try:
        mujoco = import_mujoco()
    except ImportError:
        mujoco = None
    try:
        if mujoco is not None:
            m = compile_mjcf(path)  # the hand reader's own compile: meshes MuJoCo cannot read go through trimesh
            return tuple(m.joint(j).name for j in range(m.njnt))
        world = ET.parse(Path(path)).getroot().find("worldbody")
        return tuple(j.get("name") for j in world.iter("joint") if j.get("type") != "free")
    except Exception:  # noqa: BLE001 -- moved, changed or unreadable since the hand was read
        return ()


def base_from_transform(T_palm_object) -> np.ndarray:
    """``(7,)`` the palm's pose in the object frame: ``x, y, z`` [m], ``w, x, y, z``.

    ``T_palm_object``: (4, 4) [mm].  The quaternion has ``w >= 0`` (``q`` and ``-q`` are the
    same rotation; the sign is fixed so that a file's numbers are reproducible)."""
    T = np.asarray(T_palm_object, dtype=float)
    R_object_palm = T[:3, :3].T
    t_object_palm = -R_object_palm @ T[:3, 3]
    x, y, z, w = Rotation.from_matrix(R_object_palm).as_quat()
    quat = np.array([w, x, y, z])
    if quat[0] < 0:
        quat = -quat
    return np.concatenate([t_object_palm / MM_PER_M, quat])


def transform_from_base(base, source: str = "base pose") -> np.ndarray:
    """``T_palm_object`` (4, 4) [mm] of a palm pose in the object frame ``(7,)``
    (``x, y, z`` [m], ``w, x, y, z``), the inverse of :func:`base_from_transform`.

    Raises:
        InvalidConfiguration: not 7 finite numbers, or a quaternion that is not unit
            (within :data:`QUATERNION_TOLERANCE`): a file that stores ``x, y, z, w`` or
            Euler angles there is refused rather than misread.
    """
    try:
        b = np.asarray(base, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        b = np.full(1, np.nan)  # refused below, by name
    if b.shape != (BASE_SIZE,) or not np.isfinite(b).all():
        raise InvalidConfiguration(f"{source}: expected 7 finite numbers (x, y, z [m], quaternion w, x, y, z), got {b.tolist()}")
    norm = float(np.linalg.norm(b[3:]))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise InvalidConfiguration(
            f"{source}: the quaternion {b[3:].tolist()} is not unit (norm {norm:.9g}); expected w, x, y, z with "
            "w^2 + x^2 + y^2 + z^2 = 1"
        )
    w, x, y, z = b[3:] / norm
    R_object_palm = Rotation.from_quat([x, y, z, w]).as_matrix()
    T = np.eye(4)
    T[:3, :3] = R_object_palm.T
    T[:3, 3] = -R_object_palm.T @ (b[:3] * MM_PER_M)
    return T


def grasp_qpos(hand: Hand, T_palm_object, joint_angles: Mapping[str, float]) -> np.ndarray:
    """``(7 + n_dof,)``: the base (:func:`base_from_transform`), then ``joint_angles`` [rad]
    (by dof name; every dof of ``hand``) in :func:`qpos_joint_order`."""
    missing = [d for d in hand.dof_names if d not in joint_angles]
    if missing:
        raise InvalidConfiguration(f"joint angles of hand {hand.name!r} lack {missing}")
    q = [float(joint_angles[d]) for d in qpos_joint_order(hand)]
    return np.concatenate([base_from_transform(T_palm_object), q])


def solution_qpos(solution, model) -> np.ndarray:
    """The MuJoCo ``qpos`` ``(7 + n_dof,)`` of a :class:`~prehension.results.Solution`.

    Args:
        solution: a solution (``joint_angles`` by name [rad], ``T_palm_object`` [mm]).
        model: the :class:`~prehension.hands.model.Hand`, or a task (its ``hand``).

    Returns:
        ``x, y, z`` [m] and ``w, x, y, z`` of the palm in the object frame, then the joint
        angles [rad] in the MJCF's order (:func:`qpos_joint_order`).
    """
    hand = getattr(model, "hand", model)
    return grasp_qpos(hand, solution.T_palm_object, solution.joint_angles)


def qpos_configuration(qpos, model, source: str = "qpos") -> tuple[np.ndarray, np.ndarray]:
    """The inverse of :func:`solution_qpos`: ``(q (n_dof,) [rad] in the hand's order,
    T_palm_object (4, 4) [mm])``.

    Raises:
        InvalidConfiguration: a length other than ``7 + n_dof`` (the message says both
            counts and the joint order expected), non-finite numbers, a quaternion that is
            not unit.
    """
    hand = getattr(model, "hand", model)
    try:
        v = np.asarray(qpos, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidConfiguration(f"{source}: not a list of numbers ({type(qpos).__name__})") from None
    order = qpos_joint_order(hand)
    if v.size != BASE_SIZE + len(order):
        raise InvalidConfiguration(
            f"{source}: {v.size} numbers, but hand {hand.name!r} takes 7 (base: x, y, z [m], w, x, y, z) + {len(order)} "
            f"joint angles = {BASE_SIZE + len(order)}, in the order {list(order)}; is the record for another hand?"
        )
    if not np.isfinite(v).all():
        raise InvalidConfiguration(f"{source}: non-finite numbers (NaN or infinity)")
    T = transform_from_base(v[:BASE_SIZE], f"{source} (base)")
    by_name = dict(zip(order, v[BASE_SIZE:].tolist()))
    return np.array([by_name[d] for d in hand.dof_names]), T
