"""Grasps made by other tools, judged as prehension judges its own: result records that
``prehension check`` re-verifies.

A :class:`~prehension.interop.records.GraspRecord` claims only a configuration (joint
angles and the object's pose).  The contacts it is judged against come from:

* a **task** (``--object TASK``): the task's own contacts; the residual function finds where
  on each pair of regions the contact is best made (:mod:`prehension.tasks.locate`);
* a **bare mesh** (``--object MESH``): prehension **measures** them
  (:func:`measured_task`): for every contact region of the hand, the point of the object's
  surface nearest to it, the signed distance (negative: the region is inside the object)
  and the surface's outward normal there.  Each region within :data:`TOUCH_MM` of the
  surface, outside or inside, becomes a contact with a point region on the object at that nearest point.
  The record says these contacts were measured, not claimed (``imported.contacts``).

The configuration is then judged by the one residual function with the strict tolerances.
When it passes, the record's status is ``solved``.  When it does not, the status is
``approximate`` and the stated tolerances are the smallest that admit it (each failing
kind loosened to its worst value): ``check`` re-derives that it holds within them and no
further, and exits 6 (approximate), never 0.  Idle fingers are never moved (a solver would
settle them clear of the object; an imported grasp is judged as it was given).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InvalidObject, InvalidTask
from ..geometry.regions import PointRegion
from ..hands.kinematics import forward_kinematics
from ..objects.model import GraspObject
from ..objects.solid import MeshFileSolid, solid_geometry
from ..pregrasp import judge_pregrasp
from ..quality.stored import quality_entries
from ..results import ContactResult, Solution, SolveResult, Status, result_to_dict
from ..tasks.model import Configuration, Contact, Task
from ..verification.residuals import TOLERANCE_OF_KIND, Tolerances, evaluate

__all__ = ["TOUCH_MM", "measured_task", "imported_result", "imported_record"]

TOUCH_MM = 2.0  # a hand region this close to the object's surface (or inside it) touches it


def _region_samples(hand, pose, name: str) -> tuple[np.ndarray, float]:
    """``(points (S, 3) in the palm frame [mm], offset [mm])`` standing for a hand region:
    a sphere cap's centre with its radius (the nearest point of the ball to a surface is
    along the line to the centre), else a grid of the region's points with offset 0."""
    hreg = hand.region(name)
    k = hand.link_index(hreg.link)
    region = hreg.region
    if region.kind == "sphere_cap":
        points, offset = region.center[None, :], region.radius
    else:
        points, offset = region.evaluate(region.seed_params(7))[0], 0.0
    return points @ pose.R_palm_link[0, k].T + pose.r_palm_link[0, k], float(offset)


def measured_contacts(hand, distance, q, T_palm_object) -> list[dict]:
    """Per hand contact region: the nearest point of the object's surface (object frame
    [mm]; ``distance``: its :class:`~prehension.objects.distance.MeshDistance`), the signed
    distance [mm] (negative: inside) and the outward normal there (object frame: from the
    surface point towards the region, else the nearest face's normal)."""
    pose = forward_kinematics(hand, q)
    T_object_palm = np.linalg.inv(T_palm_object)
    out = []
    for name in hand.regions:
        samples, offset = _region_samples(hand, pose, name)
        pts = samples @ T_object_palm[:3, :3].T + T_object_palm[:3, 3]
        signed, closest = distance.signed_distance(pts, closest=True)
        i = int(np.argmin(signed))
        gap = pts[i] - closest[i]
        if abs(signed[i]) > 1e-9:
            normal = np.sign(signed[i]) * gap / np.linalg.norm(gap)
        else:
            normal = distance.face_normals[int(distance.closest_faces(closest[i : i + 1])[0])]
        d = float(signed[i] - offset)
        out.append({"hand_region": name, "link": hand.region(name).link, "object_point_mm": closest[i].tolist(),
                    "object_normal": normal.tolist(), "distance_mm": d, "penetration_mm": max(0.0, -d)})  # fmt: skip
    return out


