"""Tasks and configurations: what both solvers are asked, and what they answer.

A :class:`Task` is a hand, an object, and the contacts the grasp must make ("hand region
``h_c`` touches object region ``o_c``", sec. 2.2 of Rosales et al.), plus the fingers
that take part.  Joint angles of fingers that do not take part are held at their *idle*
values (zero clamped into the limits, unless the task says otherwise), as the CuikSuite
files hold unused fingers with zero-width ranges.

A :class:`Configuration` is a candidate answer: every joint angle, the object pose in the
palm frame and, optionally, the contact parameters of each contact (where on each region
the contact is made).  :func:`prehension.verification.residuals.evaluate` decides whether it is a
solution.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from ..frozen import FrozenMap
from typing import Mapping

import numpy as np

from ..errors import InvalidConfiguration, InvalidTask, PrehensionError
from ..geometry.regions import Region
from ..hands.model import Hand
from ..objects.model import GraspObject

__all__ = ["Contact", "Task", "Configuration"]


@dataclass(frozen=True)
class Contact:
    """Hand region ``hand_region`` must touch object region ``object_region``."""

    hand_region: str
    object_region: str
    name: str = ""

    def __post_init__(self):
        if not self.name:
            object.__setattr__(self, "name", f"{self.hand_region}->{self.object_region}")


def validate_task(name, check) -> None:
    """Run ``check()``; an error other than :class:`InvalidTask` (an unknown link, region,
    finger...) becomes one that names the task."""
    try:
        check()
    except InvalidTask:
        raise
    except PrehensionError as exc:
        raise InvalidTask(f"task {name!r}: {exc}") from None


def check_head(name, contacts) -> None:
    """A task's name is a non-empty string and it has at least one contact."""
    if not isinstance(name, str) or not name.strip():
        raise InvalidTask(f"a task needs a non-empty name, got {name!r}")
    if not contacts:
        raise InvalidTask(f"task {name!r} has no contacts; give at least one hand/object region pair")


