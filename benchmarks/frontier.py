"""The complete solver at the reach frontier (issue 15): how close to t* it decides a task.

A *family* is a task with one object region moved by ``t`` mm along a fixed direction:
the built-in two-contact tasks with the thumb's region moved away from the other region
(along the line joining their centres), and two-fingertip pinches of two points (thumb
and index of the SA hand, and of the Allegro hand's URDF from ../shared/hands).  For each family the
script

1. finds the frontier ``t*`` independently of the complete solver: local solutions of the
   task at ``t = 0`` (local solver, several seeds) are the starts of SLSQP runs that
   *maximise t* subject to the contact equations, the joint limits, the couplings and the
   regions' domains; the largest ``t`` is then polished into a strict solution of the
   task at ``t*`` (so ``t*`` is feasible, verified by the residual function); while the
   complete solver's first box (its verification alone, no pair test) finds a strict
   solution ``PROBE_MM`` (0.5 mm) past ``t*``, the maximisation restarts from that
   solution (at most ``PROBE_ROUNDS`` times): ``t*`` is only ever raised, by strict
   solutions, so a run past it that is *solved* shows a maximisation stopped short, never
   a certificate;
2. runs the complete solver (depth first, sigma 0.1, one process) on the tasks at
   ``t* + delta`` for ``delta`` in -1, -0.5, +0.5, +1, +2, +4 mm and prints status, boxes,
   LPs, time and closest miss.

``t*`` is a local maximum: a task at ``t* + delta`` may still be feasible if the true
frontier lies further (the solver would then find a solution, never a certificate).
Self-collision is not part of the maximisation (as it is not part of the complete
solver's system); the table says whether the configuration at ``t*`` collides.

    python benchmarks/frontier.py                       # every family, 300 s per run (hours)
    python benchmarks/frontier.py --quick               # lid, scalpel, sa-pinch at -0.5, +2, +4 mm, 30 s caps
    python benchmarks/frontier.py --families lid sa-pinch --time-limit 60
    python benchmarks/frontier.py --frontier-only       # only t* of every family
    python benchmarks/frontier.py --families lid tuning --offsets 1 2 --max-boxes 40   # a box budget, no time cap
    python benchmarks/frontier.py --families lid --offsets 1.5 2 --pair-test 200000   # the pair test alone

**Random families (issue 32)**: ``--random K --seed S`` draws K families instead of the named
ones -- a task of the CuikSuite world files (../shared/cuik-ijrr, read at run time), a
built-in task, or two fingertips (SA hand, or the Allegro URDF's caps) on planar patches
picked on opposed faces of a ../shared/objects mesh; one object region (any contact) first
scaled (x0.6-1.4) or turned (up to 30 deg) about its centre, or left as it is, then moved
along a random direction leading away from the other regions (``u . e >= 0.3``).  Family
``i`` of seed ``S`` comes from its own generator, so ``--families 0,3`` draws the same tasks
as the whole run; a draw whose ``t*`` configuration collides with the hand itself, or
without a strict solution at ``t* - 0.05 mm``, is drawn again.  Offsets -0.5, +0.5, +1, +2,
+4 mm; each frontier and run is appended to ``--out`` (JSONL) as it ends and not repeated
when the file already holds it (same tag: the git commit by default), so a long run can be
split and resumed; ``--report`` prints the distribution of the file alone.  ``--anatomy``
also finds, once per family, the frontiers of its sub-tasks (the moved contact with each
subset of the others, the same maximisation): the fewest contacts whose sub-task's frontier
lies within 0.5 mm of ``t*`` *make* it.  Only a frontier made by two contacts can be proved
by the pose-free pair test; the report counts the certified runs of both kinds.

    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl                 # 300 s per run
    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl --families 0,1 --offsets 1 2 --time-limit 60
    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl --report        # the distribution so far
    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl --anatomy --frontier-only   # sub-task frontiers
    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl --families 0 --offsets 1 --time-limit 60 \
        --shrink feasibility_first=true lp_order=narrowest stop_after=10 --tag cheap     # other ShrinkOptions
    python benchmarks/frontier.py --random 20 --seed 1 --out s1.jsonl --families 0 --offsets 1 --time-limit 60 \
        --shrink quaternions=palm angles=true branch_width=0.1 --tag qa   # split the palm's quaternion, then the angles

Each run also records the share of the search tree still open when it stopped
(``stats["open_share"]``, ``sum 2^-depth`` over the open boxes; 0 once decided): the
progress of an undecided run, to compare solver variants in minutes rather than hours.

One process, BLAS and numba pinned to one thread (the targets of issue 15 are on one core).
At the end a Markdown table of every run is printed (for benchmarks/README.md).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from itertools import combinations  # noqa: E402
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from prehension.errors import PrehensionError
from prehension.geometry.regions import BezierRegion, PointRegion, SphereCap
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.model import Hand, HandRegion
from prehension.objects.model import GraspObject
from prehension.results import Status, make_solution
from prehension.solvers.complete.pair import congruence_test
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.solvers.complete.shrink import ShrinkOptions
from prehension.solvers.local.verifier import LocalVerifier
from prehension.solvers.local import LocalOptions, solve_local
from prehension.solvers.local.solver import refine_local
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Configuration, Contact, Task
from prehension.verification.residuals import Tolerances, contact_residuals, evaluate

HANDS = Path(__file__).resolve().parents[2] / "shared" / "hands"
OFFSETS_MM = (-1.0, -0.5, 0.5, 1.0, 2.0, 4.0)
QUICK = {"families": ["lid", "scalpel", "sa-pinch"], "offsets": [-0.5, 2.0, 4.0], "time_limit": 30.0}
NO_COLLISIONS = Tolerances(penetration_mm=float("inf"))


@dataclass(frozen=True)
class Family:
    """``base`` with the object region of contact ``moved`` translated by ``t u`` (object frame)."""

    name: str
    base: Task
    moved: int
    u: np.ndarray  # (3,) unit direction in the object frame

    def task_at(self, t: float) -> Task:
        contact = self.base.contacts[self.moved]
        region = self.base.object_region(contact)
        shift = float(t) * self.u
        if isinstance(region, BezierRegion):
            new = BezierRegion(region.patch.transformed(np.eye(3), shift))
        elif isinstance(region, PointRegion):
            new = PointRegion(region.point + shift, region.normal)
        else:
            new = SphereCap(region.center + shift, region.radius, region.axis, region.half_angle)
        regions = dict(self.base.object.regions)
        regions[contact.object_region] = new
        obj = replace(self.base.object, regions=regions, solid=None)  # the moved region is off its surface
        return replace(self.base, name=f"{self.name} {t:+.3f} mm", object=obj)


# -- families -------------------------------------------------------------------------------
def _region_centre(region) -> np.ndarray:
    if isinstance(region, BezierRegion):
        return region.patch.control_points.reshape(-1, 3).mean(axis=0)
    return np.asarray(region.point if isinstance(region, PointRegion) else region.center, dtype=float)


def builtin_family(name: str, task_name: str) -> Family:
    """A two-contact built-in task with the thumb's object region moved away from the other."""
    task = load_builtin_task(task_name)
    moved = next(i for i, c in enumerate(task.contacts) if c.hand_region.startswith("thumb"))
    other = 1 - moved
    a = _region_centre(task.object_region(task.contacts[moved]))
    b = _region_centre(task.object_region(task.contacts[other]))
    return Family(name, task, moved, (a - b) / np.linalg.norm(a - b))


