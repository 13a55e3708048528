"""``json-m``: prehension's grasps as JSON in metres, for tools that read neither prehension's
result files (mm) nor pickled ``.npy``.

.. code-block:: json

    {"prehension": "grasps-m/1", "hand": "sa-hand", "units": {...}, "frames": "...",
     "joint_order": ["..."], "object": {"path": "...", "scale_m_per_unit": 0.001},
     "grasps": [{"grasp_qpos": [x, y, z, w, qx, qy, qz, q1, ...],
                 "pregrasp_qpos": [...], "squeeze_qpos": [...]}]}

Each ``*_qpos`` is the MuJoCo qpos of :mod:`prehension.hands.qpos` (the palm in the
object frame, metres, w-x-y-z; the joints in ``joint_order``).
"""

from __future__ import annotations

from ..atomic import read_json, write_json_atomic
from ..errors import InvalidTask
from ..hands.model import Hand
from .dexgraspbench import STAGES
from ..hands.qpos import MM_PER_M, qpos_joint_order
from .records import GraspRecord, record_from_qpos

__all__ = ["TAG", "to_dict", "write_json_m", "read_json_m"]

TAG = "grasps-m/1"


def to_dict(records: list[GraspRecord], hand: Hand) -> dict:
    objects = {(r.object_path, r.object_scale_mm) for r in records}
    if len(objects) > 1:
        raise InvalidTask(f"json-m holds the grasps of one object; these name {len(objects)}: {sorted(objects)}")
    path, scale = objects.pop() if objects else ("", 1.0)
    grasps = [{f"{s}_qpos": r.qpos(hand, s).tolist() for s in STAGES if r.qpos(hand, s) is not None} for r in records]
    return {
        "prehension": TAG,
        "hand": hand.name,
        "units": {"length": "m", "angle": "rad", "quaternion": "w, x, y, z"},
        "frames": "qpos[:7] is the palm's pose in the object frame; then the joints in joint_order",
        "joint_order": list(qpos_joint_order(hand)),
        "object": {"path": path, "scale_m_per_unit": scale / MM_PER_M},
        "grasps": grasps,
    }


def write_json_m(records: list[GraspRecord], hand: Hand, output) -> None:
    write_json_atomic(output, to_dict(records, hand))


def read_json_m(path, hand: Hand) -> list[GraspRecord]:
    """Every grasp of a ``json-m`` file.

    Raises:
        InvalidTask: not a ``grasps-m/1`` file, written for another hand or joint order,
            a grasp without ``grasp_qpos``, or a palm farther than
            :data:`~prehension.interop.records.MAX_BASE_M` from the object (millimetres
            written where metres belong).
    """
    data = read_json(path, "grasp file")
    if not isinstance(data, dict) or data.get("prehension") != TAG:
        raise InvalidTask(f"{path}: not a json-m grasp file (expected 'prehension: {TAG}')")
    order = list(qpos_joint_order(hand))
    if data.get("joint_order", order) != order:
        raise InvalidTask(f"{path}: written for joints {data.get('joint_order')} (hand {data.get('hand')!r}); "
                          f"hand {hand.name!r} has {order}")  # fmt: skip
    obj = data.get("object") if isinstance(data.get("object"), dict) else {}
    if not isinstance(data.get("grasps", []), list):
        raise InvalidTask(f"{path}: 'grasps' must be a list of grasps")
    out = []
    for k, g in enumerate(data.get("grasps") or []):
        where = f"{path}: grasps[{k}]"
        if not isinstance(g, dict) or "grasp_qpos" not in g:
            raise InvalidTask(f"{where}: no 'grasp_qpos'")
        stages = [g.get(f"{s}_qpos") for s in STAGES]
        scale = obj.get("scale_m_per_unit", 1e-3)
        if not isinstance(scale, (int, float)) or not 0 < scale < float("inf"):
            raise InvalidTask(f"{path}: object.scale_m_per_unit must be a positive number, got {scale!r}")
        out.append(record_from_qpos(hand, stages[1], stages[0], stages[2], object_path=str(obj.get("path", "")),
                                    object_scale_mm=float(scale) * MM_PER_M, source=where))  # fmt: skip
    if not out:
        raise InvalidTask(f"{path}: the file holds no grasps")
    return out
