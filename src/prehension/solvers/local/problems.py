"""Problems for the local solver: lists of tasks, and a compact form for point contacts.

:class:`PointProblems` is the compact batch form of the paper's problems (sec. 4.2): one
hand, the same hand regions for every problem (e.g. the four SA fingertips), and per
problem one object point with its outward normal per contact, in the object's frame.
It holds thousands of problems in three arrays; :meth:`PointProblems.task` turns one into
an ordinary :class:`~prehension.tasks.model.Task` (object regions =
:class:`~prehension.geometry.regions.PointRegion`).

:func:`random_point_problems` makes feasible ones by forward kinematics, as the paper's
Monte-Carlo study and Fig. 9 need: random joint angles within the limits (couplings
exact), random contact parameters within each fingertip cap, rejected when the hand
collides with itself (the foundation's capsules), then every contact point and normal
expressed in a random object frame.  The true configuration is kept in ``truth``.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Mapping

import numpy as np

from ...deadline import check_deadline
from ...errors import InvalidTask, SamplingError
from ...frozen import cached_per_value
from ...geometry.regions import PointRegion
from ...hands.collision import max_penetration
from ...hands.kinematics import forward_kinematics
from ...hands.model import Hand
from ...objects.model import GraspObject
from ...tasks.model import Contact, Task
from . import _regions as RG
from ._layout import ContactRegions, Group, build_group, hand_arrays
from ._penetration import NO_OBJECT, ObjectArrays
from ._sd_grid import sd_grid_of

__all__ = ["PointProblems", "random_point_problems", "SA_FOUR_TIPS", "group_from_tasks", "structure_key"]

SA_FOUR_TIPS = ("thumb_tip", "index_tip", "middle_tip", "ring_tip")


@dataclass(frozen=True, eq=False)
class PointProblems:
    """Many point-contact problems of one hand (object frame, mm).

    Attributes:
        hand: the hand.
        hand_regions: hand region name of each contact, shape (C,).
        points: (P, C, 3) object contact points.
        normals: (P, C, 3) outward unit normals of the object at those points.
        truth: optional known solutions: ``q (P, n_dof)``, ``T_palm_object (P, 4, 4)``,
            ``hand_params (P, C, k)``.
    """

    hand: Hand
    hand_regions: tuple[str, ...]
    points: np.ndarray
    normals: np.ndarray
    truth: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "hand_regions", tuple(self.hand_regions))
        p = np.asarray(self.points, dtype=float)
        n = np.asarray(self.normals, dtype=float)
        C = len(self.hand_regions)
        if p.ndim != 3 or p.shape[1:] != (C, 3) or n.shape != p.shape:
            raise InvalidTask(
                f"point problems need points and normals of shape (P, {C}, 3) for {C} hand regions; "
                f"got {p.shape} and {n.shape}"
            )
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
            raise InvalidTask("point problems: points and normals must be finite")
        norm = np.linalg.norm(n, axis=-1, keepdims=True)
        if np.any(norm < 1e-12):
            raise InvalidTask("point problems: every normal must be non-zero")
        for name in self.hand_regions:
            self.hand.region(name)
        object.__setattr__(self, "points", p)
        unit = np.abs(norm - 1.0) <= 4e-16  # already unit: kept as given (subsets re-create problems)
        object.__setattr__(self, "normals", np.where(unit, n, n / norm))

    def __len__(self) -> int:
        return self.points.shape[0]

    @property
    def fingers(self) -> tuple[str, ...]:
        """Fingers that carry a contact (they take part), in hand order."""
        used = {self.hand.finger_of_link(self.hand.region(r).link) for r in self.hand_regions}
        return tuple(f.name for f in self.hand.fingers if f.name in used)

    def subset(self, index) -> "PointProblems":
        index = np.atleast_1d(np.asarray(index))
        truth = {k: np.asarray(v)[index] for k, v in self.truth.items()}
        return PointProblems(self.hand, self.hand_regions, self.points[index], self.normals[index], truth)

    def task(self, i: int, name: str | None = None) -> Task:
        """Problem ``i`` as a task (object regions are points with normals)."""
        regions = {f"p{c}": PointRegion(self.points[i, c], self.normals[i, c]) for c in range(len(self.hand_regions))}
        contacts = tuple(Contact(h, f"p{c}") for c, h in enumerate(self.hand_regions))
        return Task(name or f"point-problem-{i}", self.hand, GraspObject(f"points-{i}", regions), contacts, self.fingers)

    def group(self, joint_scale_mm: float = 40.0) -> Group:
        """The kernel's arrays for these problems."""
        hand, C, P = self.hand, len(self.hand_regions), len(self)
        hregs = [hand.region(r) for r in self.hand_regions]
        blocks = []
        for c, h in enumerate(hregs):
            data = RG.pack(h.region)
            blocks += [np.broadcast_to(data, (P, data.size)), self.points[:, c], self.normals[:, c]]
        piv = self.points.mean(axis=1)
        extent = np.max(np.linalg.norm(self.points - piv[:, None], axis=-1), axis=1, initial=0.0)
        pdata = np.concatenate(blocks + [piv, extent[:, None]], axis=1)
        first = [PointRegion(self.points[0, c], self.normals[0, c]) for c in range(C)] if P else []
        contacts = [ContactRegions(f"{name}->p{c}", h.link, h.region, first[c], 1.0)
                    for c, (name, h) in enumerate(zip(self.hand_regions, hregs))]  # fmt: skip
        return build_group(hand, _active_mask(hand, self.fingers), np.clip(0.0, hand.lower, hand.upper), contacts, pdata,
                           joint_scale_mm)  # fmt: skip