def pinch_family(name: str, hand: Hand, thumb: str, finger: str, fingers: tuple[str, ...], width_mm: float) -> Family:
    """Two points ``width_mm`` apart along x, normals pointing out (-x, +x), pinched by the
    regions ``thumb`` and ``finger``; the second point moves along +x."""
    obj = GraspObject("two-points", {"a": PointRegion((0, 0, 0), (-1, 0, 0)), "b": PointRegion((width_mm, 0, 0), (1, 0, 0))})
    task = Task(name, hand, obj, (Contact(thumb, "a"), Contact(finger, "b")), _coupled_closure(hand, fingers))
    return Family(name, task, 1, np.array([1.0, 0.0, 0.0]))


def fingertip_caps(hand: Hand, half_angle_deg: float = 80.0) -> dict[str, HandRegion]:
    """A sphere cap on every finger's last link, a benchmark stand-in for fitted fingertips:
    the collision capsule end farthest from the link's joint is the centre, that capsule's
    radius the radius, and the cap faces the flexion side (the direction the tip moves when
    the last joint turns towards the larger of its limits)."""
    regions = {}
    for finger in hand.fingers:
        link = finger.links[-1]
        joint = hand.joint_of_link(link)
        ends = [(p, c.radius) for c in hand.links[hand.link_index(link)].collision for p in (c.a, c.b)]
        centre, radius = max(ends, key=lambda e: np.linalg.norm(e[0] - joint.origin_in_child))
        axis = joint.R_parent_child_zero.T @ joint.axis_in_parent
        pad = np.cross(axis, centre - joint.origin_in_child)
        dof = hand.dof_index(joint.dof_names[-1])
        if abs(hand.lower[dof]) > abs(hand.upper[dof]):
            pad = -pad
        cap = SphereCap(np.asarray(centre, dtype=float), float(radius), pad / np.linalg.norm(pad), np.radians(half_angle_deg))
        regions[f"{finger.name}_cap"] = HandRegion(link, cap)
    return regions


def _coupled_closure(hand: Hand, fingers: tuple[str, ...]) -> tuple[str, ...]:
    """``fingers`` and every finger whose dofs are coupled to theirs (a task needs both sides)."""
    owner = {d: f.name for f in hand.fingers for link in f.links for d in hand.chain_dofs(link)}
    out = list(fingers)
    changed = True
    while changed:
        changed = False
        for c in hand.couplings:
            ends = {owner.get(hand.dof_index(c.dof)), owner.get(hand.dof_index(c.source))} - {None}
            if ends & set(out) and not ends <= set(out):
                out += sorted(ends - set(out))
                changed = True
    return tuple(out)


def urdf_pinch_family() -> Family:
    """Thumb and index fingertip caps of the Allegro hand (URDF) pinching two points.  (The
    SVH hand of ../shared/hands is left out: finding its t* did not end in 15 minutes.)"""
    from prehension.hands.urdf import hand_from_urdf

    hand = hand_from_urdf(HANDS / "allegro_hand" / "allegro_hand_right.urdf")
    hand = hand.with_regions(fingertip_caps(hand))
    return pinch_family("allegro-pinch", hand, "thumb_cap", "index_cap", ("thumb", "index"), 40.0)


# -- random families (issue 32) ----------------------------------------------------------
CUIK = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr"
OBJECTS = Path(__file__).resolve().parents[2] / "shared" / "objects"
MESHES = (("bunny.obj", 100.0),) + tuple((f"random/{i:03d}.obj", 10.0) for i in range(5))
SOURCES = ("world", "builtin", "mesh")
GRIP_MM = (25.0, 95.0)  # widths of opposed faces a mesh family's pinch is drawn across
TURN_DEG = 30.0  # largest turn of the moved region's variant
SCALE = (0.6, 1.4)  # range of the moved region's scale factor


def _unit_vector(rng) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _transformed_region(region, M: np.ndarray, centre: np.ndarray):
    """``region`` mapped by ``x -> centre + M (x - centre)``, ``M`` a rotation times a
    positive scale (normals turn with the rotation; a point's and a cap's too)."""
    shift = centre - M @ centre
    if isinstance(region, BezierRegion):
        return BezierRegion(region.patch.transformed(M, shift))
    turn = M / np.cbrt(np.linalg.det(M))
    if isinstance(region, PointRegion):
        return PointRegion(M @ region.point + shift, turn @ region.normal)
    return SphereCap(M @ region.center + shift, region.radius * np.cbrt(np.linalg.det(M)), turn @ region.axis,
                     region.half_angle)  # fmt: skip


def _random_family(name: str, task: Task, moved: int, rng) -> tuple[Family, str]:
    """``task`` with the object region of contact ``moved`` first scaled or turned (a third
    of the draws each; the rest as it is) about its centre, then moved along a random
    direction ``u`` that leads away from the other regions (``u . e >= 0.3``, ``e`` the unit
    vector from the other regions' mean centre to this one's): not only the centre line."""
    contact = task.contacts[moved]
    region = task.object_region(contact)
    centre = _region_centre(region)
    others = np.mean([_region_centre(task.object_region(c)) for i, c in enumerate(task.contacts) if i != moved], axis=0)
    e = (centre - others) / np.linalg.norm(centre - others)
    kind = rng.integers(3)
    if kind == 0:
        factor = float(rng.uniform(*SCALE))
        M, what = factor * np.eye(3), f"scaled x{factor:.2f}"
    elif kind == 1:
        angle = float(rng.uniform(-TURN_DEG, TURN_DEG))
        M, what = Rotation.from_rotvec(np.radians(angle) * _unit_vector(rng)).as_matrix(), f"turned {angle:+.0f} deg"
    else:
        M, what = np.eye(3), "as is"
    regions = dict(task.object.regions)
    regions[contact.object_region] = _transformed_region(region, M, centre)
    base = replace(task, object=replace(task.object, regions=regions, solid=None))
    while True:
        u = _unit_vector(rng)
        if u @ e >= 0.3:
            break
    described = f"{contact.object_region} ({contact.hand_region}) {what}, moved along ({u[0]:+.2f}, {u[1]:+.2f}, {u[2]:+.2f})"
    return Family(name, base, moved, u), described


def _world_task(rng) -> Task:
    from prehension.tasks.cuik_import import import_world

    paths = sorted(CUIK.glob("*/*/*.world"))
    return import_world(paths[rng.integers(len(paths))])


def _builtin_task(rng) -> Task:
    from prehension.tasks.library import builtin_task_names

    names = builtin_task_names()
    return load_builtin_task(names[rng.integers(len(names))])


