"""Write a :class:`~prehension.hands.model.Hand` as URDF or MJCF (lengths in metres).

Both files keep every link frame, joint angle (by its dof name), limit and coupling, so
that the file read back (:func:`~prehension.hands.urdf.hand_from_urdf`,
:func:`~prehension.hands.mjcf.hand_from_mjcf`) has the same forward kinematics.

* **URDF** has 1-dof joints whose axis passes through the child frame's origin.  A joint
  becomes a ``revolute`` joint with ``origin = [R0, P]`` and axis ``R0^T u``; a universal
  joint becomes two, through an extra link ``<child>__<first angle>``; a joint whose centre
  is not the child frame's origin (``Q != 0``) gets an extra link ``<child>__joint`` at its
  centre and a fixed joint to the child (read back, the child is a named frame of that
  link).  Couplings are ``<mimic>``.  Capsules are written as a cylinder and two end
  spheres (collision and visual).
* **MJCF**: a body per link at ``pos = P - R0 Q``, ``quat = R0``; a ``hinge`` per angle at
  ``pos = Q`` (a universal joint's two hinges share the body, as MuJoCo composes them);
  capsules as ``capsule`` geoms (``fromto``); couplings as ``<equality><joint>`` with
  ``polycoef="offset ratio 0 0 0"``; collision exclusions as ``<contact><exclude>``; each
  body gets a small explicit inertia (MuJoCo needs a mass on moving bodies).
* In both, each region with a frame of its own (:attr:`~prehension.geometry.regions.Region.frame`:
  the sphere caps) becomes a named frame (URDF: a fixed child link; MJCF:
  a site) at the cap's centre with its z axis along the cap axis, named after the region
  (``<region>__region`` when a link has that name), so that the fingertip fit of the hand
  read back finds the tips where they were.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..geometry.rotations import orthonormal_frame
from .model import Capsule, Coupling, Hand, Joint

__all__ = ["hand_to_urdf", "hand_to_mjcf", "region_frame_name"]

_M = 1e-3  # metres per mm


def _num(x: float) -> str:
    return repr(float(x) + 0.0)


def _vec(v, scale: float = 1.0) -> str:
    return " ".join(_num(scale * x) for x in np.asarray(v, dtype=float))


def _rpy(R: np.ndarray) -> tuple[float, float, float]:
    """``(roll, pitch, yaw)`` with ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = float(np.arcsin(np.clip(-R[2, 0], -1.0, 1.0)))
    if abs(R[2, 0]) < 1.0 - 1e-12:
        return float(np.arctan2(R[2, 1], R[2, 2])), pitch, float(np.arctan2(R[1, 0], R[0, 0]))
    return float(np.arctan2(-R[1, 2], R[1, 1])), pitch, 0.0  # gimbal lock: yaw folded into roll


def _quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


