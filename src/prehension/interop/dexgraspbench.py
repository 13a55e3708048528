"""DexGraspBench / BODex grasp files: one ``.npy`` dict per grasp.

Layout (read from DexGraspBench's ``src/task/eval_func/base.py``, ``src/util/hand_util.py``
and ``src/task/convert_format.py``, github.com/Mingrui-Yu/DexGraspBench, a copy of JYChen18/DexGraspBench, and its README;
see docs/interop.md):

* ``obj_path`` (str): the object (DexGraspBench: a MeshProcess folder; here: the mesh file);
* ``obj_scale`` (float): the object mesh's scale, metres per file unit;
* ``obj_pose`` (7,): the object's pose in the world, ``x, y, z`` [m], ``w, x, y, z``;
* ``pregrasp_qpos``, ``grasp_qpos``, ``squeeze_qpos`` (7 + n,): the hand's root body pose in
  the world (metres, w-x-y-z), then its joints in the MJCF's order
  (:mod:`prehension.hands.qpos`); older files keep the 7 numbers apart in
  ``pregrasp_pose`` / ``grasp_pose`` / ``squeeze_pose`` and only the joints in ``*_qpos``:
  both are read.

prehension writes ``obj_pose`` as the identity (the world is the object frame) and adds
``joint_names`` (the qpos order) and ``hand`` (the hand's name), which DexGraspBench ignores.
A file with ``joint_names`` is read in that order (a permutation of the hand's joints; other
names are refused); a file without is in the hand's qpos order.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InvalidTask
from ..hands.model import Hand
from .npy import load_npy, plain_value, save_npy
from ..hands.qpos import BASE_SIZE, MM_PER_M, base_from_transform, qpos_joint_order, transform_from_base
from .records import GraspRecord, record_from_qpos

__all__ = ["record_to_dict", "record_from_dict", "grasp_files", "write_dexgraspbench", "read_dexgraspbench", "STAGES"]

STAGES = ("pregrasp", "grasp", "squeeze")
IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def record_to_dict(record: GraspRecord, hand: Hand) -> dict:
    """The DexGraspBench dict of one grasp (the stages the record has)."""
    out = {
        "obj_path": record.object_path,
        "obj_scale": record.object_scale_mm / MM_PER_M,
        "obj_pose": IDENTITY_POSE.copy(),
    }
    for stage in STAGES:
        qpos = record.qpos(hand, stage)
        if qpos is not None:
            out[f"{stage}_qpos"] = qpos
    out["joint_names"] = np.array(qpos_joint_order(hand))
    out["hand"] = hand.name
    return out


def grasp_files(output, n: int, first: int = 0) -> list[Path]:
    """The files :func:`write_dexgraspbench` writes for ``n`` grasps: ``output`` itself when
    it is named ``*.npy`` (one grasp), else ``output/{first}.npy, ...`` (DexGraspBench's
    layout; ``first``: the first grasp's solution number)."""
    output = Path(output)
    if output.suffix.lower() == ".npy":
        if n != 1:
            raise InvalidTask(f"{output}: {n} grasps do not fit one .npy file; give a folder, or --solution K")
        return [output]
    return [output / f"{k}.npy" for k in range(first, first + n)]


def write_dexgraspbench(records: list[GraspRecord], hand: Hand, output, first: int = 0) -> list[Path]:
    """One ``.npy`` per grasp, in the files of :func:`grasp_files` (a folder is made)."""
    paths = grasp_files(output, len(records), first)
    paths[0].parent.mkdir(parents=True, exist_ok=True)
    for record, path in zip(records, paths):
        save_npy(path, record_to_dict(record, hand))
    return paths


def _vector(data: dict, key: str, source: str) -> np.ndarray:
    try:
        v = np.asarray(data[key], dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidTask(f"{source}: {key!r} is not a list of numbers") from None
    if not np.isfinite(v).all():
        raise InvalidTask(f"{source}: {key!r} has non-finite values (NaN or infinity)")
    return v


def _stage(data: dict, stage: str, n_dof: int, source: str) -> np.ndarray | None:
    """``(7 + n,)`` of one stage: ``*_qpos`` with its base, or ``*_pose`` + ``*_qpos``."""
    if f"{stage}_qpos" not in data:
        return None
    q = _vector(data, f"{stage}_qpos", source)
    if q.size == n_dof and f"{stage}_pose" in data:
        return np.concatenate([_vector(data, f"{stage}_pose", source), q])
    return q


def record_from_dict(data, hand: Hand, source: str) -> GraspRecord:
    """The record of a DexGraspBench dict; the hand's base is taken into the object frame
    through ``obj_pose``; the object's scale is ``obj_scale`` [m per unit].

    Raises:
        InvalidTask: not a dict, no ``grasp_qpos``, a joint count that is not the hand's,
            a quaternion that is not unit (the message names the key and the file).
    """
    if not isinstance(data, dict):
        raise InvalidTask(f"{source}: expected a dict (a DexGraspBench grasp), got a {type(data).__name__}")
    plain_value(data, source)
    n = len(hand.dof_names)
    stages = {s: _stage(data, s, n, source) for s in STAGES}
    if stages["grasp"] is None:
        raise InvalidTask(f"{source}: no 'grasp_qpos'; a DexGraspBench grasp has keys {sorted(data)} "
                          "(expected grasp_qpos, and optionally pregrasp_qpos, squeeze_qpos, obj_pose, obj_scale, obj_path)")  # fmt: skip
    T_world_object = np.eye(4)
    if "obj_pose" in data:
        T_world_object = np.linalg.inv(transform_from_base(_vector(data, "obj_pose", source), f"{source}: obj_pose"))
    stages = {s: None if v is None else _in_object_frame(v, T_world_object, f"{source}: {s}_qpos") for s, v in stages.items()}
    if "joint_names" in data:
        stages = {s: None if v is None else _reordered(v, data["joint_names"], hand, source) for s, v in stages.items()}
    scale = float(_vector(data, "obj_scale", source)[0]) * MM_PER_M if "obj_scale" in data else MM_PER_M
    return record_from_qpos(hand, stages["grasp"], stages["pregrasp"], stages["squeeze"],
                            object_path=str(data.get("obj_path", "")), object_scale_mm=scale, source=source)  # fmt: skip


def _in_object_frame(qpos: np.ndarray, T_world_object: np.ndarray, source: str) -> np.ndarray:
    """``qpos`` with its base (the palm in the world) re-expressed in the object frame."""
    if qpos.size < BASE_SIZE:
        raise InvalidTask(f"{source}: {qpos.size} numbers; expected 7 (the base) + the joints")
    T_palm_world = transform_from_base(qpos[:BASE_SIZE], f"{source} (base)")  # 'object' there = the world
    return np.concatenate([base_from_transform(T_palm_world @ T_world_object), qpos[BASE_SIZE:]])


def _reordered(qpos: np.ndarray, names, hand: Hand, source: str) -> np.ndarray:
    """``qpos`` whose joints are in the order ``names`` (a file's ``joint_names``) put in
    the hand's qpos order; names that are not the hand's dofs are refused."""
    names = [str(n) for n in np.asarray(names).reshape(-1)]
    order = qpos_joint_order(hand)
    if sorted(names) != sorted(order):
        raise InvalidTask(f"{source}: joint_names {names} are not the joints of hand {hand.name!r} ({list(order)}); "
                          "is the record for another hand?")  # fmt: skip
    if qpos.size != BASE_SIZE + len(names):
        return qpos  # the count is refused, by name, when the qpos is read
    by_name = dict(zip(names, qpos[BASE_SIZE:]))
    return np.concatenate([qpos[:BASE_SIZE], [by_name[n] for n in order]])


def read_dexgraspbench(path, hand: Hand) -> list[GraspRecord]:
    """The grasp of one DexGraspBench ``.npy`` file (a list of one)."""
    return [record_from_dict(load_npy(path), hand, str(path))]
