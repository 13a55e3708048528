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

from ..geometry.rotations import signed_angle
from ..hands.kinematics import forward_kinematics
from ..tasks.model import Configuration
from .formulation import Formulation
from .keys import BaseKey, ContactVariables, PalmOrigin, PatchParameter, QuaternionComponent, RotationEntry, Side
from .regions import form_of

__all__ = ["embed", "configuration_from_point", "unit_quaternion"]


def _object_frame_pose(form: Formulation, config: Configuration) -> tuple[dict, np.ndarray]:
    """``R_object_link`` for every link of the system, and ``p_palm_in_object`` [mm]."""
    hand = form.task.hand
    pose = forward_kinematics(hand, config.joint_angles)
    R_palm_object, p_object_in_palm = config.T_palm_object[:3, :3], config.T_palm_object[:3, 3]
    R_object_link = {link: R_palm_object.T @ pose.R_palm_link[0, hand.link_index(link)] for link in form.links}
    return R_object_link, R_palm_object.T @ (-p_object_in_palm)


def embed(form: Formulation, config: Configuration) -> np.ndarray:
    """The system point of a configuration that carries its contact parameters."""
    if config.contact_params is None:
        raise ValueError("embed needs a configuration with contact parameters")
    R_object_link, p_palm_in_object = _object_frame_pose(form, config)
    values = {i: _base_value(key, R_object_link, p_palm_in_object, form.task, config) for i, key in form.base_keys.items()}
    return form.builder.complete_point(values)


def _base_value(key: BaseKey, R_object_link: dict, p_palm_in_object: np.ndarray, task, config) -> float:
    """The value of one base variable at a configuration (dispatch on the key's type)."""
    if isinstance(key, RotationEntry):
        return float(R_object_link[key.link][key.row, key.col])
    if isinstance(key, QuaternionComponent):
        return float(unit_quaternion(R_object_link[key.link])[key.index])
    if isinstance(key, PalmOrigin):
        return float(p_palm_in_object[key.axis])
    contact = task.contacts[key.contact]
    hand_params, object_params = config.contact_params[key.contact]
    params = object_params if key.side == Side.OBJECT else hand_params
    if isinstance(key, PatchParameter):
        return float(params[key.index])
    region = task.object_region(contact) if key.side == Side.OBJECT else task.hand_region(contact).region
    return form_of(region).normal_value(region, params, key)


def unit_quaternion(R: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` of a rotation matrix with ``w >= 0`` (scipy's,
    reordered from its ``(x, y, z, w)``, with the sign that makes ``w >= 0``)."""
    from scipy.spatial.transform import Rotation  # here, not at import: scipy.spatial costs ~0.3 s to import

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    q = np.array([w, x, y, z])
    return -q if w < 0.0 else q


def _orthonormal(R: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(R)
    R = u @ vt
    if np.linalg.det(R) < 0:
        R = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return R


def _joint_angles(form: Formulation, R_object_link: dict[str, np.ndarray]) -> np.ndarray:
    """Joint angles read from link rotations; angles outside the system keep idle values,
    clipped into the limits, and coupled angles follow their sources."""
    task, hand = form.task, form.task.hand
    q = task.idle_vector.copy()
    for joint, off in zip(hand.joints, hand.dof_offsets):
        if joint.child not in R_object_link:
            continue
        R_parent_child = R_object_link[joint.parent].T @ R_object_link[joint.child]
        u, R0 = joint.axis_in_parent, joint.R_parent_child_zero
        if joint.kind == "revolute":
            a = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
            q[off] = float(signed_angle(a, R_parent_child @ R0.T @ a, u))
        else:
            v = joint.axis_in_child
            q[off] = float(signed_angle(R0 @ v, R_parent_child @ v, u))
            q[off + 1] = float(signed_angle(R_parent_child.T @ u, R0.T @ u, v))
    q = np.clip(q, hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return q


def configuration_from_point(form: Formulation, x: np.ndarray) -> Configuration:
    """A configuration read from a system point (rotations re-orthonormalised)."""
    R_object_link = {link: _orthonormal(x[idx]) for link, idx in form.R_object_link.items()}
    R_object_palm, p_palm_in_object = R_object_link[form.task.hand.palm], x[form.p_palm_in_object]
    T_palm_object = np.eye(4)  # the inverse of T_object_palm
    T_palm_object[:3, :3], T_palm_object[:3, 3] = R_object_palm.T, -R_object_palm.T @ p_palm_in_object
    params = []
    for contact, variables in zip(form.task.contacts, form.contact_vars):
        hand = _hand_params(form, contact, variables, x, R_object_link)
        params.append((hand, _object_params(form, contact, variables, x)))
    return Configuration(_joint_angles(form, R_object_link), T_palm_object, tuple(params))


def _object_params(form: Formulation, contact, variables: ContactVariables, x) -> np.ndarray:
    region = form.task.object_region(contact)
    return form_of(region).object_params(region, variables, x)


def _hand_params(form: Formulation, contact, variables: ContactVariables, x, R_object_link) -> np.ndarray:
    hreg = form.task.hand_region(contact)
    nu = _object_normal(form, contact, variables, x)
    return form_of(hreg.region).hand_params(hreg.region, variables, x, nu, R_object_link[hreg.link])


def _object_normal(form: Formulation, contact, variables: ContactVariables, x) -> np.ndarray:
    """The unit outward object normal in the object frame (constant for a point region)."""
    if variables.object_normal is not None:
        return x[list(variables.object_normal)]
    return form.task.object_region(contact).normal