@dataclass(frozen=True, eq=False)
class Task:
    """A grasp configuration problem.

    Attributes:
        name: task name.
        hand: the hand (its ``regions`` hold every hand region the contacts name).
        object: the object.
        contacts: the contacts to make, in order.
        fingers: names of the fingers that take part (may move).
        description: free text.
        idle_angles: angles [rad] of dofs that do not take part, by dof name; dofs
            not listed are held at zero clamped into their limits.  Solvers hold idle
            fingers there; the residual function does not require it (an idle finger
            anywhere within its limits, clear of the others, is still a valid grasp).
    """

    name: str
    hand: Hand
    object: GraspObject
    contacts: tuple[Contact, ...]
    fingers: tuple[str, ...]
    description: str = ""
    idle_angles: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "contacts", tuple(self.contacts))
        object.__setattr__(self, "fingers", tuple(self.fingers))
        object.__setattr__(self, "idle_angles", FrozenMap(dict(self.idle_angles)))
        validate_task(self.name, self._validate)

    def _validate(self) -> None:
        check_head(self.name, self.contacts)
        for f in self.fingers:
            self.hand.finger(f)
        names = [c.name for c in self.contacts]
        if len(set(names)) != len(names):
            raise InvalidTask(f"task {self.name!r}: contact names must be unique, got {names}")
        for c in self.contacts:
            link = self.hand.region(c.hand_region).link
            self.object.region(c.object_region)
            finger = self.hand.finger_of_link(link)
            if finger is not None and finger not in self.fingers:
                raise InvalidTask(
                    f"task {self.name!r}: contact {c.name!r} uses link {link!r} of finger {finger!r}, "
                    f"which does not take part; fingers taking part: {list(self.fingers)}"
                )
        for dof, value in self.idle_angles.items():
            i = self.hand.dof_index(dof)
            if not (self.hand.lower[i] - 1e-12 <= value <= self.hand.upper[i] + 1e-12):
                raise InvalidTask(f"task {self.name!r}: idle angle of {dof!r} ({value} rad) is outside its limits")
        for cpl in self.hand.couplings:
            if self.dof_is_active(cpl.dof) != self.dof_is_active(cpl.source):
                raise InvalidTask(
                    f"task {self.name!r}: coupled angles {cpl.dof!r} and {cpl.source!r} must both take part or both be idle"
                )

    # -- which dofs move ------------------------------------------------------------
    def dof_is_active(self, dof: str) -> bool:
        return bool(self.active_mask[self.hand.dof_index(dof)])

    @cached_property
    def active_mask(self) -> np.ndarray:
        """(n_dof,) bool: the dofs that move the links of the participating fingers, with
        the dofs coupled to them (:meth:`Hand.active_dofs`; computed once; read-only)."""
        mask = self.hand.active_dofs(self.fingers)
        mask.setflags(write=False)
        return mask

    @cached_property
    def idle_vector(self) -> np.ndarray:
        """(n_dof,) [rad]: the value of every dof that does not take part (others: 0)
        (computed once; read-only)."""
        q = np.clip(0.0, self.hand.lower, self.hand.upper)
        for dof, value in self.idle_angles.items():
            q[self.hand.dof_index(dof)] = value
        idle = np.where(self.active_mask, 0.0, q)
        idle.setflags(write=False)
        return idle

    def hand_region(self, contact: Contact):
        return self.hand.region(contact.hand_region)

    def object_region(self, contact: Contact) -> Region:
        return self.object.region(contact.object_region)

    @property
    def n_contact_params(self) -> int:
        """Total number of region parameters over all contacts (hand + object)."""
        return sum(
            self.hand_region(c).region.n_params + self.object_region(c).n_params for c in self.contacts
        )

    def counts(self) -> dict[str, int]:
        """Sizes of the problem in the configuration variables both solvers use.

        ``variables`` = independent moving angles + 6 (object pose) + region parameters
        (+1 per contact for the free spin about the common normal, which the object pose
        already holds, so it is *not* counted); ``equations`` = 5 per contact (3 for the
        point, 2 for the normal direction); ``dimension`` = variables - equations, the
        expected dimension of the solution set when the equations are independent.
        """
        coupled = {c.dof for c in self.hand.couplings}
        active = [d for d, a in zip(self.hand.dof_names, self.active_mask) if a]
        free = [d for d in active if d not in coupled]
        n_var = len(free) + 6 + self.n_contact_params
        n_eq = 5 * len(self.contacts)
        return {
            "moving_angles": len(active),
            "independent_angles": len(free),
            "region_parameters": self.n_contact_params,
            "variables": n_var,
            "equations": n_eq,
            "dimension": n_var - n_eq,
        }


_EYE3 = np.eye(3)
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def _close(a: np.ndarray, b: np.ndarray, atol: float, rtol: float = 1e-5) -> bool:
    """``np.allclose(a, b, rtol, atol)`` for finite arrays, without its generic handling
    (one configuration is checked per solution: this runs thousands of times a second)."""
    return bool(np.all(np.abs(a - b) <= atol + rtol * np.abs(b)))


def _det3(R: np.ndarray) -> float:
    """Determinant of a (3, 3) matrix by cofactors (its sign is all that is asked: R is
    orthonormal to 1e-6 when this runs, so the determinant is +-1 to rounding)."""
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