def _active_mask(hand: Hand, fingers) -> np.ndarray:
    return hand.active_dofs(fingers)  # as Task.active_mask: closed under couplings


SAMPLING_TRIAL = 10_000  # draws after which an acceptance rate below 1% ends a rejection sampler


def sampling_cap(n: int) -> int:
    """Candidates a rejection sampler draws at most for ``n`` accepted ones: 1000 + 100 n
    (an acceptance rate below about 1% is refused rather than waited for)."""
    return 1000 + 100 * int(n)


def _hopeless(drawn: int, accepted: int, cap: int) -> bool:
    """Whether a rejection sampler should stop: its cap is reached, or after
    :data:`SAMPLING_TRIAL` draws fewer than 1% of them were accepted."""
    return drawn >= cap or (drawn >= SAMPLING_TRIAL and 100 * accepted < drawn)


def random_params(region, rng, n: int, *, deadline: float | None = None) -> np.ndarray:
    """``n`` random parameter vectors inside a region's domain (caps: inside the cone),
    drawn by rejection from the parameter box: at most :func:`sampling_cap` draws and
    until ``deadline`` (:class:`~prehension.deadline.TimeLimitReached`).

    Raises:
        SamplingError: the domain takes too few of the box's draws (a degenerate region).
    """
    k = region.n_params
    if k == 0:
        return np.zeros((n, 0))
    lo, hi, boxed, _ = RG.unknown_box(region)
    if boxed:  # the box is the domain (patches): nothing to reject
        return rng.uniform(lo, hi, (n, k))
    lo, hi = region.param_bounds()
    out, drawn = np.empty((0, k)), 0
    while out.shape[0] < n:
        if _hopeless(drawn, out.shape[0], sampling_cap(n)):
            raise SamplingError(
                f"{type(region).__name__} region: only {out.shape[0]} of {drawn} random parameter vectors in its box "
                f"{np.round(lo, 4).tolist()}..{np.round(hi, 4).tolist()} lie in its domain ({n} wanted); is the region degenerate?"
            )
        check_deadline(deadline, f"drawing {n} random parameters of a {type(region).__name__} region")
        cand = rng.uniform(lo, hi, (2 * n + 8, k))
        drawn += cand.shape[0]
        ok = region.domain_violation(cand) == 0.0
        out = np.concatenate([out, cand[ok]])
    return out[:n]


