"""Typed keys of the system's base variables (the seam between formulation and embedding).

The system is written in the **object frame**: every rotation variable is an entry of
``R_object_link`` (``x_object = R_object_link x_link``), the palm's position is
``p_palm_in_object``, object points and normals are in the object's own coordinates.  A
*base* variable is one whose value is not a function of earlier variables (the others --
squares, products, Bernstein forms, linear combinations -- follow from them, see
:meth:`~prehension.system.builder.Builder.complete_point`).  Each base variable is named
by one small frozen key, so that :func:`~prehension.system.embedding.embed` can compute its
value from a configuration by dispatching on the key's type, never by decoding strings.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Union

__all__ = ["BaseKey", "ContactVariables", "NormalLength", "PalmOrigin", "PatchParameter", "QuaternionComponent", "RotationEntry",
           "Side", "UnitNormal"]


class Side(str, Enum):
    """Which side of a contact a variable belongs to."""

    OBJECT = "object"
    HAND = "hand"


@dataclass(frozen=True)
class RotationEntry:
    """Entry ``(row, col)`` of ``R_object_link``: the rotation of ``link`` in the object frame."""

    link: str
    row: int
    col: int


@dataclass(frozen=True)
class QuaternionComponent:
    """Component ``index`` (0: ``w``, 1-3: ``x, y, z``) of the unit quaternion of ``R_object_link``,
    the one with ``w >= 0`` (only in a system built with quaternions, :func:`.formulation.build_system`)."""

    link: str
    index: int


@dataclass(frozen=True)
class PalmOrigin:
    """Coordinate ``axis`` (0, 1, 2) of ``p_palm_in_object``: the palm origin in the object frame [mm]."""

    axis: int


@dataclass(frozen=True)
class PatchParameter:
    """Parameter ``index`` (0: ``s``, 1: ``t``) of the Bézier patch on one side of contact ``contact``."""

    contact: int
    side: Side
    index: int


@dataclass(frozen=True)
class UnitNormal:
    """Component ``axis`` of the unit outward normal ``nu`` of one side's region of a contact,
    in that region's frame: the object frame for the object side, the link frame for a hand
    patch."""

    contact: int
    side: Side
    axis: int


@dataclass(frozen=True)
class NormalLength:
    """``mu = |p_s x p_t|`` of a Bézier patch (its normal patch is ``N = mu nu``, eqs. 22-25)."""

    contact: int
    side: Side


BaseKey = Union[RotationEntry, QuaternionComponent, PalmOrigin, PatchParameter, UnitNormal, NormalLength]


@dataclass(frozen=True)
class ContactVariables:
    """Indices of the variables of one contact that a configuration is read back from.

    Attributes:
        object_params: ``(s, t)`` of an object Bézier patch, else None.
        object_normal: ``(3,)`` unit outward object normal ``nu`` (object frame) of an
            object patch or sphere cap, else None (a point region's normal is constant).
        hand_params: ``(s, t)`` of a hand Bézier patch, else None.
    """

    object_params: tuple[int, int] | None = None
    object_normal: tuple[int, int, int] | None = None
    hand_params: tuple[int, int] | None = None