def _mesh_task(rng) -> Task:
    """Two fingertips (the thumb's and another finger's, of the SA hand or the Allegro
    URDF's caps) on planar patches picked on opposed faces of a shared mesh, 25-95 mm apart
    across the object (``region_from_mesh``, degree 1, inside one face)."""
    from prehension.objects.distance import MeshDistance
    from prehension.objects.mesh_io import load_mesh
    from prehension.objects.pick import region_from_mesh

    file, scale = MESHES[rng.integers(len(MESHES))]
    mesh = load_mesh(OBJECTS / file, scale)
    distance = MeshDistance(mesh.vertices, mesh.faces)
    tri = mesh.vertices[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / (2.0 * area[:, None])
    side = [np.linalg.norm(tri[:, (i + 1) % 3] - tri[:, (i + 2) % 3], axis=1) for i in range(3)]
    incentre = sum(side[i][:, None] * tri[:, i] for i in range(3)) / sum(side)[:, None]
    inradius = 2.0 * area / sum(side)
    outer = (distance.signed_distance(incentre + 1.5 * normal) > 0) & (distance.signed_distance(incentre - 0.3 * normal) < 0)
    big = np.flatnonzero((inradius >= 1.5) & outer)
    pairs = [(i, j) for i in big for j in big
             if normal[i] @ normal[j] < -0.7 and GRIP_MM[0] <= np.linalg.norm(incentre[j] - incentre[i]) <= GRIP_MM[1]
             and -normal[i] @ (incentre[j] - incentre[i]) / np.linalg.norm(incentre[j] - incentre[i]) > 0.6]  # fmt: skip
    if not pairs:
        raise RuntimeError(f"no opposed faces on {file}")
    i, j = pairs[rng.integers(len(pairs))]
    patch = lambda f: region_from_mesh(mesh, at=incentre[f], radius=min(0.8 * inradius[f], 6.0), degree=1,  # noqa: E731
                                       distance=distance).region  # fmt: skip
    if rng.integers(2) == 0:
        hand, thumb, finger = load_builtin_task("guitar-tuning").hand, "thumb_tip", ("index", "middle", "ring")[rng.integers(3)]
        region = f"{finger}_tip"
    else:
        from prehension.hands.urdf import hand_from_urdf

        hand = hand_from_urdf(HANDS / "allegro_hand" / "allegro_hand_right.urdf")
        hand = hand.with_regions(fingertip_caps(hand))
        fingers = [f.name for f in hand.fingers if f.name != "thumb"]
        thumb, finger = "thumb_cap", fingers[rng.integers(len(fingers))]
        region = f"{finger}_cap"
    obj = GraspObject(Path(file).stem, {"thumb_side": patch(i), "finger_side": patch(j)})
    contacts = (Contact(thumb, "thumb_side"), Contact(region, "finger_side"))
    return Task(f"{Path(file).stem}-{finger}", hand, obj, contacts, _coupled_closure(hand, ("thumb", finger)))


@dataclass(frozen=True)
class RandomFamily:
    """Family ``index`` of the draw ``seed`` (its ``attempt``), what it is, and its frontier."""

    seed: int
    index: int
    attempt: int
    family: Family
    described: str
    frontier: Frontier
    refused: tuple[str, ...] = ()  # why earlier attempts were drawn again


def _draw(seed: int, index: int, attempt: int) -> tuple[Family, str]:
    """Attempt ``attempt`` at family ``index`` of the draw ``seed`` (cheap, deterministic:
    its own generator ``default_rng([seed, index, attempt])``): the family and what it is."""
    rng = np.random.default_rng([seed, index, attempt])
    source = SOURCES[rng.integers(len(SOURCES))]
    task = {"world": _world_task, "builtin": _builtin_task, "mesh": _mesh_task}[source](rng)
    moved = int(rng.integers(len(task.contacts)))
    family, described = _random_family(f"s{seed}-{index}", task, moved, rng)
    return family, f"{source} {task.name} ({len(task.contacts)} contacts): {described}"


def draw_family(seed: int, index: int, *, attempts: int = 12, seeds: int = 3) -> RandomFamily:
    """Family ``index`` of the seeded draw ``seed`` with its frontier ``t*`` (see
    :func:`_random_family`), any one of them drawable alone (:func:`_draw`).  A draw is
    taken again (next attempt) when it has no frontier this script can vouch for with a
    strict solution: the local solver does not solve it at ``t = 0``, it is still solved
    480 mm out, the configuration at ``t*`` collides with the hand itself (a task just
    inside might then be infeasible for that reason, and "solved below ``t*``" could not be
    asked of the solver), or there is no strict solution at ``t* - 0.05 mm``."""
    failures = []
    for attempt in range(attempts):
        try:
            family, described = _draw(seed, index, attempt)
            frontier = find_frontier(family, seeds=seeds)
        except (RuntimeError, PrehensionError, np.linalg.LinAlgError, ValueError) as exc:
            failures.append(f"attempt {attempt}: {exc}")
            continue
        if frontier.collides:
            failures.append(f"attempt {attempt}: the configuration at t* = {frontier.t_mm:.1f} mm collides")
            continue
        inside = solution_at(family, frontier.configuration, frontier.t_mm, frontier.t_mm - 0.05)
        if inside is None or make_solution(family.task_at(frontier.t_mm - 0.05), inside) is None:
            failures.append(f"attempt {attempt}: no strict solution at t* - 0.05 mm")
            continue
        return RandomFamily(seed, index, attempt, family, described, frontier, tuple(failures))
    raise RuntimeError(f"family {index} of seed {seed}: no usable draw in {attempts} attempts ({'; '.join(failures)})")


def families(names: list[str] | None = None) -> list[Family]:
    from prehension.hands.sa_hand import schunk_sa_hand

    makers = {
        "lid": lambda: builtin_family("lid", "teapot-lid-lifting"),
        "scalpel": lambda: builtin_family("scalpel", "scalpel-upholding"),
        "tuning": lambda: builtin_family("tuning", "guitar-tuning"),
        "sa-pinch": lambda: pinch_family("sa-pinch", schunk_sa_hand(), "thumb_tip", "index_tip", ("thumb", "index"), 40.0),
        "allegro-pinch": urdf_pinch_family,
    }
    return [makers[n]() for n in (names or list(makers))]


# -- the frontier by local maximisation of the offset ---------------------------------------
@dataclass(frozen=True)
class Frontier:
    t_mm: float  # the largest offset with a strict solution found
    configuration: Configuration  # that solution (of family.task_at(t_mm))
    starts: int
    collides: bool
    seconds: float
    raised: int = 0  # times a solution past the maximum restarted it (PROBE_MM)


class _Unknowns:
    """The vector SLSQP works on: free joint angles, object pose, contact parameters, t."""

    def __init__(self, family: Family):
        task, hand = family.base, family.base.hand
        self.family, self.task, self.hand = family, task, hand
        chain = sorted({d for c in task.contacts for d in hand.chain_dofs(task.hand_region(c).link)})
        self.dependent = {hand.dof_index(c.dof): c for c in hand.couplings if hand.dof_index(c.dof) in chain}
        self.free = [d for d in chain if d not in self.dependent or hand.dof_index(self.dependent[d].source) not in chain]
        for d in list(self.dependent):
            if d in self.free:
                del self.dependent[d]
        self.sizes = [(task.hand_region(c).region.param_bounds()[0].size, task.object_region(c).param_bounds()[0].size)
                      for c in task.contacts]  # fmt: skip
        self.n = len(self.free) + 6 + sum(a + b for a, b in self.sizes) + 1

    def pack(self, config: Configuration, t: float) -> np.ndarray:
        T = config.T_palm_object
        parts = [config.joint_angles[self.free], Rotation.from_matrix(T[:3, :3]).as_rotvec(), T[:3, 3]]
        for h, o in config.contact_params:
            parts += [np.asarray(h, dtype=float), np.asarray(o, dtype=float)]
        return np.concatenate(parts + [[t]])

    def unpack(self, z: np.ndarray) -> tuple[Configuration, float]:
        q, T, params, t = self._unpack_batch(np.asarray(z, dtype=float)[None])
        return Configuration(q[0], T[0], tuple((h[0], o[0]) for h, o in params)), float(t[0])

    def _unpack_batch(self, Z: np.ndarray):
        """``Z (B, n) -> q (B, n_dof), T_palm_object (B, 4, 4), params [(B, k_h), (B, k_o)], t (B,)``."""
        B, k = len(Z), len(self.free)
        q = np.repeat(self.task.idle_vector[None], B, axis=0)
        q[:, self.free] = Z[:, :k]
        for d, c in self.dependent.items():
            q[:, d] = c.ratio * q[:, self.hand.dof_index(c.source)] + c.offset
        T = np.repeat(np.eye(4)[None], B, axis=0)
        T[:, :3, :3], T[:, :3, 3] = Rotation.from_rotvec(Z[:, k:k + 3]).as_matrix(), Z[:, k + 3:k + 6]
        k += 6
        params = []
        for nh, no in self.sizes:
            params.append((Z[:, k:k + nh], Z[:, k + nh:k + nh + no]))
            k += nh + no
        return q, T, params, Z[:, -1]

    def bounds(self) -> list[tuple[float, float]]:
        hand = self.hand
        out = [(hand.lower[d], hand.upper[d]) for d in self.free] + [(None, None)] * 6
        for c in self.task.contacts:
            for region in (self.task.hand_region(c).region, self.task.object_region(c)):
                lo, hi = region.param_bounds()
                out += list(zip(lo, hi))
        return out + [(None, None)]

    def equations_batch(self, Z: np.ndarray) -> np.ndarray:
        """Contact equations ``(B, 6 C)``: hand point - object point, hand normal + object normal."""
        q, T, params, t = self._unpack_batch(Z)
        res = contact_residuals(self.task, forward_kinematics(self.hand, q), T, params)
        obj = res["object_point"].copy()
        obj[:, self.family.moved] += t[:, None] * (T[:, :3, :3] @ self.family.u)
        # the hand normal must be -n_object: its two components across n_object vanish (two
        # equations per contact, not three: SLSQP needs independent equality constraints)
        n_obj = res["object_normal"]
        e1 = np.cross(n_obj, self.references)
        e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
        e2 = np.cross(n_obj, e1)
        h = res["hand_normal"]
        across = np.stack([np.sum(h * e1, axis=-1), np.sum(h * e2, axis=-1)], axis=-1)
        return np.concatenate([(res["hand_point"] - obj).reshape(len(Z), -1), across.reshape(len(Z), -1)], axis=1)

    def set_references(self, z: np.ndarray) -> None:
        """Per contact, the frame axis least aligned with its object normal at ``z`` (palm
        frame): the reference of the two normal equations near ``z``."""
        q, T, params, _ = self._unpack_batch(z[None])
        res = contact_residuals(self.task, forward_kinematics(self.hand, q), T, params)
        n = res["object_normal"][0]
        self.references = np.eye(3)[np.argmin(np.abs(n), axis=1)]

    def inequalities_batch(self, Z: np.ndarray) -> np.ndarray:
        """``(B, m) >= 0``: coupled angles within their limits, cap normals inside their cones."""
        q, _, params, _ = self._unpack_batch(Z)
        out = []
        for d in self.dependent:
            out += [q[:, d] - self.hand.lower[d], self.hand.upper[d] - q[:, d]]
        for c, (h, o) in zip(self.task.contacts, params):
            for region, p in ((self.task.hand_region(c).region, h), (self.task.object_region(c), o)):
                if isinstance(region, SphereCap):
                    out.append(region.normals(p) @ region.axis - np.cos(region.half_angle))
        return np.stack(out, axis=1) if out else np.zeros((len(Z), 1))


def _with_jacobian(fun, step: float = 1e-7):
    """``(f(z), J(z))`` of a batch function, by forward differences in one batch call."""

    def value(z):
        return fun(z[None])[0]

    def jacobian(z):
        Z = np.vstack([z, z + step * np.eye(len(z))])
        F = fun(Z)
        return ((F[1:] - F[0]) / step).T

    return value, jacobian


#: Past a maximum, the task at ``t + PROBE_MM`` is given to the complete solver's first box
#: (its verification from points spread over the whole initial box, no LP counted on, no
#: pair test): a strict solution there restarts the maximisation from it, at most
#: ``PROBE_ROUNDS`` times.  s1-14 (mesh 002-ring) of ``--random 20 --seed 1`` was solved in
#: its first box at t* + 1 and + 2 mm: the local solver's starts had all led SLSQP to a
#: smaller local maximum.
PROBE_MM = 0.5
PROBE_ROUNDS = 6


def find_frontier(family: Family, seeds: int = 3, probe_rounds: int = PROBE_ROUNDS) -> Frontier:
    """``t*`` by SLSQP from local solutions near the frontier (see the module docstring),
    raised while the complete solver's first box finds a strict solution ``PROBE_MM`` past
    it (:func:`_probe_past`; ``probe_rounds`` times at most: the maximisation restarts from
    that solution).  Only ever raised by a strict solution, so ``t*`` stays feasible."""
    started = time.perf_counter()
    unknowns = _Unknowns(family)
    t0, starts = _scan(family, seeds)
    t, config = _best_maximum(family, unknowns, [(t0, c) for c in starts], (t0, starts[0]))
    collides = not evaluate(family.task_at(t), config).ok
    raised = 0
    while not collides and raised < probe_rounds and (past := _probe_past(family, t + PROBE_MM)) is not None:
        probed = (t + PROBE_MM, past)
        t, config = _best_maximum(family, unknowns, [probed], probed)
        if not evaluate(family.task_at(t), config).ok:  # the maximum collides: the probe's solution does not
            t, config = probed
        raised += 1
    return Frontier(t, config, len(starts), collides, time.perf_counter() - started, raised)


def _best_maximum(family: Family, unknowns: _Unknowns, starts: list[tuple[float, Configuration]],
                  best: tuple[float, Configuration]) -> tuple[float, Configuration]:  # fmt: skip
    """The largest polished maximum of SLSQP from each ``(t, solution at t)`` of ``starts``
    (``best`` when none is larger)."""
    for t, config in starts:
        found = _polish(family, unknowns, _maximise(unknowns, unknowns.pack(config, t)))
        if found is not None and found[0] > best[0]:
            best = found
    return best


def _probe_past(family: Family, t: float) -> Configuration | None:
    """A strict solution (self-collision included) of the task at ``t`` found by the complete
    solver's first box (its verifier from points spread over the initial box), or None."""
    task = family.task_at(t)
    result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=1, pair_test_boxes=0))
    if result.status != Status.SOLVED:
        return None
    config = result.solutions[0].configuration()
    return config if make_solution(task, config) is not None else None


