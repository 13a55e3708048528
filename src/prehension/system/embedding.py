"""Maps between task configurations and points of the canonical system.

:func:`embed` turns a configuration (joint angles, object pose, contact parameters) into
the point of the system it corresponds to; a configuration that satisfies the task gives
a point that satisfies every equation and lies in the initial box -- the property the
tests check to show the formulation never loses a solution.

:func:`configuration_from_point` goes back: from any point of a box (its centre, a
linear-program vertex...) it reads joint angles, object pose and contact parameters, the
start of the local refinement that may verify a solution inside the box.
"""

from __future__ import annotations

import numpy as np

from ..geometry.regions import BezierRegion, SphereCap
from ..geometry.rotations import signed_angle
from ..hands.kinematics import forward_kinematics
from ..tasks.model import Configuration
from .formulation import Formulation

__all__ = ["embed", "configuration_from_point"]


def _object_frame_rotations(form: Formulation, config: Configuration) -> tuple[dict, np.ndarray]:
    """Link rotations and the palm origin in the object frame."""
    hand = form.task.hand
    pose = forward_kinematics(hand, config.joint_angles)
    R_po, t_po = config.T_palm_object[:3, :3], config.T_palm_object[:3, 3]
    rot = {link: R_po.T @ pose.R_palm_link[0, hand.link_index(link)] for link in form.links}
    return rot, R_po.T @ (-t_po)


def _patch_values(patch, st: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit normal and ``|p_u x p_v|`` of a patch at ``(s, t)``."""
    N = patch.normal_patch().evaluate(st[0:1], st[1:2])[0]
    mu = float(np.linalg.norm(N))
    return N / mu, mu


def embed(form: Formulation, config: Configuration) -> np.ndarray:
    """The system point of a configuration that carries its contact parameters."""
    task = form.task
    if config.contact_params is None:
        raise ValueError("embed needs a configuration with contact parameters")
    rot, r0 = _object_frame_rotations(form, config)
    values: dict[int, float] = {}
    for i, key in form.base_keys.items():
        values[i] = _base_value(key, rot, r0, task, config)
    return form.builder.complete_point(values)


def _base_value(key, rot, r0, task, config) -> float:
    kind = key[0]
    if kind == "R":
        return float(rot[key[1]][key[2], key[3]])
    if kind == "r0":
        return float(r0[key[1]])
    ci = key[1]
    contact = task.contacts[ci]
    hparams, oparams = config.contact_params[ci]
    if kind in ("os", "ot"):
        return float(oparams[0 if kind == "os" else 1])
    if kind in ("hs", "ht"):
        return float(hparams[0 if kind == "hs" else 1])
    if kind in ("onu", "omu"):
        region = task.object_region(contact)
        if isinstance(region, SphereCap):
            return float(region.normals(oparams[None])[0][key[2]])
        nu, mu = _patch_values(region.patch, oparams)
        return mu if kind == "omu" else float(nu[key[2]])
    if kind in ("hnu", "hmu"):
        nu, mu = _patch_values(task.hand_region(contact).region.patch, hparams)
        return mu if kind == "hmu" else float(nu[key[2]])
    raise KeyError(f"unknown base variable {key}")


def _orthonormal(R: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(R)
    R = u @ vt
    if np.linalg.det(R) < 0:
        R = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return R


def _joint_angles(form: Formulation, rot: dict[str, np.ndarray]) -> np.ndarray:
    """Joint angles read from link rotations; angles outside the system keep idle values,
    clipped into the limits, and coupled angles follow their sources."""
    task, hand = form.task, form.task.hand
    q = task.idle_vector.copy()
    for joint, off in zip(hand.joints, hand.dof_offsets):
        if joint.child not in rot:
            continue
        R_rel = rot[joint.parent].T @ rot[joint.child]
        u, R0 = joint.axis_in_parent, joint.R_parent_child_zero
        if joint.kind == "revolute":
            a = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
            q[off] = float(signed_angle(a, R_rel @ R0.T @ a, u))
        else:
            v = joint.axis_in_child
            q[off] = float(signed_angle(R0 @ v, R_rel @ v, u))
            q[off + 1] = float(signed_angle(R_rel.T @ u, R0.T @ u, v))
    q = np.clip(q, hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return q


def configuration_from_point(form: Formulation, x: np.ndarray) -> Configuration:
    """A configuration read from a system point (rotations re-orthonormalised)."""
    rot = {link: _orthonormal(x[idx]) for link, idx in form.rot.items()}
    R_op, r0 = rot[form.task.hand.palm], x[form.r0]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R_op.T, -R_op.T @ r0  # T_palm_object = inverse of T_object_palm
    params = []
    for ci, contact in enumerate(form.task.contacts):
        info = form.contact_vars[ci]
        params.append((_hand_params(form, ci, contact, info, x, rot), _object_params(form, contact, info, x)))
    return Configuration(_joint_angles(form, rot), T, tuple(params))


def _object_params(form, contact, info, x) -> np.ndarray:
    region = form.task.object_region(contact)
    if isinstance(region, BezierRegion):
        return np.clip(x[list(info["o_params"])], 0.0, 1.0)
    if isinstance(region, SphereCap):
        nu = x[info["object_nu"]]
        return np.zeros(2) if np.linalg.norm(nu) < 1e-6 else region.params_for_normal(nu)[0]
    return np.zeros(0)


def _hand_params(form, ci, contact, info, x, rot) -> np.ndarray:
    hreg = form.task.hand_region(contact)
    region = hreg.region
    if isinstance(region, BezierRegion):
        return np.clip(x[list(info["h_params"])], 0.0, 1.0)
    if isinstance(region, SphereCap):
        nu = _object_normal(form, contact, info, x)
        if np.linalg.norm(nu) < 1e-6:  # no direction in this point: the cap's axis
            return np.zeros(2)
        return region.params_for_normal(rot[hreg.link].T @ -nu)[0]
    return np.zeros(0)


def _object_normal(form, contact, info, x) -> np.ndarray:
    region = form.task.object_region(contact)
    if "o_nu" in info:
        return x[info["o_nu"]]
    if "object_nu" in info:
        return x[info["object_nu"]]
    return region.normal
