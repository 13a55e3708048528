"""The neutral description of a hand file: what each reader (URDF, MJCF) produces.

A reader turns its format into a :class:`RawHand`: links with their shapes, joints with
their transforms, couplings as stated, and what it noticed (warnings).  One assembler
(:mod:`prehension.hands.assemble`) turns any :class:`RawHand` into a
:class:`~prehension.hands.model.Hand`: merging fixed joints into named frames, finding
the palm and the fingers, fitting fingertips.  A new format touches one reader.

Conventions (every length in mm, every transform ``T_a_b`` maps b coordinates to a):

* a joint places its child by ``T_parent_child(q) = T_parent_joint Rot(axis, q) T_joint_child``
  with ``axis`` a unit vector in the joint frame (URDF: ``T_joint_child = I``; MJCF:
  the body frame, the joint's anchor and its reference angle);
* a shape lives in its link frame at ``T_link_shape``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Literal

import numpy as np

from .model import LinkMesh

__all__ = ["RawShape", "RawJoint", "RawCoupling", "RawHand", "SHAPE_KINDS"]

SHAPE_KINDS = ("sphere", "capsule", "cylinder", "box", "ellipsoid", "mesh")


@dataclass(frozen=True, eq=False)
class RawShape:
    """One collision or visual shape of a link.

    Attributes:
        kind: one of :data:`SHAPE_KINDS`.
        role: ``"collision"`` or ``"visual"``.
        T_link_shape: (4, 4) pose of the shape in its link frame [mm].
        size: the kind's sizes [mm]: sphere ``(r,)``; capsule and cylinder ``(r, length)``
            along the shape's z axis; box ``(x, y, z)`` full side lengths; ellipsoid
            ``(a, b, c)`` semi-axes; mesh ``()``.
        vertices: for a mesh, a function returning its vertices (n, 3) in the shape
            frame [mm]; it may raise ``OSError`` / ``ValueError`` (missing or unreadable
            file), which the assembler reports as a warning.
        what: how messages name it (``"link 'a' collision 0"``).
        file: for a mesh, the file that draws it (:class:`~prehension.hands.model.LinkMesh`,
            its ``T_link_mesh`` the file's frame in the *shape* frame: the identity for a
            URDF mesh, MuJoCo's re-centring for an MJCF one); the assembler moves it into
            the link frame.  ``None``: a primitive, or a mesh without a file.
    """

    kind: str
    role: Literal["collision", "visual"]
    T_link_shape: np.ndarray
    size: tuple[float, ...] = ()
    vertices: Callable[[], np.ndarray] | None = None
    what: str = ""
    file: LinkMesh | None = None


@dataclass(frozen=True, eq=False)
class RawJoint:
    """One joint as read.

    Attributes:
        name: joint name (also the name of its dof).
        type: ``"revolute"`` (1 dof), ``"fixed"``, or the file's name of an unsupported
            type (``"prismatic"``, ``"slide"``, ``"ball"``, ``"free"``...), held fixed
            at its reference position with a warning when it lies below the palm.
        parent, child: link names.
        T_parent_joint, T_joint_child: (4, 4) fixed transforms [mm].
        axis: (3,) unit rotation axis in the joint frame.
        limits: ``(lower, upper)`` [rad].
    """

    name: str
    type: str
    parent: str
    child: str
    T_parent_joint: np.ndarray
    T_joint_child: np.ndarray = field(default_factory=lambda: np.eye(4))
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    limits: tuple[float, float] = (0.0, 0.0)

    @property
    def T_fixed(self) -> np.ndarray:
        """``T_parent_child`` at zero angle (4, 4)."""
        return self.T_parent_joint @ self.T_joint_child


@dataclass(frozen=True)
class RawCoupling:
    """``q[dof] = ratio * q[source] + offset`` as stated in the file (``source`` may
    itself be coupled: the assembler follows chains)."""

    dof: str
    source: str
    ratio: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, eq=False)
class RawHand:
    """A hand file, read.

    Attributes:
        name: the model's name.
        links: link names in file order.
        shapes: per link name, its shapes.
        joints: every joint (any order, any type).
        couplings: couplings as stated.
        warnings: what the reader noticed (ignored elements...).
        where: the file (or ``"<URDF text>"``) for messages.
        exclusions: link pairs the file says never to check for collision.
    """

    name: str
    links: tuple[str, ...]
    shapes: dict[str, list[RawShape]]
    joints: tuple[RawJoint, ...]
    couplings: tuple[RawCoupling, ...] = ()
    warnings: tuple[str, ...] = ()
    where: str = ""
    exclusions: tuple[tuple[str, str], ...] = ()