def _local_solutions(family: Family, t: float, seeds: int) -> list[Configuration]:
    task = family.task_at(t)
    results = (solve_local(task, LocalOptions(initial="random"), seed=seed) for seed in range(seeds))
    return [r.solutions[0].configuration() for r in results if r.solutions]


def _scan(family: Family, seeds: int, step_mm: float = 16.0, resolution_mm: float = 0.5, max_mm: float = 480.0):
    """The largest offset (to ``resolution_mm``) at which the local solver solves the task,
    and its solutions there: steps of ``step_mm`` outwards, then bisection (a family still
    solved at ``max_mm`` is refused)."""
    lo, starts = 0.0, _local_solutions(family, 0.0, seeds)
    if not starts:
        raise RuntimeError(f"{family.name}: the local solver does not solve the task at t = 0")
    hi = step_mm
    while (found := _local_solutions(family, hi, seeds)):
        lo, starts, hi = hi, found, hi + step_mm
        if lo > max_mm:
            raise RuntimeError(f"{family.name}: still solved at t = {lo:g} mm")
    while hi - lo > resolution_mm:
        mid = 0.5 * (lo + hi)
        found = _local_solutions(family, mid, seeds)
        lo, hi, starts = (mid, hi, found) if found else (lo, mid, starts)
    return lo, starts