def measured_task(hand, mesh_path: str, scale_mm: float, q, T_palm_object, name: str) -> tuple[Task, list[dict]]:
    """The task of a grasp on a bare mesh: its contacts where the hand touches the object
    (see the module docstring), and what was measured for every hand region.  An open
    mesh (not watertight) gives an object without collision rows (and signs of distances
    that only the nearest face's side decides).

    Raises:
        InvalidTask: no hand region within :data:`TOUCH_MM` of the object (the grasp touches
            nothing: another object, another scale, or millimetres read as metres).
    """
    if not hand.regions:
        raise InvalidTask(f"hand {hand.name!r} has no contact regions: nothing to measure on {name!r}; give a task (--object TASK)")
    solid, closed, measured = _measure(hand, mesh_path, scale_mm, q, T_palm_object)
    touching = [m for m in measured if abs(m["distance_mm"]) <= TOUCH_MM]
    if not touching:
        nearest = min(measured, key=lambda m: abs(m["distance_mm"]))
        where = "inside it" if nearest["distance_mm"] < 0 else "away"
        raise InvalidTask(f"{name}: no contact region of hand {hand.name!r} is within {TOUCH_MM:g} mm of the object's "
                          f"surface at {scale_mm:g} mm per mesh unit (the nearest, {nearest['hand_region']!r}, is "
                          f"{abs(nearest['distance_mm']):.4g} mm {where}); "
                          + _units_hint(hand, mesh_path, scale_mm, q, T_palm_object))  # fmt: skip
    regions = {f"at_{m['hand_region']}": PointRegion(m["object_point_mm"], m["object_normal"]) for m in touching}
    obj = GraspObject(name, regions, solid=solid, collisions=closed)
    contacts = tuple(Contact(m["hand_region"], f"at_{m['hand_region']}", m["hand_region"]) for m in touching)
    fingers = tuple(dict.fromkeys(f for m in touching if (f := hand.finger_of_link(m["link"])) is not None))
    return _task(name, hand, obj, contacts, fingers, q), measured


def _measure(hand, mesh_path: str, scale_mm: float, q, T_palm_object):
    """``(solid, closed, measured_contacts)`` of the mesh at ``scale_mm`` mm per unit."""
    solid = MeshFileSolid(str(mesh_path), float(scale_mm))
    try:
        closed, distance = True, solid_geometry(solid, True)[1]
    except InvalidObject:  # an open mesh: regions and display only, no collision rows
        closed, distance = False, solid_geometry(solid, False)[1]
    return solid, closed, measured_contacts(hand, distance, q, T_palm_object)


def _units_hint(hand, mesh_path: str, scale_mm: float, q, T_palm_object) -> str:
    """Whether the grasp touches the mesh 1000 times larger or smaller (metres and
    millimetres confused: the mesh, or the pose, 1000x off), said with the scale to give."""
    for factor, why in ((1000.0, "a mesh in metres read as millimetres"), (1e-3, "a mesh in millimetres read as metres")):
        measured = _measure(hand, mesh_path, scale_mm * factor, q, T_palm_object)[2]
        n = sum(abs(m["distance_mm"]) <= TOUCH_MM for m in measured)
        if n:
            return (f"at {scale_mm * factor:g} mm per unit ({why}, or a pose 1000x {'too small' if factor > 1 else 'too large'}) "
                    f"{n} region(s) touch it: give --mesh-scale {scale_mm * factor:g}")  # fmt: skip
    return "is the record for this object, at this scale and in these units?"


def _task(name, hand, obj, contacts, fingers, q) -> Task:
    """A task whose idle angles are the record's own (where within the limits)."""
    bare = Task(name, hand, obj, contacts, fingers)
    idle = {d: float(v) for d, v, a, lo, hi in zip(hand.dof_names, q, bare.active_mask, hand.lower, hand.upper)
            if not a and lo <= v <= hi}  # fmt: skip
    return replace(bare, idle_angles=idle) if idle else bare


def _admitting(report) -> Tolerances:
    """The strict tolerances, each kind that fails loosened to its worst value."""
    tol = Tolerances()
    loose = {}
    for kind in report.kinds:
        field = TOLERANCE_OF_KIND[kind]
        worst = report.worst(kind)
        if worst > getattr(tol, field):
            loose[field] = max(loose.get(field, 0.0), worst * (1 + 1e-9) + 1e-12)
    return replace(tol, **loose)


def _solution(task: Task, q: np.ndarray, T: np.ndarray, report, tolerances: Tolerances):
    """The :class:`~prehension.results.Solution` of a judged configuration, as it was given."""
    pose = forward_kinematics(task.hand, q)
    contacts = tuple(ContactResult(s.name, s.hand_point, s.hand_normal, s.object_point, s.object_normal, s.hand_params,
                                   s.object_params, s.distance_mm, s.normal_angle_deg) for s in report.contacts)  # fmt: skip
    moved = tuple(d for d, m in zip(task.hand.dof_names, ~task.active_mask & (q != task.idle_vector)) if m)
    links = dict(zip(task.hand.link_names, pose.T_palm_link[0]))
    return Solution(dict(zip(task.hand.dof_names, q.tolist())), T.copy(), links, contacts, report, tolerances, moved)