def _pretty(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"


# -- URDF ------------------------------------------------------------------------------------
def _origin(parent: ET.Element, R: np.ndarray, t) -> None:
    ET.SubElement(parent, "origin", xyz=_vec(t, _M), rpy=" ".join(_num(a) for a in _rpy(R)))


def _capsule_urdf(link: ET.Element, cap: Capsule) -> None:
    length = float(np.linalg.norm(cap.b - cap.a))
    for tag in ("collision", "visual"):
        if length > 1e-9:
            elem = ET.SubElement(link, tag)
            z = (cap.b - cap.a) / length
            _origin(elem, orthonormal_frame(z), (cap.a + cap.b) / 2)
            ET.SubElement(ET.SubElement(elem, "geometry"), "cylinder", radius=_num(cap.radius * _M), length=_num(length * _M))
        for end in (cap.a, cap.b) if length > 1e-9 else (cap.a,):
            elem = ET.SubElement(link, tag)
            _origin(elem, np.eye(3), end)
            ET.SubElement(ET.SubElement(elem, "geometry"), "sphere", radius=_num(cap.radius * _M))


@dataclass(frozen=True)
class _UrdfJoint:
    """One URDF ``<joint>``: ``child`` at ``(R, t)`` [mm] in ``parent``; revolute about
    ``axis`` (child frame) within ``limits`` [rad] and following ``mimic`` (a coupling),
    or fixed when ``axis`` is None."""

    name: str
    parent: str
    child: str
    R: np.ndarray
    t: np.ndarray
    axis: np.ndarray | None = None
    limits: tuple[float, float] | None = None
    mimic: Coupling | None = None

    def write(self, robot: ET.Element) -> None:
        j = ET.SubElement(robot, "joint", name=self.name, type="revolute" if self.axis is not None else "fixed")
        ET.SubElement(j, "parent", link=self.parent)
        ET.SubElement(j, "child", link=self.child)
        _origin(j, self.R, self.t)
        if self.axis is not None:
            ET.SubElement(j, "axis", xyz=_vec(self.axis))
            lower, upper = self.limits
            ET.SubElement(j, "limit", lower=_num(lower), upper=_num(upper), effort="0", velocity="0")
        if self.mimic is not None:
            m = self.mimic
            ET.SubElement(j, "mimic", joint=m.source, multiplier=_num(m.ratio), offset=_num(m.offset))


def _urdf_joints(robot, joint: Joint, coupled: dict) -> list[str]:
    """The URDF joints of one joint; returns the extra links it needs."""
    R0, P, Q = joint.R_parent_child_zero, joint.origin_in_parent, joint.origin_in_child
    has_q = bool(np.any(Q != 0))
    last = f"{joint.child}__joint" if has_q else joint.child
    extra = [f"{joint.child}__{joint.dof_names[0]}"] if joint.kind == "universal" else []
    first_child = extra[0] if extra else last
    d0 = joint.dof_names[0]
    _UrdfJoint(d0, joint.parent, first_child, R0, P, R0.T @ joint.axis_in_parent,
               (joint.lower[0], joint.upper[0]), coupled.get(d0)).write(robot)  # fmt: skip
    if extra:
        d1 = joint.dof_names[1]
        _UrdfJoint(d1, extra[0], last, np.eye(3), np.zeros(3), joint.axis_in_child,
                   (joint.lower[1], joint.upper[1]), coupled.get(d1)).write(robot)  # fmt: skip
    if has_q:
        extra.append(last)
        _UrdfJoint(f"{joint.child}__fixed", last, joint.child, np.eye(3), -Q).write(robot)
    return extra


def region_frame_name(hand: Hand, region: str) -> str:
    """The frame name of a region in an exported file (``<region>__region`` when a link has its name)."""
    return f"{region}__region" if region in hand.link_names else region


def _region_frame(hand: Hand, name: str) -> tuple[str, np.ndarray, np.ndarray] | None:
    reg = hand.regions[name]
    if reg.region.frame is None:  # a region without a frame of its own is not marked
        return None
    return reg.link, reg.region.frame, reg.region.center


def hand_to_urdf(hand: Hand) -> str:
    """The URDF text of ``hand`` (see the module docstring)."""
    robot = ET.Element("robot", name=hand.name)
    coupled = {c.dof: c for c in hand.couplings}
    extras: list[str] = []
    joints = ET.Element("joints")
    for joint in hand.joints:
        extras += _urdf_joints(joints, joint, coupled)
    for link in hand.links:
        elem = ET.SubElement(robot, "link", name=link.name)
        for cap in link.collision:
            _capsule_urdf(elem, cap)
    for name in extras:
        ET.SubElement(robot, "link", name=name)
    robot.extend(list(joints))
    for region in hand.regions:
        frame, name = _region_frame(hand, region), region_frame_name(hand, region)
        if frame is not None and name not in extras:
            ET.SubElement(robot, "link", name=name)
            _UrdfJoint(f"{name}__frame", frame[0], name, frame[1], frame[2]).write(robot)
    return '<?xml version="1.0"?>\n' + _pretty(robot)


# -- MJCF ------------------------------------------------------------------------------------------
def _mjcf_body(parent: ET.Element, hand: Hand, link: str, joint: Joint | None) -> ET.Element:
    if joint is None:
        body = ET.SubElement(parent, "body", name=link)
    else:
        R0, P, Q = joint.R_parent_child_zero, joint.origin_in_parent, joint.origin_in_child
        body = ET.SubElement(parent, "body", name=link, pos=_vec(P - R0 @ Q, _M), quat=_vec(_quat(R0)))
        axes = [R0.T @ joint.axis_in_parent] + ([joint.axis_in_child] if joint.kind == "universal" else [])
        for d, axis, lo, hi in zip(joint.dof_names, axes, joint.lower, joint.upper):
            ET.SubElement(body, "joint", name=d, type="hinge", pos=_vec(Q, _M), axis=_vec(axis), range=f"{_num(lo)} {_num(hi)}")
    ET.SubElement(body, "inertial", pos="0 0 0", mass="0.001", diaginertia="1e-08 1e-08 1e-08")
    for cap in hand.links[hand.link_index(link)].collision:
        if np.array_equal(cap.a, cap.b):
            ET.SubElement(body, "geom", type="sphere", pos=_vec(cap.a, _M), size=_num(cap.radius * _M))
        else:
            ET.SubElement(body, "geom", type="capsule", fromto=f"{_vec(cap.a, _M)} {_vec(cap.b, _M)}", size=_num(cap.radius * _M))
    for region in hand.regions:
        frame = _region_frame(hand, region)
        if frame is not None and frame[0] == link:
            name = region_frame_name(hand, region)
            ET.SubElement(body, "site", name=name, pos=_vec(frame[2], _M), quat=_vec(_quat(frame[1])))
    return body


def hand_to_mjcf(hand: Hand) -> str:
    """The MJCF text of ``hand`` (see the module docstring)."""
    root = ET.Element("mujoco", model=hand.name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    ET.SubElement(ET.SubElement(root, "option"), "flag", gravity="disable")
    world = ET.SubElement(root, "worldbody")
    bodies = {hand.palm: _mjcf_body(world, hand, hand.palm, None)}
    for joint in hand.joints:
        bodies[joint.child] = _mjcf_body(bodies[joint.parent], hand, joint.child, joint)
    if hand.couplings:
        eq = ET.SubElement(root, "equality")
        for c in hand.couplings:
            ET.SubElement(eq, "joint", joint1=c.dof, joint2=c.source, polycoef=f"{_num(c.offset)} {_num(c.ratio)} 0 0 0")
    if hand.collision_exclusions:
        contact = ET.SubElement(root, "contact")
        for a, b in hand.collision_exclusions:
            ET.SubElement(contact, "exclude", body1=a, body2=b)
    return _pretty(root)