def _maximise(unknowns: _Unknowns, z0: np.ndarray) -> np.ndarray:
    unknowns.set_references(z0)
    eq, eq_jac = _with_jacobian(unknowns.equations_batch)
    ineq, ineq_jac = _with_jacobian(unknowns.inequalities_batch)
    cons = [{"type": "eq", "fun": eq, "jac": eq_jac}, {"type": "ineq", "fun": ineq, "jac": ineq_jac}]
    gradient = np.zeros(len(z0))
    gradient[-1] = -1.0
    out = minimize(lambda z: -z[-1], z0, jac=lambda z: gradient, bounds=unknowns.bounds(), constraints=cons,
                   method="SLSQP", options={"maxiter": 300, "ftol": 1e-12})  # fmt: skip
    return out.x


def solution_at(family: Family, config: Configuration, t_from: float, t: float) -> Configuration | None:
    """A strict solution (self-collision aside) of ``family.task_at(t)``, by SLSQP with the
    offset pinned to ``t`` from ``config``, a solution at ``t_from`` (None if none is found).
    A witness that the task at ``t`` is feasible, independent of the solvers under test."""
    unknowns = _Unknowns(family)
    z0 = unknowns.pack(config, t_from)
    z0[-1] = t
    unknowns.set_references(z0)
    eq, eq_jac = _with_jacobian(unknowns.equations_batch)
    ineq, ineq_jac = _with_jacobian(unknowns.inequalities_batch)
    cons = [{"type": "eq", "fun": eq, "jac": eq_jac}, {"type": "ineq", "fun": ineq, "jac": ineq_jac}]
    bounds = unknowns.bounds()[:-1] + [(t, t)]
    out = minimize(lambda z: 0.0, z0, jac=lambda z: np.zeros(len(z)), bounds=bounds, constraints=cons,
                   method="SLSQP", options={"maxiter": 40, "ftol": 1e-14})  # fmt: skip
    return _polish_exact(family, unknowns, out.x)


def _polish_exact(family: Family, unknowns: _Unknowns, z: np.ndarray) -> Configuration | None:
    """The SLSQP point with its angles clipped into the limits, if strict at its own ``t``."""
    config, (_, t) = _clipped(family, unknowns, z), unknowns.unpack(z)
    return config if make_solution(family.task_at(t), config, NO_COLLISIONS) is not None else None


def _clipped(family: Family, unknowns: _Unknowns, z: np.ndarray) -> Configuration:
    """The configuration of ``z`` with its angles clipped into the limits (couplings exact)."""
    config, _ = unknowns.unpack(z)
    hand = family.base.hand
    q = np.clip(config.joint_angles, hand.lower, hand.upper)
    for c in hand.couplings:
        q[hand.dof_index(c.dof)] = c.ratio * q[hand.dof_index(c.source)] + c.offset
    return Configuration(q, config.T_palm_object, config.contact_params)


def _polish(family: Family, unknowns: _Unknowns, z: np.ndarray) -> tuple[float, Configuration] | None:
    """A strict solution at (or just below) the ``t`` of ``z``: the SLSQP point itself, with
    its angles clipped into the limits, or local refinement from it a little further in."""
    exact = _polish_exact(family, unknowns, z)
    _, t = unknowns.unpack(z)
    if exact is not None:
        return t, exact
    config = _clipped(family, unknowns, z)
    for back in (1e-4, 1e-3, 1e-2, 0.05, 0.1):
        task = family.task_at(t - back)
        refined = refine_local(task, [config], LocalOptions(check_collisions=False))
        for c in refined.configurations:
            if c is not None and make_solution(task, c, NO_COLLISIONS) is not None:
                return t - back, c
    return None


# -- which contacts make the frontier --------------------------------------------------------
#: A sub-task whose frontier lies within this of ``t*`` [mm] makes the family's frontier.
MADE_BY_MM = 0.5


def sub_frontiers(family: Family, seeds: int = 1) -> dict[str, float]:
    """``t*`` of the family's sub-tasks: the moved contact with every subset of the others
    (all but the full set), by the same offset maximisation, keyed ``"0,3"`` (contact
    indices).  A sub-task drops constraints, so its frontier lies at or past ``t*``; a pair
    test (pose-free, two contacts) can prove ``t* + delta`` only when some pair's frontier
    lies before it.  Each is a local maximum (a lower estimate of the sub-task's frontier);
    a sub-task the local solver does not solve is left out."""
    n, out = len(family.base.contacts), {}
    for size in range(2, n):
        for subset in combinations(range(n), size):
            if family.moved not in subset:
                continue
            base = replace(family.base, contacts=tuple(family.base.contacts[i] for i in subset))
            sub = Family(f"{family.name}{list(subset)}", base, subset.index(family.moved), family.u)
            try:
                out[",".join(map(str, subset))] = find_frontier(sub, seeds=seeds).t_mm
            except (RuntimeError, PrehensionError, np.linalg.LinAlgError, ValueError):
                continue
    return out


def made_by(t_star: float, subsets: dict[str, float], contacts: int) -> int:
    """The fewest contacts of a sub-task whose frontier lies within :data:`MADE_BY_MM` of
    ``t_star`` (``contacts``, the whole task, when none does)."""
    sizes = [len(k.split(",")) for k, t in subsets.items() if t <= t_star + MADE_BY_MM]
    return min(sizes, default=contacts)


# -- the runs --------------------------------------------------------------------------------
def _shrink(args) -> ShrinkOptions:
    """The complete solver's shrink options: the default, with the rotation cuts, and with
    the fields of ``--shrink`` (``KEY=VALUE``)."""
    fields = {"rotation_cuts": True, "limit_cuts": True} if args.rotation_cuts else {}
    return ShrinkOptions(**{**fields, **shrink_fields(getattr(args, "shrink", None) or [])})