@dataclass(frozen=True, eq=False)
class Configuration:
    """A candidate grasp.

    Attributes:
        joint_angles: (n_dof,) every joint angle of the hand [rad], in ``hand.dof_names`` order.
        T_palm_object: (4, 4) object pose in the palm frame (``x_palm = T x_object``, mm).
        contact_params: per contact, ``(hand_params (k_h,), object_params (k_o,))``: where
            on each region the contact is made; ``None`` lets the residual function find
            the best-fitting parameters itself.
    """

    joint_angles: np.ndarray
    T_palm_object: np.ndarray
    contact_params: tuple[tuple[np.ndarray, np.ndarray], ...] | None = None

    def __post_init__(self):
        quick = _quick_arrays(self.joint_angles, self.T_palm_object, self.contact_params)
        if quick is None:  # something is off: the checks one by one say what
            self._check_slowly()
            return
        q, T, pairs = quick
        if not _rigid(T):
            raise InvalidConfiguration(_NOT_RIGID)
        object.__setattr__(self, "joint_angles", q)
        object.__setattr__(self, "T_palm_object", T)
        if pairs is not None:
            object.__setattr__(self, "contact_params", pairs)

    def _check_slowly(self) -> None:
        """Each array checked and converted in turn: the first problem raises, by name."""
        q = np.asarray(self.joint_angles, dtype=float)
        if q.ndim != 1 or not np.isfinite(q).all():
            raise InvalidConfiguration(f"joint_angles must be a 1-D array of finite angles [rad], got shape {q.shape}")
        T = np.asarray(self.T_palm_object, dtype=float)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise InvalidConfiguration(f"T_palm_object must be a finite 4x4 transform, got shape {T.shape}")
        if not _rigid(T):
            raise InvalidConfiguration(_NOT_RIGID)
        object.__setattr__(self, "joint_angles", q)
        object.__setattr__(self, "T_palm_object", T)
        if self.contact_params is not None:
            object.__setattr__(self, "contact_params", tuple(_pair(i, p) for i, p in enumerate(self.contact_params)))

    def check_against(self, task: Task) -> None:
        """Raise :class:`InvalidConfiguration` if the shapes do not fit ``task``."""
        if self.joint_angles.shape != (task.hand.n_dof,):
            raise InvalidConfiguration(
                f"configuration has {self.joint_angles.size} joint angles; hand {task.hand.name!r} has "
                f"{task.hand.n_dof}: {', '.join(task.hand.dof_names)}"
            )
        if self.contact_params is None:
            return
        if len(self.contact_params) != len(task.contacts):
            raise InvalidConfiguration(
                f"configuration gives parameters for {len(self.contact_params)} contacts; task has {len(task.contacts)}"
            )
        for c, (h, o) in zip(task.contacts, self.contact_params):
            kh, ko = task.hand_region(c).region.n_params, task.object_region(c).n_params
            if h.size != kh or o.size != ko:
                raise InvalidConfiguration(
                    f"contact {c.name!r}: expected {kh} hand and {ko} object parameters, got {h.size} and {o.size}"
                )


_NOT_RIGID = "T_palm_object must be a rigid transform (rotation block orthonormal, det +1, last row 0 0 0 1)"
_FLOAT = np.dtype(float)


def _rigid(T: np.ndarray) -> bool:
    R = T[:3, :3]
    return _close(R.T @ R, _EYE3, 1e-6) and _det3(R) >= 0 and _close(T[3], _LAST_ROW, 1e-8)


def _floats(values) -> np.ndarray:
    """``np.asarray(values, dtype=float)``: the array itself when it is one already."""
    return values if type(values) is np.ndarray and values.dtype == _FLOAT else np.asarray(values, dtype=float)


def _quick_arrays(joint_angles, T_palm_object, contact_params):
    """``(q, T, pairs)`` as :meth:`Configuration._check_slowly` makes them when every
    shape is right and every number finite (one finiteness test for all of them), else
    ``None`` (nothing raised here: the slow checks name the problem, in their order)."""
    try:
        q, T = _floats(joint_angles), _floats(T_palm_object)
        if q.ndim != 1 or T.shape != (4, 4):
            return None
        parts, pairs = [q, T.ravel()], None
        if contact_params is not None:
            if not isinstance(contact_params, (tuple, list)):  # e.g. an iterator: read once, slowly
                return None
            pairs = []
            for h, o in contact_params:
                h, o = _floats(h), _floats(o)
                if h.ndim > 1 or o.ndim > 1:
                    return None
                h, o = (h if h.ndim else h[None]), (o if o.ndim else o[None])
                pairs.append((h, o))
                parts += (h, o)
            pairs = tuple(pairs)
    except (TypeError, ValueError):
        return None
    return (q, T, pairs) if np.isfinite(np.concatenate(parts)).all() else None


def _pair(i: int, pair) -> tuple[np.ndarray, np.ndarray]:
    """One contact's ``(hand_params, object_params)`` as two finite 1-D arrays."""
    try:
        h, o = pair
        h, o = np.asarray(h, dtype=float), np.asarray(o, dtype=float)
    except (TypeError, ValueError):
        raise InvalidConfiguration(
            f"contact_params[{i}] must be a pair (hand_params, object_params) of numbers"
        ) from None
    for what, arr in (("hand", h), ("object", o)):
        if arr.ndim > 1 or not np.isfinite(arr).all():
            raise InvalidConfiguration(
                f"contact_params[{i}]: {what} parameters must be a flat list of finite numbers, got shape {arr.shape}"
            )
    return np.atleast_1d(h), np.atleast_1d(o)
