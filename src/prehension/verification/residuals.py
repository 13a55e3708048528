"""The one residual function that decides what counts as a solution.

Solvers, tests, benchmarks and ``prehension check`` all call :func:`evaluate`.  Given a
task and a configuration it reports, in physical units:

* per contact: the distance between the hand point and the object point [mm]
  (eq. 15), the angle between the hand normal and the *opposite* of the object normal
  [deg] (eq. 16), and how far each region's parameters lie outside the region
  (patch parameters outside [0, 1]; a sphere cap's normal outside its cone, in deg);
* per joint angle: how far it lies outside its limits [deg];
* per coupling: ``|q[dof] - (ratio q[source] + offset)|`` [deg];
* per pair of collision capsules: the penetration depth [mm] (0 when apart);
* per link with collision capsules, when the object has a solid that collides: how deep
  the link reaches into the object [mm], only what lies inside a contact's own pad excused;
  and per contact, how deep its pad (a fingertip cap's ball) reaches into the object [mm]
  (:mod:`prehension.tasks.object_collision` defines both exactly).

Each value is compared with a :class:`Tolerances` entry; a configuration is a solution
when every check passes.  The batch cores (:func:`contact_residuals`,
:func:`limit_violations`, :func:`coupling_violations`) work on ``B`` configurations at once.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np

from ..frozen import cached_per_value
from ..geometry.regions import evaluate_regions
from ..geometry.rotations import angle_between
from ..hands.collision import capsule_clearances
from ..hands.kinematics import HandPose, as_batch, forward_kinematics
from ..tasks.locate import locate_contact_params
from ..tasks.model import Configuration, Task

__all__ = [
    "Tolerances",
    "TOLERANCE_OF_KIND",
    "Check",
    "ContactState",
    "ResidualReport",
    "evaluate",
    "contact_residuals",
    "limit_violations",
    "coupling_violations",
]


@dataclass(frozen=True)
class Tolerances:
    """Largest violation of each kind that still counts as satisfied.

    The defaults are those of a *verified* solution: contacts within 1e-6 mm and 1e-6 deg,
    limits and couplings exact up to rounding, no self-penetration, and no link deeper
    than 0.5 mm into the object (``object_penetration_mm``: a hand and an object touch
    over a patch, not a point, so a fraction of a millimetre is contact, not collision).
    The local solver's acceptance test (``d_min`` of Claret & Suárez) passes looser
    contact tolerances.
    """

    contact_mm: float = 1e-6
    normal_deg: float = 1e-6
    region: float = 1e-9  # patch parameters (unitless) and cap cones (deg)
    limit_deg: float = 1e-9
    coupling_deg: float = 1e-9
    penetration_mm: float = 0.0
    object_penetration_mm: float = 0.5


TOLERANCE_OF_KIND = {
    "contact_distance": "contact_mm",
    "contact_normal": "normal_deg",
    "hand_region": "region",
    "object_region": "region",
    "joint_limit": "limit_deg",
    "coupling": "coupling_deg",
    "collision": "penetration_mm",
    "object_collision": "object_penetration_mm",
    "pad_collision": "object_penetration_mm",
}  # each kind of check, and the Tolerances field it is judged with


@dataclass(frozen=True)
class Check:
    """One constraint: ``value`` (>= 0) is its violation, in ``unit``."""

    kind: str  # contact_distance | contact_normal | hand_region | object_region | joint_limit | coupling | collision | object_collision | pad_collision
    name: str
    value: float
    unit: str
    tolerance: float

    @property
    def ok(self) -> bool:
        return bool(self.value <= self.tolerance)

    def describe(self) -> str:
        verdict = "ok" if self.ok else "FAILED"
        return f"{self.kind} {self.name}: {self.value:.3g} {self.unit} (tolerance {self.tolerance:g}) {verdict}"


@dataclass(frozen=True, eq=False)
class ContactState:
    """Where a contact is made, in the palm frame (points in mm, unit normals)."""

    name: str
    hand_params: np.ndarray
    object_params: np.ndarray
    hand_point: np.ndarray
    hand_normal: np.ndarray
    object_point: np.ndarray
    object_normal: np.ndarray
    distance_mm: float
    normal_angle_deg: float


class ResidualReport:
    """Every check of a configuration against a task (read-only).

    ``ResidualReport(checks, contacts)`` holds given :class:`Check` objects;
    :func:`evaluate` builds it from columns (:meth:`from_columns`: one kind, name, value,
    unit and tolerance per check) and makes the :class:`Check` objects only when
    :attr:`checks` is read, so that judging a configuration (:attr:`ok`, :meth:`worst`)
    costs no object per check.  Either way the same checks, in the same order.
    """

    __slots__ = ("_kinds", "_names", "_values", "_units", "_tolerances", "_checks", "contacts", "_worst")

    def __init__(self, checks: Sequence[Check], contacts: tuple[ContactState, ...]):
        checks = tuple(checks)
        self._fill(
            tuple(c.kind for c in checks), tuple(c.name for c in checks), [c.value for c in checks],
            tuple(c.unit for c in checks), [c.tolerance for c in checks], checks, tuple(contacts),
        )  # fmt: skip

    @classmethod
    def from_columns(cls, kinds, names, values, units, tolerances, contacts) -> "ResidualReport":
        """A report of ``len(kinds)`` checks: ``kinds``, ``names``, ``units`` (str each),
        ``values`` and ``tolerances`` (floats each, in the checks' units)."""
        report = cls.__new__(cls)
        report._fill(tuple(kinds), tuple(names), [float(v) for v in values], tuple(units),
                     [float(t) for t in tolerances], None, tuple(contacts))  # fmt: skip
        return report

    @classmethod
    def _from_floats(cls, kinds: tuple, names: tuple, values: list, units: tuple, tolerances: list, contacts: tuple):
        """:meth:`from_columns` of columns already of the right types (tuples of str, lists
        of Python floats), as :func:`evaluate` builds them: nothing converted again."""
        report = cls.__new__(cls)
        report._fill(kinds, names, values, units, tolerances, None, contacts)
        return report

    def _fill(self, kinds, names, values, units, tolerances, checks, contacts) -> None:
        if not len(kinds) == len(names) == len(values) == len(units) == len(tolerances):
            raise ValueError("a residual report needs one kind, name, value, unit and tolerance per check")
        for key, value in zip(self.__slots__, (kinds, names, values, units, tolerances, checks, contacts, None)):
            object.__setattr__(self, key, value)

    def __setattr__(self, key, value):
        raise AttributeError(f"a ResidualReport is read-only (cannot set {key!r})")

    def __reduce__(self):  # pickled between processes (batch workers): the columns travel
        state = (self._kinds, self._names, self._values, self._units, self._tolerances, self._checks, self.contacts)
        return _report_from_state, state

    @property
    def checks(self) -> tuple[Check, ...]:
        if self._checks is None:
            made = tuple(map(Check, self._kinds, self._names, self._values, self._units, self._tolerances))
            object.__setattr__(self, "_checks", made)
        return self._checks

    @property
    def kinds(self) -> tuple[str, ...]:
        """The distinct kinds of check, in order of first appearance."""
        return tuple(dict.fromkeys(self._kinds))

    @property
    def ok(self) -> bool:
        return all(map(operator.le, self._values, self._tolerances))  # every value <= its tolerance (NaN fails)

    @property
    def failures(self) -> tuple[Check, ...]:
        return tuple(c for c, v, t in zip(self.checks, self._values, self._tolerances) if not v <= t)

    def worst(self, kind: str) -> float:
        """Largest violation of one kind (0 when there is no such check)."""
        if self._worst is None:  # every kind's largest value (max() over each kind's values in order)
            worst = {k: max(take(self._values)) for k, take in _kind_getters(self._kinds)}
            object.__setattr__(self, "_worst", worst)
        return self._worst.get(kind, 0.0)

    def judged(self, tolerances: "Tolerances") -> "ResidualReport":
        """The same checks judged with other tolerances (what :func:`evaluate` reports with
        ``tolerances`` for the same configuration: its values do not depend on them)."""
        tols = [getattr(tolerances, TOLERANCE_OF_KIND[k]) for k in self._kinds]
        return ResidualReport.from_columns(self._kinds, self._names, self._values, self._units, tols, self.contacts)

    def summary(self) -> str:
        if self.ok:
            return "all constraints satisfied"
        return "; ".join(c.describe() for c in self.failures)


@lru_cache(maxsize=256)
def _kind_getters(kinds: tuple[str, ...]) -> tuple:
    """Per distinct kind (in order of first appearance): a function of the values list
    giving that kind's values, in order (the same kinds for every configuration of a task)."""
    where: dict = {}
    for i, k in enumerate(kinds):
        where.setdefault(k, []).append(i)
    return tuple((k, _getter(idx)) for k, idx in where.items())


def _getter(idx: list[int]):
    if len(idx) == 1:
        i = idx[0]
        return lambda values: (values[i],)
    return operator.itemgetter(*idx)


def _report_from_state(kinds, names, values, units, tolerances, checks, contacts) -> ResidualReport:
    report = ResidualReport.__new__(ResidualReport)
    report._fill(kinds, names, values, units, tolerances, checks, contacts)
    return report


# -- batch cores ------------------------------------------------------------------------
def _transform_points(T, p) -> np.ndarray:
    return np.einsum("bij,bj->bi", T[:, :3, :3], p) + T[:, :3, 3]


def contact_residuals(task: Task, pose: HandPose, T_palm_object, params) -> dict[str, np.ndarray]:
    """Contact errors of ``B`` configurations.

    Args:
        task: the task.
        pose: forward kinematics of the ``B`` configurations.
        T_palm_object: (B, 4, 4) object poses.
        params: per contact, ``(hand_params (B, k_h), object_params (B, k_o))``.

    Returns:
        ``distance_mm (B, C)``, ``normal_angle_deg (B, C)``, ``hand_region (B, C)``,
        ``object_region (B, C)`` and the palm-frame ``hand_point``, ``hand_normal``,
        ``object_point``, ``object_normal`` (B, C, 3).
    """
    T = np.asarray(T_palm_object, dtype=float).reshape(-1, 4, 4)
    regions, links = _contact_sides(task)
    C = len(links)  # the hand's regions, then the object's: one call evaluates both sides
    pts, nrms, out = evaluate_regions(regions, [hp for hp, _ in params] + [op for _, op in params])
    h_pt, h_n, h_out, o_pt, o_n, o_out = pts[:, :C], nrms[:, :C], out[:, :C], pts[:, C:], nrms[:, C:], out[:, C:]
    R, r = pose.R_palm_link[:, links], pose.r_palm_link[:, links]  # (B, C, 3, 3), (B, C, 3)
    R_o = T[:, :3, :3]  # (B, 3, 3): one rotation for every contact (einsum broadcasts it, the same sums)
    res = {
        "hand_point": np.einsum("bcij,bcj->bci", R, h_pt) + r,
        "hand_normal": np.einsum("bcij,bcj->bci", R, h_n),
        "object_point": np.einsum("bij,bcj->bci", R_o, o_pt) + T[:, None, :3, 3],
        "object_normal": np.einsum("bij,bcj->bci", R_o, o_n),
        "hand_region": h_out,
        "object_region": o_out,
    }
    gap = res["hand_point"] - res["object_point"]
    res["distance_mm"] = np.sqrt(np.add.reduce(gap * gap, axis=-1))  # np.linalg.norm(gap, axis=-1) without its wrapper
    res["normal_angle_deg"] = np.degrees(angle_between(res["hand_normal"], -res["object_normal"]))
    return res


@cached_per_value
def _contact_sides(task: Task) -> tuple[tuple, np.ndarray]:
    """The regions of the ``C`` contacts, the hand's then the object's (2C,), and the index
    of each hand region's link (C,) -- the same for every configuration of a task."""
    hregs = [task.hand_region(c) for c in task.contacts]
    links = np.array([task.hand.link_index(h.link) for h in hregs], dtype=np.intp)
    links.setflags(write=False)
    return tuple(h.region for h in hregs) + tuple(task.object_region(c) for c in task.contacts), links


def limit_violations(hand, q) -> np.ndarray:
    """How far each angle lies outside its limits, (B, n_dof) [rad], 0 inside."""
    q = as_batch(q, hand.n_dof)
    lower, upper = _limit_arrays(hand)
    return np.maximum(np.maximum(lower - q, q - upper), 0.0)


def coupling_violations(hand, q) -> np.ndarray:
    """``|q[dof] - (ratio q[source] + offset)|`` per coupling, (B, n_couplings) [rad]."""
    q = as_batch(q, hand.n_dof)
    if not hand.couplings:
        return np.zeros((q.shape[0], 0))
    dof, src, ratio, offset = _coupling_arrays(hand)
    return np.abs(q[:, dof] - (ratio * q[:, src] + offset))


@cached_per_value
def _limit_arrays(hand) -> tuple[np.ndarray, np.ndarray]:
    """``(hand.lower, hand.upper)`` (n_dof,) [rad], read-only, once per hand."""
    lower, upper = hand.lower, hand.upper
    lower.setflags(write=False)
    upper.setflags(write=False)
    return lower, upper


@cached_per_value
def _coupling_arrays(hand) -> tuple[np.ndarray, ...]:
    """Per coupling: ``dof`` and ``source`` indices, ``ratio``, ``offset``, once per hand."""
    return (
        np.array([hand.dof_index(c.dof) for c in hand.couplings]),
        np.array([hand.dof_index(c.source) for c in hand.couplings]),
        np.array([c.ratio for c in hand.couplings]),
        np.array([c.offset for c in hand.couplings]),
    )


# -- one configuration, with names ------------------------------------------------------
def evaluate(task: Task, config: Configuration, tolerances: Tolerances = Tolerances(), *,
             pose: HandPose | None = None) -> ResidualReport:  # fmt: skip
    """Check ``config`` against every constraint of ``task`` (see the module docstring).

    When ``config.contact_params`` is ``None``, the parameters of each contact are those
    that bring its two regions closest (:func:`~prehension.tasks.locate.locate_contact_params`).
    ``pose``: ``forward_kinematics(task.hand, config.joint_angles)`` when the caller has
    computed it already (it is not computed twice).
    """
    config.check_against(task)
    return _evaluate(task, config, tolerances, pose)


def _evaluate(task: Task, config: Configuration, tolerances: Tolerances, pose: HandPose | None) -> ResidualReport:
    """:func:`evaluate` of a configuration whose shapes fit the task (``check_against`` done)."""
    if pose is None:
        pose = forward_kinematics(task.hand, config.joint_angles)
    T = config.T_palm_object[None]
    params = config.contact_params
    if params is None:
        params = locate_contact_params(task, pose, config.T_palm_object)
    batch_params = [(h[None], o[None]) for h, o in params]
    res = contact_residuals(task, pose, T, batch_params)
    q = config.joint_angles
    clearance, pair_names = capsule_clearances(task.hand, pose)
    kinds, names, units, tols = _fixed_columns(task, pair_names, tolerances)
    values = np.concatenate((
        _contact_values(res), np.degrees(limit_violations(task.hand, q)[0]),
        np.degrees(coupling_violations(task.hand, q)[0]), _link_pair_depths(clearance[0], pair_names),
    )).tolist()  # fmt: skip
    obj = _object_collision_checks(task, pose, config.T_palm_object, res["hand_point"][0], tolerances)
    if obj[0]:  # a solid that collides: its checks last
        kinds, names, units, tols = kinds + obj[0], names + obj[1], units + obj[3], tols + obj[4]
        values += obj[2]
    hp, hn, op, on = res["hand_point"][0], res["hand_normal"][0], res["object_point"][0], res["object_normal"][0]
    dist, ang = res["distance_mm"][0].tolist(), res["normal_angle_deg"][0].tolist()
    states = tuple(
        ContactState(c.name, params[i][0], params[i][1], hp[i], hn[i], op[i], on[i], dist[i], ang[i])
        for i, c in enumerate(task.contacts)
    )
    return ResidualReport._from_floats(kinds, names, values, units, list(tols), states)  # floats: see _fixed_columns


# The checks of a configuration, in order: per contact its distance [mm], normal angle
# [deg], hand and object region; per dof its limit [deg], per coupling [deg]; per pair of
# links with capsules their deepest penetration [mm]; per link with capsules its depth in
# the object [mm], then per contact its pad's depth [mm], when the object collides
# (:func:`_object_collision_checks`).  Every
# column but the values depends only on the task (and the tolerances): built once.
_CONTACT_KINDS = ("contact_distance", "contact_normal", "hand_region", "object_region")


def _fixed_columns(task: Task, pair_names: tuple, tolerances: Tolerances) -> tuple:
    """``(kinds, names, units, tolerances)`` of the contact, joint and collision checks of
    ``task`` (tuples: str each, Python floats), built once per task and tolerances (the
    capsule pairs' ``pair_names`` are the hand's one tuple, checked by identity)."""
    per_task = _columns_per_task(task)
    held = per_task.get(tolerances)
    if held is None or held[0] is not pair_names:
        held = per_task[tolerances] = (pair_names, _build_columns(task, pair_names, tolerances))
    return held[1]


@cached_per_value
def _columns_per_task(task: Task) -> dict:
    """Tolerances -> ``(pair_names, columns)`` of :func:`_fixed_columns`, per task."""
    return {}


def _build_columns(task: Task, pair_names: tuple, tol: Tolerances) -> tuple:
    """The columns of :func:`_fixed_columns`."""
    C = len(task.contacts)
    contact_names, contact_units = _contact_labels(task)
    hand = task.hand
    n, m = hand.n_dof, len(hand.couplings)
    labels = _link_pairs(pair_names)[0]
    k = len(labels)
    kinds = _CONTACT_KINDS * C + ("joint_limit",) * n + ("coupling",) * m + ("collision",) * k
    names = contact_names + _joint_labels(hand) + labels
    units = contact_units + ("deg",) * (n + m) + ("mm",) * k
    tols = ((float(tol.contact_mm), float(tol.normal_deg), float(tol.region), float(tol.region)) * C
            + (float(tol.limit_deg),) * n + (float(tol.coupling_deg),) * m + (float(tol.penetration_mm),) * k)  # fmt: skip
    return kinds, names, units, tols


def _contact_values(res) -> np.ndarray:
    """Per contact, in order: distance [mm], normal angle [deg], hand and object region, (4 C,)."""
    return np.stack([res[k][0] for k in ("distance_mm", "normal_angle_deg", "hand_region", "object_region")], axis=1).ravel()


def _link_pair_depths(clearance: np.ndarray, pair_names: tuple) -> np.ndarray:
    """Per pair of links (:func:`_link_pairs` order): the deepest penetration of their capsule pairs [mm]."""
    labels, group, starts = _link_pairs(pair_names)
    depth = np.zeros(len(labels))
    if group.size:  # the pairs of one pair of links are contiguous (collision_pairs sorts them)
        depth[group[starts]] = np.maximum.reduceat(np.maximum(-clearance, 0.0), starts)
    return depth


@cached_per_value
def _contact_labels(task: Task) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The names and units of a task's contact checks (the same for every configuration)."""
    units = tuple(u for c in task.contacts
                  for u in ("mm", "deg", _unit(task.hand_region(c).region), _unit(task.object_region(c))))  # fmt: skip
    return tuple(c.name for c in task.contacts for _ in range(4)), units


def _unit(region) -> str:
    return {"sphere_cap": "deg", "bezier": "param"}.get(region.kind, "-")


@cached_per_value
def _joint_labels(hand) -> tuple[str, ...]:
    """The names of a hand's limit and coupling checks."""
    return tuple(hand.dof_names) + tuple(f"{c.dof}={c.source}" for c in hand.couplings)


@lru_cache(maxsize=64)
def _link_pairs(names: tuple[tuple[str, str], ...]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """``("a/b" per link pair in order of first appearance, the link pair of each capsule
    pair, where each run of one link pair starts)`` for the capsule pairs' link ``names``
    (the same tuple for every call on a hand)."""
    order: dict = {}
    group = np.array([order.setdefault(pair, len(order)) for pair in names], dtype=np.intp)
    starts = np.flatnonzero(np.concatenate([[True], group[1:] != group[:-1]])) if group.size else np.zeros(0, np.intp)
    return tuple(f"{a}/{b}" for a, b in order), group, starts


def _object_collision_checks(task, pose, T_palm_object, hand_points_palm, tol) -> tuple:
    """``(kinds, names, values, units, tolerances)`` of the object's checks: per link with
    capsules its depth (``object_collision``), per contact its pad's (``pad_collision``)."""
    if not task.object.collides:
        return (), (), [], (), ()
    from ..tasks.object_collision import link_penetrations, pad_penetrations

    T = np.asarray(T_palm_object, dtype=float)
    points = (hand_points_palm - T[:3, 3]) @ T[:3, :3]  # palm -> object frame, (C, 3)
    depth, pads = link_penetrations(task, pose, T, points), pad_penetrations(task, pose, T, points)
    n, m = len(depth), len(pads)
    return (("object_collision",) * n + ("pad_collision",) * m, tuple(depth) + tuple(pads),
            [float(v) for v in depth.values()] + [float(v) for v in pads.values()], ("mm",) * (n + m),
            (float(tol.object_penetration_mm),) * (n + m))  # fmt: skip