def random_rotations(rng, n: int) -> np.ndarray:
    """``n`` uniformly random rotations (unit quaternions), (n, 3, 3)."""
    qv = rng.normal(size=(n, 4))
    qv /= np.linalg.norm(qv, axis=1, keepdims=True)
    w, x, y, z = qv.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def random_hand_configurations(
    hand: Hand, fingers, n: int, rng, collision_free: bool = True, *, deadline: float | None = None,
    max_draws: int | None = None, fill: bool = False,
) -> np.ndarray:
    """``n`` random joint-angle vectors (n, n_dof): moving angles uniform within their limits,
    coupled angles following their source exactly (rejected when that leaves their limits),
    the others at zero clamped into the limits; without self-collision if asked.

    Bounded: at most ``max_draws`` candidates (default :func:`sampling_cap`; fewer when
    under 1% of the first :data:`SAMPLING_TRIAL` or more are accepted) and until
    ``deadline`` (a :func:`time.perf_counter` instant; :class:`~prehension.deadline.TimeLimitReached`).
    With ``fill``, the vectors still missing when the cap is reached are taken from the
    draws that only self-collide (initial poses of the local solver need not be free of
    self-collision: every answer is re-verified); without it, or when the limits and
    couplings themselves reject the draws, that is a :class:`SamplingError`.
    """
    active = _active_mask(hand, fingers)
    idle = np.clip(0.0, hand.lower, hand.upper)
    coupled = {hand.dof_index(c.dof): c for c in hand.couplings}
    cap = sampling_cap(n) if max_draws is None else int(max_draws)
    out, colliding = np.empty((0, hand.n_dof)), np.empty((0, hand.n_dof))
    drawn = in_limits = 0
    while out.shape[0] < n:
        if _hopeless(drawn, out.shape[0], cap):
            if fill and out.shape[0] + colliding.shape[0] >= n:
                return np.concatenate([out, colliding[: n - out.shape[0]]])
            raise _sampling_error(hand, fingers, n, out.shape[0], drawn, in_limits, collision_free)
        check_deadline(deadline, f"drawing {n} random joint vectors of hand {hand.name!r}")
        m = min(max(64, 2 * (n - out.shape[0])), cap - drawn)
        q = rng.uniform(hand.lower, hand.upper, (m, hand.n_dof))
        drawn += m
        for _ in range(len(coupled) + 1):  # settle chains of couplings
            for d, c in coupled.items():
                q[:, d] = c.ratio * q[:, hand.dof_index(c.source)] + c.offset
        q = np.where(active, q, idle)
        ok = np.all((q >= hand.lower) & (q <= hand.upper), axis=1)
        q = q[ok]
        in_limits += len(q)
        if collision_free and len(q):
            free = max_penetration(hand, forward_kinematics(hand, q), stop_at_first=True) <= 0.0
            if fill and colliding.shape[0] < n:
                colliding = np.concatenate([colliding, q[~free][: n - colliding.shape[0]]])
            q = q[free]
        out = np.concatenate([out, q])
    return out[:n]


def _sampling_error(hand: Hand, fingers, n: int, found: int, drawn: int, in_limits: int, collision_free: bool):
    fingers = ", ".join(fingers) or "none"
    why = (f"{in_limits} kept their joint limits through the couplings and "
           f"{found} of those were free of self-collision" if collision_free else f"{in_limits} kept their joint limits through the couplings")  # fmt: skip
    return SamplingError(
        f"hand {hand.name!r}: cannot draw {n} random joint vectors (fingers {fingers}"
        f"{', free of self-collision' if collision_free else ''}): of {drawn} draws uniform within the limits, {why}; "
        "check the hand's limits, couplings and collision shapes (prehension show HAND)"
    )