def shrink_fields(pairs: list[str]) -> dict:
    """``["stop_after=10", "lp_order=narrowest", "feasibility_first=true"]`` as ShrinkOptions
    fields, each typed like its default (a clear error for an unknown field or value)."""
    defaults = ShrinkOptions()
    fields = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not hasattr(defaults, key) or key == "variables":
            raise SystemExit(f"--shrink: {pair!r} is not FIELD=VALUE with a field of ShrinkOptions "
                             f"(e.g. stop_after=10, lp_order=narrowest, feasibility_first=true)")
        kind = type(getattr(defaults, key))
        try:
            fields[key] = text.lower() in ("1", "true", "yes", "on") if kind is bool else kind(text)
        except ValueError:
            raise SystemExit(f"--shrink: {key}={text!r} is not a valid {kind.__name__} (the type of its default)") from None
    try:
        ShrinkOptions(**fields)
    except ValueError as exc:
        raise SystemExit(f"--shrink: {exc}") from None
    return fields


def run_family(console: Console, family: Family, frontier: Frontier, limit: float | None, offsets,
               max_boxes: int | None = None, shrink: ShrinkOptions = ShrinkOptions()) -> list[dict]:  # fmt: skip
    table = Table(title=f"{family.name}: t* = {frontier.t_mm:.3f} mm ({frontier.starts} starts, "
                        f"{frontier.seconds:.1f} s; configuration at t* {'collides' if frontier.collides else 'collision-free'})")  # fmt: skip
    for col in ("t - t* [mm]", "status", "boxes", "LPs", "time [s]", "closest miss"):
        table.add_column(col, justify="right" if col != "status" else "left")
    rows = []
    for delta in offsets:
        task = family.task_at(frontier.t_mm + delta)
        try:
            result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit, max_boxes=max_boxes,
                                                                shrink=shrink))
        except PrehensionError as exc:  # e.g. a version of the solver that refuses the task
            table.add_row(f"{delta:+g}", f"error: {exc}", "", "", "", "")
            continue
        s = result.stats
        best = s.get("best_residual")
        miss = "-" if best is None else f"{best['contact_mm']:.2g} mm, {best['normal_deg']:.2g} deg"
        table.add_row(f"{delta:+g}", result.status, str(s["boxes"]), str(s["lps"]), f"{result.seconds:.1f}", miss)
        rows.append({"family": family.name, "t_star": frontier.t_mm, "delta": delta, "status": result.status,
                     "boxes": s["boxes"], "lps": s["lps"], "seconds": result.seconds, "miss": miss})  # fmt: skip
        if delta < 0 and result.status == Status.INFEASIBLE:
            console.print(f"[red]FALSE INFEASIBLE: {task.name} is feasible (t < t*)[/red]")
    console.print(table)
    return rows


def run_pair_tests(console: Console, family: Family, frontier: Frontier, offsets, budget: int) -> list[dict]:
    """The pose-free pair test alone (``congruence_test``, ``budget`` boxes) at ``t* + delta``:
    proved or not, its boxes and CPU seconds (load-independent counts, one thread)."""
    table = Table(title=f"{family.name}: the pair test alone, {budget} boxes (t* = {frontier.t_mm:.3f} mm)")
    for col in ("t - t* [mm]", "outcome", "boxes", "CPU [s]"):
        table.add_column(col, justify="right" if col != "outcome" else "left")
    rows = []
    for delta in offsets:
        started = time.process_time()
        proof = congruence_test(family.task_at(frontier.t_mm + delta), max_boxes=budget)
        seconds = time.process_time() - started
        stopped = ", ".join(sorted({o.stopped for _, o in proof.outcomes if o.stopped}))
        outcome = "proved" if proof.proved else f"not proved ({stopped or 'no pair'})"
        table.add_row(f"{delta:+g}", outcome, str(proof.boxes), f"{seconds:.1f}")
        rows.append({"family": family.name, "t_star": frontier.t_mm, "delta": delta, "status": outcome,
                     "boxes": proof.boxes, "lps": "-", "seconds": seconds, "miss": "-"})  # fmt: skip
        if delta < 0 and proof.proved:
            console.print(f"[red]FALSE PROOF: {family.name} at t* {delta:+g} mm is feasible[/red]")
    console.print(table)
    return rows


# -- random families: runs appended to a JSONL file, and their distribution ---------------
RANDOM_OFFSETS_MM = (-0.5, 0.5, 1.0, 2.0, 4.0)


def _git_head() -> str:
    import subprocess

    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=Path(__file__).parent, capture_output=True,
                             text=True, timeout=10)  # fmt: skip
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _read_jsonl(path: Path | None) -> list[dict]:
    if path is None or not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _append(path: Path | None, record: dict) -> None:
    if path is not None:
        with path.open("a") as f:
            f.write(json.dumps(record) + "\n")


def _random_frontier(console: Console, seed: int, index: int, records: list[dict], out: Path | None):
    """``(family, described, t*)`` of family ``index`` of the draw ``seed``: from a frontier
    record of ``records`` when there is one (the family is drawn again, cheaply, from its
    attempt), else found now and appended to ``out``."""
    known = [r for r in records if r["kind"] == "frontier" and r["seed"] == seed and r["index"] == index]
    if known:
        r = known[-1]
        family, described = _draw(seed, index, r["attempt"])
        return family, described, r["t_star"]
    found = draw_family(seed, index)
    f = found.frontier
    record = {"kind": "frontier", "seed": seed, "index": index, "attempt": found.attempt, "name": found.family.name,
              "described": found.described, "t_star": f.t_mm, "starts": f.starts, "seconds": f.seconds,
              "raised": f.raised, "refused": list(found.refused)}  # fmt: skip
    records.append(record)
    _append(out, record)
    raised = f", raised {f.raised} x by a solution {PROBE_MM:g} mm past it" if f.raised else ""
    console.print(f"{found.family.name}: t* = {f.t_mm:.3f} mm ({f.seconds:.1f} s, attempt {found.attempt}{raised}): {found.described}")
    return found.family, found.described, f.t_mm


def _anatomy(console: Console, seed: int, index: int, family: Family, t_star: float, records: list[dict],
             out: Path | None) -> None:  # fmt: skip
    """The frontiers of the family's sub-tasks (:func:`sub_frontiers`), found once and
    appended to ``out`` as an ``anatomy`` record."""
    if any(r["kind"] == "anatomy" and r["seed"] == seed and r["index"] == index for r in records):
        return
    started = time.perf_counter()
    subsets = sub_frontiers(family)
    k = made_by(t_star, subsets, len(family.base.contacts))
    record = {"kind": "anatomy", "seed": seed, "index": index, "t_star": t_star, "subsets": subsets, "made_by": k,
              "contacts": len(family.base.contacts), "seconds": time.perf_counter() - started}  # fmt: skip
    records.append(record)
    _append(out, record)
    gaps = ", ".join(f"[{key}] {t - t_star:+.1f}" for key, t in subsets.items())
    console.print(f"{family.name}: frontier made by {k} of {len(family.base.contacts)} contacts (sub-task t - t* [mm]: {gaps or '-'})")


