"""DexGraspNet grasp files: one ``.npy`` per object, a list of dicts, one per grasp.

Layout (read from DexGraspNet's ``grasp_generation/scripts/generate_grasps.py`` and
``validate_grasps.py``, github.com/PKU-EPIC/DexGraspNet; see docs/interop.md):

* ``scale`` (float): the object mesh's scale (the normalised mesh times ``scale`` is the
  object in metres);
* ``qpos`` (dict name -> float): the wrist as ``WRJTx, WRJTy, WRJTz`` [m] and ``WRJRx,
  WRJRy, WRJRz`` [rad], Euler angles of transforms3d's ``'sxyz'`` convention (static
  axes: ``R = Rz(WRJRz) @ Ry(WRJRy) @ Rx(WRJRx)``), the hand's pose in the object frame;
  then every joint angle [rad] by joint name.

DexGraspNet also stores ``qpos_st`` (where its optimiser started) and energies; they are
not grasps and are neither written nor read.  prehension writes only the grasp (DexGraspNet
has no pre-grasp or squeeze), and ``hand`` (the hand's name).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InvalidTask
from ..hands.model import Hand
from .npy import load_npy, plain_value, save_npy
from ..hands.qpos import MM_PER_M
from .records import GraspRecord, check_metres

__all__ = ["record_to_dict", "record_from_dict", "write_dexgraspnet", "read_dexgraspnet", "TRANSLATION", "ROTATION"]

TRANSLATION = ("WRJTx", "WRJTy", "WRJTz")
ROTATION = ("WRJRx", "WRJRy", "WRJRz")
_EULER = "xyz"  # scipy's lower case: extrinsic (static) axes x, y, z = transforms3d's 'sxyz'


def record_to_dict(record: GraspRecord, hand: Hand) -> dict:
    """The DexGraspNet dict of one grasp."""
    T = np.linalg.inv(record.T_palm_object)  # T_object_palm [mm]
    qpos = dict(zip(TRANSLATION, (T[:3, 3] / MM_PER_M).tolist()))
    qpos.update(zip(ROTATION, Rotation.from_matrix(T[:3, :3]).as_euler(_EULER).tolist()))
    qpos.update({d: float(record.joint_angles[d]) for d in hand.dof_names})
    return {"scale": record.object_scale_mm / MM_PER_M, "qpos": qpos, "hand": hand.name}


def write_dexgraspnet(records: list[GraspRecord], hand: Hand, output) -> None:
    """Every grasp into one ``.npy`` (a pickled list of dicts, as DexGraspNet saves them)."""
    save_npy(output, [record_to_dict(r, hand) for r in records])


def record_from_dict(data, hand: Hand, source: str) -> GraspRecord:
    """The record of one DexGraspNet dict.

    Raises:
        InvalidTask: not a dict with ``qpos``, a wrist value missing, joints that are not
            the hand's (the message lists the missing and the unknown names).
    """
    if not isinstance(data, dict) or not isinstance(data.get("qpos"), dict):
        raise InvalidTask(f"{source}: expected a dict with 'qpos' (a dict of joint name to value), as DexGraspNet stores a grasp")
    plain_value(data, source)
    qpos = data["qpos"]
    wrist = TRANSLATION + ROTATION
    missing = [k for k in wrist + hand.dof_names if k not in qpos]
    unknown = [k for k in qpos if k not in wrist and k not in hand.dof_names]
    if missing or unknown:
        raise InvalidTask(f"{source}: qpos does not fit hand {hand.name!r}: missing {missing}, not joints of the hand "
                          f"{unknown}; is the record for another hand?")  # fmt: skip
    try:
        values = {k: float(v) for k, v in qpos.items()}
        scale = float(data.get("scale", 1.0)) * MM_PER_M
    except (TypeError, ValueError) as exc:
        raise InvalidTask(f"{source}: qpos values and scale must be numbers ({exc})") from None
    if not np.isfinite([*values.values(), scale]).all():
        raise InvalidTask(f"{source}: qpos or scale has non-finite values (NaN or infinity)")
    T_object_palm = np.eye(4)
    T_object_palm[:3, :3] = Rotation.from_euler(_EULER, [values[k] for k in ROTATION]).as_matrix()
    T_object_palm[:3, 3] = np.array([values[k] for k in TRANSLATION]) * MM_PER_M
    check_metres(T_object_palm, source)
    return GraspRecord(np.linalg.inv(T_object_palm), {d: values[d] for d in hand.dof_names},
                       object_scale_mm=scale, source=source)  # fmt: skip


def read_dexgraspnet(path, hand: Hand) -> list[GraspRecord]:
    """Every grasp of a DexGraspNet ``.npy`` file (a list of dicts, or one dict)."""
    data = load_npy(path)
    items = [data] if isinstance(data, dict) else list(np.asarray(data, dtype=object).reshape(-1))
    return [record_from_dict(d, hand, f"{path}[{k}]") for k, d in enumerate(items)]