def random_point_problems(
    n: int,
    hand: Hand | None = None,
    hand_regions=SA_FOUR_TIPS,
    seed=0,
    *,
    collision_free: bool = True,
    object_offset_mm: float = 100.0,
    rim_fraction: float | None = None,
    deadline: float | None = None,
) -> PointProblems:
    """``n`` feasible point-contact problems made by forward kinematics (seeded).

    Args:
        n: number of problems.
        hand: the hand (default: the SA hand).
        hand_regions: hand region of each contact (default: the four SA fingertips).
        seed: an int seed or a ``numpy.random.Generator``.
        collision_free: reject configurations in self-collision.
        object_offset_mm: the object frame is a random rotation and a translation of up to
            this much (each coordinate) away from the palm frame.
        rim_fraction: ``None``: cap parameters uniform in their box, kept inside the cone;
            a number: normals uniform over each cap's area (:func:`._regions.cone_params`), that
            share of them exactly on the rim.
        deadline: stop at this :func:`time.perf_counter` instant
            (:class:`~prehension.deadline.TimeLimitReached`).

    Raises:
        SamplingError: the hand almost never gives such configurations (e.g. free of
            self-collision): see :func:`random_hand_configurations`.
    """
    from ...hands.sa_hand import schunk_sa_hand

    hand = schunk_sa_hand() if hand is None else hand
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    hand_regions = tuple(hand_regions)
    hregs = [hand.region(r) for r in hand_regions]
    fingers = tuple(
        f.name for f in hand.fingers if f.name in {hand.finger_of_link(h.link) for h in hregs}
    )
    q = random_hand_configurations(hand, fingers, n, rng, collision_free, deadline=deadline)
    pose = forward_kinematics(hand, q)
    params = [_contact_params(h.region, rng, n, rim_fraction, deadline) for h in hregs]
    R = random_rotations(rng, n)
    t = rng.uniform(-object_offset_mm, object_offset_mm, (n, 3))
    T = np.zeros((n, 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = t
    T[:, 3, 3] = 1.0
    pts, nrm = _object_contacts(hand, hregs, params, pose, R, t)
    k = max((h.region.n_params for h in hregs), default=0)
    hp = np.zeros((n, len(hregs), k))
    for c, prm in enumerate(params):
        hp[:, c, : prm.shape[1]] = prm
    return PointProblems(hand, hand_regions, pts, nrm, {"q": q, "T_palm_object": T, "hand_params": hp})


def _contact_params(region, rng, n: int, rim_fraction: float | None, deadline: float | None) -> np.ndarray:
    """A hand region's random parameters for :func:`random_point_problems`: with
    ``rim_fraction``, normals uniform over its cone (:func:`._regions.cone_params`) when it
    has one; else :func:`random_params`."""
    cone = RG.cone_params(region, rng, n, rim_fraction) if rim_fraction is not None else None
    return cone if cone is not None else random_params(region, rng, n, deadline=deadline)


def _object_contacts(hand: Hand, hregs, params, pose, R, t) -> tuple[np.ndarray, np.ndarray]:
    """The contact points and outward object normals (P, C, 3) in the object frames ``(R, t)``
    (palm -> object) of the hand regions ``hregs`` at ``params`` in the hand ``pose``."""
    n = R.shape[0]
    pts, nrm = [], []
    for h, prm in zip(hregs, params):
        p_link, n_link = h.region.evaluate(prm) if h.region.n_params else h.region.evaluate(np.zeros((n, 0)))
        li = hand.link_index(h.link)
        p = pose.points(li, p_link)
        nn = pose.directions(li, n_link)
        pts.append(np.einsum("bji,bj->bi", R, p - t))  # R^T (p - t)
        nrm.append(-np.einsum("bji,bj->bi", R, nn))
    return np.stack(pts, axis=1), np.stack(nrm, axis=1)


# -- tasks ------------------------------------------------------------------------------
_TEMPLATES: "OrderedDict[tuple, Group]" = OrderedDict()  # structure key -> a group of that structure
_TEMPLATES_KEPT = 32


@cached_per_value
def structure_key(task: Task) -> tuple:
    """Tasks with equal keys share one group: same hand (kinematics, capsules, and name: its
    shipped sequence), moving angles, per contact the region kinds and everything the
    layout takes from a group's first task -- the regions' sizes (the scales of their
    parameters) and their parameters' boxes --, and the same colliding solid (or none), so
    that a task's answer does not depend on the other tasks of its batch; see
    :mod:`._layout`.  Computed once per task object."""
    per_contact = []
    for c in task.contacts:
        h = task.hand_region(c)
        (hcode, hsize, hbox), (ocode, osize, obox) = _region_key(h.region), _region_key(task.object_region(c))
        per_contact.append((h.link, hcode, ocode, hsize, osize, (hbox, obox)))
    solid = id(task.object.distance) if task.object.collides else None  # the task holds it: the id stays its own
    return (hand_arrays(task.hand)[1], task.hand.name, tuple(task.fingers), task.active_mask.tobytes(),
            task.idle_vector.tobytes(), tuple(per_contact), solid)  # fmt: skip


@cached_per_value
def _region_key(region) -> tuple:
    """What :func:`structure_key` takes from one region: its kind and degrees, its size and
    its parameters' box (as bytes); once per region object (a hand's regions serve every
    task of the hand)."""
    return RG.code(region)[:3], RG.size(region), np.concatenate(RG.unknown_box(region)[:2]).tobytes()


def _task_row(task: Task) -> np.ndarray:
    """One task's row of region data, then its pivot and object extent [mm]."""
    blocks, refs = [], []
    for c in task.contacts:
        oreg = task.object_region(c)
        blocks += [RG.pack(task.hand_region(c).region), RG.pack(oreg)]
        refs.append(RG.reference_point(oreg))
    refs = np.array(refs)
    piv = np.add.reduce(refs, axis=0) / len(refs)  # refs.mean(axis=0): the same sum and division
    gap = refs - piv
    return np.concatenate(blocks + [piv, [np.sqrt(np.add.reduce(gap * gap, axis=1)).max()]])  # max |refs - piv|


def object_arrays(task: Task) -> ObjectArrays:
    """The kernel's view of the task's solid (:class:`._penetration.ObjectArrays`): the
    capsules of the links that move with the task are checked (idle fingers are cleared by
    :func:`~prehension.tasks.idle.settle_idle_fingers`), what lies inside each contact's
    pad excused and each pad checked as :mod:`prehension.tasks.object_collision` does (the
    pads' radii: a cap's, 0 for a point or patch); inactive when the object does not collide."""
    from ...hands.collision import collision_pairs
    from ...tasks.object_collision import SAMPLE_MM, moving_links, pad_radius

    if not task.object.collides:
        return NO_OBJECT
    checked = np.isin(collision_pairs(task.hand).link, moving_links(task))
    pads = np.array([pad_radius(task.hand_region(c)) for c in task.contacts], dtype=float)
    distance = task.object.distance
    return ObjectArrays(distance.arrays, True, checked.astype(np.bool_), pads, float(SAMPLE_MM), sd_grid_of(distance))


def group_from_tasks(tasks, joint_scale_mm: float = 40.0) -> Group:
    """The kernel's arrays for tasks that share one structure (see :func:`structure_key`).

    The layout of a structure is built once and kept (the last few structures, with the
    hand object they were built for); only the tasks' data rows and the object's solid
    (:func:`object_arrays`) are new.
    """
    tasks = list(tasks)
    first = tasks[0]
    key = structure_key(first)
    if any(t is not first and structure_key(t) != key for t in tasks):
        raise InvalidTask("group_from_tasks: the tasks do not share one hand and one structure")
    rows = np.array([_task_row(t) for t in tasks])
    # what else the layout takes from the first task: object region sizes and boxes
    oregs = [first.object_region(c) for c in first.contacts]
    shape = (key, joint_scale_mm, tuple(RG.size(r) for r in oregs), tuple(tuple(RG.unknown_box(r)[1]) for r in oregs))
    template = _TEMPLATES.get(shape)
    if template is not None and template.hand is first.hand:
        _TEMPLATES.move_to_end(shape)
        return replace(template, pdata=np.ascontiguousarray(rows, dtype=float), obj=object_arrays(first))  # with_data
    contacts = [ContactRegions(c.name, first.hand_region(c).link, first.hand_region(c).region, first.object_region(c),
                               RG.size(first.object_region(c))) for c in first.contacts]  # fmt: skip
    group = build_group(first.hand, first.active_mask, first.idle_vector, contacts, rows, joint_scale_mm)
    _TEMPLATES[shape] = group
    while len(_TEMPLATES) > _TEMPLATES_KEPT:
        _TEMPLATES.popitem(last=False)
    return replace(group, obj=object_arrays(first))