def run_random(console: Console, args) -> list[dict]:
    """The random families of ``args.random`` / ``args.seed`` (only ``args.indices`` when
    given) at ``args.offsets``; each run appended to ``args.out`` as it ends, and skipped
    when ``args.out`` already holds it (same family, offset, limits and ``args.tag``)."""
    records = _read_jsonl(args.out)
    indices = args.indices if args.indices is not None else list(range(args.random))
    for index in indices:
        try:
            family, described, t_star = _random_frontier(console, args.seed, index, records, args.out)
        except RuntimeError as exc:
            console.print(f"[red]{exc}[/red]")
            continue
        if args.anatomy:
            _anatomy(console, args.seed, index, family, t_star, records, args.out)
        if args.frontier_only:
            continue
        for delta in args.offsets:
            key = {"seed": args.seed, "index": index, "delta": delta, "time_limit": args.time_limit,
                   "max_boxes": args.max_boxes, "tag": args.tag, **({"cuts": True} if args.rotation_cuts else {}),
                   **({"shrink": shrink_fields(args.shrink)} if args.shrink else {})}  # fmt: skip
            if any(r["kind"] == "run" and all(r.get(k) == v for k, v in key.items())
                   and r.get("cuts", False) == args.rotation_cuts for r in records):  # fmt: skip
                continue
            task = family.task_at(t_star + delta)
            load = os.getloadavg()[0]
            limit = None if args.time_limit == float("inf") else args.time_limit
            result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit, max_boxes=args.max_boxes,
                                                                shrink=_shrink(args)))
            s = result.stats
            best = s.get("best_residual")
            record = {"kind": "run", **key, "name": family.name, "t_star": t_star, "status": str(result.status),
                      "boxes": s["boxes"], "lps": s["lps"], "seconds": result.seconds, "load": load,
                      "open_share": s.get("open_share"),
                      "pair_test": s.get("pair_test"), "self_collision_pruned": s.get("self_collision_pruned", 0),
                      "miss": None if best is None else [best["contact_mm"], best["normal_deg"]],
                      "message": result.message, "commit": args.commit}  # fmt: skip
            records.append(record)
            _append(args.out, record)
            flag = "  [red]FALSE INFEASIBLE[/red]" if delta < 0 and result.status == Status.INFEASIBLE else ""
            left = f", {s['open_share']:.3g} of the tree open" if result.status == Status.GAVE_UP else ""
            console.print(f"{family.name} t*{delta:+g} mm: {result.status}, {s['boxes']} boxes, {s['lps']} LPs{left}, "
                          f"{result.seconds:.1f} s (load {load:.1f}){flag}")  # fmt: skip
    return [r for r in records if r["kind"] == "run" and r["seed"] == args.seed and r.get("tag") == args.tag
            and r.get("cuts", False) == args.rotation_cuts and (args.indices is None or r["index"] in indices)]  # fmt: skip


def distribution(runs: list[dict]) -> Table:
    """Per offset: certified (infeasible) / solved / undecided, times and boxes (median, max),
    and false "infeasible" below ``t*`` (each run is its last record)."""
    last = {(r["seed"], r["index"], r["delta"]): r for r in runs}
    table = Table(title=f"{len({k[:2] for k in last})} random families: the complete search at t* + delta")
    for col in ("t - t* [mm]", "runs", "certified", "solved", "undecided", "false infeasible", "time median / max [s]",
                "boxes median / max", "load median"):  # fmt: skip
        table.add_column(col, justify="right")
    for delta in sorted({k[2] for k in last}):
        rows = [r for k, r in last.items() if k[2] == delta]
        count = lambda status: sum(r["status"] == status for r in rows)  # noqa: E731
        false = count(Status.INFEASIBLE) if delta < 0 else 0
        t = [r["seconds"] for r in rows]
        b = [r["boxes"] for r in rows]
        table.add_row(f"{delta:+g}", str(len(rows)), str(count(Status.INFEASIBLE)), str(count(Status.SOLVED)),
                      str(count(Status.GAVE_UP)), str(false), f"{np.median(t):.1f} / {max(t):.1f}",
                      f"{np.median(b):.0f} / {max(b)}", f"{np.median([r['load'] for r in rows]):.1f}")  # fmt: skip
    return table


def targets(runs: list[dict]) -> list[str]:
    """The issue's targets on these runs: ``+1 mm`` certified within 300 s on at least 19 of
    20 (the same share), ``+2 mm`` within 60 s on all, ``-0.5 mm`` solved on all, no false
    "infeasible"."""
    last = {(r["seed"], r["index"], r["delta"]): r for r in runs}

    def share(delta, ok):
        rows = [r for k, r in last.items() if k[2] == delta]
        return sum(ok(r) for r in rows), len(rows)

    lines = []
    for delta, what, ok in ((1.0, "certified within 300 s", lambda r: r["status"] == Status.INFEASIBLE and r["seconds"] <= 300),
                            (2.0, "certified within 60 s", lambda r: r["status"] == Status.INFEASIBLE and r["seconds"] <= 60),
                            (-0.5, "solved", lambda r: r["status"] == Status.SOLVED)):  # fmt: skip
        k, n = share(delta, ok)
        past, _ = share(delta, lambda r: delta > 0 and r["status"] == Status.SOLVED)
        if n:
            note = f" ({past} solved: feasible past t*, whose maximisation stopped short)" if past else ""
            lines.append(f"t* {delta:+g} mm {what}: {k} of {n}{note}")
    false = [f"{r['name']} {r['delta']:+g}" for r in last.values() if r["delta"] < 0 and r["status"] == Status.INFEASIBLE]
    lines.append(f"false 'infeasible' below t*: {len(false)}{' (' + ', '.join(false) + ')' if false else ''}")
    return lines


def _family_table(records: list[dict], runs: list[dict]) -> Table:
    table = Table(title="The families (t* by offset maximisation; a strict solution at t* - 0.05 mm)")
    for col in ("family", "t* [mm]", "what", "made by", *(f"{d:+g}" for d in sorted({r['delta'] for r in runs}))):
        table.add_column(col)
    deltas = sorted({r["delta"] for r in runs})
    anatomy = _made_by(records)
    for f in records:
        if f["kind"] != "frontier" or not any(r["index"] == f["index"] and r["seed"] == f["seed"] for r in runs):
            continue
        cells = []
        for d in deltas:
            r = [r for r in runs if r["index"] == f["index"] and r["seed"] == f["seed"] and r["delta"] == d]
            short = {Status.SOLVED: "solved", Status.INFEASIBLE: "certified", Status.GAVE_UP: "undecided"}
            cells.append(f"{short.get(r[-1]['status'], r[-1]['status'])} {r[-1]['seconds']:.0f} s" if r else "")
        k = anatomy.get((f["seed"], f["index"]))
        t_star = f"{f['t_star']:.3f}" + (f" (raised {f['raised']} x)" if f.get("raised") else "")  # PROBE_MM
        table.add_row(f["name"], t_star, f["described"], "?" if k is None else f"{k[0]} of {k[1]}", *cells)
    return table


def _made_by(records: list[dict]) -> dict[tuple[int, int], tuple[int, int]]:
    """``(seed, index) -> (contacts making t*, contacts)`` of the anatomy records."""
    return {(r["seed"], r["index"]): (r["made_by"], r["contacts"]) for r in records if r["kind"] == "anatomy"}