def _check_pose_units(task: Task, q: np.ndarray, T: np.ndarray, report, source: str) -> None:
    """Refuse a grasp whose contacts miss by more than :data:`TOUCH_MM` but hold strictly with
    the palm's position 1000x larger or smaller: metres and millimetres confused (a pose
    1000x too small or too large), not a grasp that misses."""
    if report.worst("contact_distance") <= TOUCH_MM:
        return
    for factor, what in ((1000.0, "too small (metres given where millimetres are expected?)"),
                         (1e-3, "too large (millimetres given where metres are expected?)")):  # fmt: skip
        scaled = T.copy()
        scaled[:3, 3] *= factor
        if evaluate(task, Configuration(q, scaled), Tolerances()).ok:
            raise InvalidTask(f"{source}: the palm's position is 1000x {what}: as given the contacts miss by up to "
                              f"{report.worst('contact_distance'):.4g} mm, with it {factor:g}x they all hold; fix the "
                              "record's units")  # fmt: skip


def imported_result(task: Task, record, *, measured: list[dict] | None = None, format_name: str = "") -> dict:
    """The result dict (``prehension: result/1``, method ``"imported"``) of one record of a
    grasp of ``task`` (see the module docstring for its status and tolerances).

    ``measured``: what :func:`measured_task` measured (a bare mesh), stored as it is.  The
    record's own pre-grasp is judged as prehension judges its pre-grasps (joint limits,
    couplings, self- and object collision; :func:`~prehension.pregrasp.judge_pregrasp`) and
    stored as ``"pregrasp"`` (``check`` re-derives it); its squeeze targets are stored under
    ``"imported"`` only (prehension's squeeze is its own protocol's).
    """
    q = np.array([record.joint_angles[d] for d in task.hand.dof_names])
    T = np.asarray(record.T_palm_object, dtype=float)
    report = evaluate(task, Configuration(q, T), Tolerances())
    if not report.ok:
        _check_pose_units(task, q, T, report, record.source)
    tolerances = Tolerances() if report.ok else _admitting(report)
    solution = _solution(task, q, T, report.judged(tolerances), tolerances)
    status = Status.SOLVED if report.ok else Status.APPROXIMATE
    strict = Tolerances()
    failing = ", ".join(f"{k} {report.worst(k):.3g}" for k in report.kinds if report.worst(k) > getattr(strict, TOLERANCE_OF_KIND[k]))
    verdict = "every constraint holds within the strict tolerances" if report.ok else (
        f"does not hold strictly (worst: {failing}); stored as approximate, within exactly those tolerances")
    message = f"imported from {record.source}: {verdict}"
    result = SolveResult(task, "imported", status, message, (solution,))
    data = result_to_dict(result, quality_entries(result))  # no approach entries: the pre-grasp is the record's own, below
    entry = data["solutions"][0]
    if record.pregrasp is not None:
        q_pre = np.array([record.pregrasp[d] for d in task.hand.dof_names])
        pre = judge_pregrasp(task, q, q_pre, T, solution.contacts, 0.0)  # the record states no distance: its largest
        entry["pregrasp"] = replace(pre, back_off_mm=float(np.max(pre.reached_mm, initial=0.0))).to_dict(task)
    entry["imported"] = _claims(record, format_name, measured)
    return data


def _claims(record, format_name: str, measured) -> dict:
    """What the record claimed (its configuration) and, on a bare mesh, what was measured."""
    claimed = {"source": record.source, "format": format_name, "object_path": record.object_path,
               "object_scale_mm_per_unit": record.object_scale_mm, "T_palm_object": np.asarray(record.T_palm_object).tolist(),
               "joint_angles_rad": dict(record.joint_angles)}  # fmt: skip
    for stage in ("pregrasp", "squeeze"):
        if getattr(record, stage) is not None:
            claimed[f"{stage}_joint_angles_rad"] = dict(getattr(record, stage))
    out = {"claimed": claimed}
    if measured is not None:
        out["contacts"] = "measured: each hand region within %g mm of the mesh became a contact (not claimed by the record)" % TOUCH_MM
        out["measured"] = measured
    else:
        out["contacts"] = "the task's contacts; their points located by the residual function"
    return out


def imported_record(task: Task, record, index: str, **kwargs) -> dict:
    """A batch-output line (``{"id", "status", "result"}``) that ``prehension check`` reads."""
    data = imported_result(task, record, **kwargs)
    return {"id": index, "status": data["status"], "result": data}