def by_anatomy(records: list[dict], runs: list[dict]) -> list[str]:
    """Per offset, certified runs among families whose frontier a pair makes and among the
    others (families with an anatomy record only)."""
    anatomy, last = _made_by(records), {(r["seed"], r["index"], r["delta"]): r for r in runs}
    lines = []
    for delta in sorted({k[2] for k in last if k[2] > 0}):
        parts = []
        for label, ok in (("a pair's frontier", lambda k: k[0] == 2), ("3+ contacts' frontier", lambda k: k[0] > 2)):
            rows = [r for key, r in last.items() if key[2] == delta and key[:2] in anatomy and ok(anatomy[key[:2]])]
            if rows:
                parts.append(f"{label}: {sum(r['status'] == Status.INFEASIBLE for r in rows)} of {len(rows)} certified")
        if parts:
            lines.append(f"t* {delta:+g} mm -- " + "; ".join(parts))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--families", nargs="*", help="lid scalpel tuning sa-pinch allegro-pinch (default: all); "
                        "with --random, indices of the draw (0,3,7)")
    parser.add_argument("--time-limit", type=float, help="seconds per complete run (default 300; --quick: 30)")
    parser.add_argument("--offsets", type=float, nargs="*", help="t - t* [mm] to run (default -1 -0.5 0.5 1 2 4)")
    parser.add_argument("--quick", action="store_true", help="lid, scalpel, sa-pinch at -0.5, +2, +4 mm, 30 s per run")
    parser.add_argument("--max-boxes", type=int, help="box budget per complete run (then no time limit unless "
                        "--time-limit is given): the same search on a loaded machine")
    parser.add_argument("--rotation-cuts", action="store_true", help="the complete solver with ShrinkOptions(rotation_cuts="
                        "True, limit_cuts=True) (off by default; docs/complete-solver.md)")
    parser.add_argument("--shrink", nargs="*", metavar="FIELD=VALUE", help="ShrinkOptions fields of the complete "
                        "solver (e.g. feasibility_first=true lp_order=narrowest stop_after=10); runs of the JSONL "
                        "keep them (give them a --tag of their own to sum them apart)")
    parser.add_argument("--frontier-only", action="store_true", help="only find t* of each family")
    parser.add_argument("--pair-test", type=int, metavar="BOXES", help="run the pose-free pair test alone with this "
                        "box budget instead of the complete solver (its time is CPU seconds)")
    parser.add_argument("--frontiers", type=Path, help="JSON file of t* per family: read when present, else written")
    parser.add_argument("--random", type=int, metavar="K", help="K random families of the draw --seed instead of the "
                        "named ones (--families then takes indices, e.g. 0,3,7); offsets -0.5 0.5 1 2 4 by default")
    parser.add_argument("--seed", type=int, default=1, help="the draw of --random (default 1)")
    parser.add_argument("--out", type=Path, help="--random: JSONL file of frontiers and runs; read first (a family's "
                        "t* and runs already there are not repeated), every result appended as it ends")
    parser.add_argument("--tag", help="--random: a label kept with each run (default: the git commit); runs of "
                        "another tag are neither skipped nor summed")
    parser.add_argument("--report", action="store_true", help="--random: only print the distribution of --out")
    parser.add_argument("--anatomy", action="store_true", help="--random: also find the frontiers of each family's "
                        "sub-tasks (the moved contact with subsets of the others): how many contacts make t*")
    args = parser.parse_args()
    if args.random is not None:
        main_random(args)
        return
    defaults = QUICK if args.quick else {"families": None, "offsets": list(OFFSETS_MM), "time_limit": 300.0}
    if args.max_boxes is not None and args.time_limit is None:
        defaults = {**defaults, "time_limit": float("inf")}
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    console = Console(width=140)
    summary = Table(title="Frontiers found by maximising the offset (SLSQP from local solutions at t = 0)")
    for col in ("family", "t* [mm]", "starts", "time [s]", "collides at t*"):
        summary.add_column(col)
    all_rows = []
    known = json.loads(args.frontiers.read_text()) if args.frontiers and args.frontiers.is_file() else {}
    for family in families(args.families):
        if family.name in known:
            frontier = Frontier(known[family.name]["t_mm"], None, 0, known[family.name]["collides"], 0.0)
        else:
            frontier = find_frontier(family)
            known[family.name] = {"t_mm": frontier.t_mm, "collides": frontier.collides}
            if args.frontiers:
                args.frontiers.write_text(json.dumps(known, indent=1))
        console.print(f"{family.name}: t* = {frontier.t_mm:.3f} mm ({frontier.seconds:.1f} s)")
        summary.add_row(family.name, f"{frontier.t_mm:.3f}", str(frontier.starts), f"{frontier.seconds:.1f}",
                        "yes" if frontier.collides else "no")  # fmt: skip
        if args.pair_test and not args.frontier_only:
            all_rows += run_pair_tests(console, family, frontier, args.offsets, args.pair_test)
        elif not args.frontier_only:
            limit = None if args.time_limit == float("inf") else args.time_limit
            all_rows += run_family(console, family, frontier, limit, args.offsets, args.max_boxes, _shrink(args))
    console.print(summary)
    false = [r for r in all_rows if r["delta"] < 0 and r["status"] in (Status.INFEASIBLE, "proved")]
    console.print(f"false 'infeasible' below t*: {len(false)}")
    if all_rows:
        print(_markdown(all_rows))


def main_random(args) -> None:
    """``--random K --seed S``: draw, run (or only report) and print the distribution."""
    args.commit = _git_head()  # of the code this process loaded (runs record it)
    args.tag = args.tag or args.commit
    args.indices = None
    if args.families:
        args.indices = sorted({int(i) for item in args.families for i in item.split(",") if i.strip()})
    args.offsets = list(RANDOM_OFFSETS_MM) if args.offsets is None else args.offsets
    if args.time_limit is None:
        args.time_limit = float("inf") if args.max_boxes is not None else 300.0
    console = Console(width=200)
    if args.report:
        records = _read_jsonl(args.out)
        runs = [r for r in records if r["kind"] == "run" and r["seed"] == args.seed and r.get("tag") == args.tag
                and r.get("cuts", False) == args.rotation_cuts  # runs with and without --rotation-cuts kept apart
                and (args.indices is None or r["index"] in args.indices) and r["index"] < args.random]  # fmt: skip
    else:
        runs = run_random(console, args)
        records = _read_jsonl(args.out) if args.out else []
    if not runs:
        console.print(f"no runs of seed {args.seed} (tag {args.tag})")
        return
    console.print(_family_table(records, runs))
    console.print(distribution(runs))
    for line in targets(runs) + by_anatomy(records, runs):
        console.print(line)


def _markdown(rows: list[dict]) -> str:
    lines = ["| family | t* [mm] | t - t* [mm] | status | boxes | LPs | time [s] | closest miss |",
             "| --- | ---: | ---: | --- | ---: | ---: | ---: | --- |"]  # fmt: skip
    for r in rows:
        lines.append(f"| {r['family']} | {r['t_star']:.3f} | {r['delta']:+g} | {r['status']} | {r['boxes']} | "
                     f"{r['lps']} | {r['seconds']:.1f} | {r['miss']} |")  # fmt: skip
    return "\n".join(lines)


if __name__ == "__main__":
    main()
