"""Tasks built by forward kinematics: the contacts hold by construction.

:func:`build_fk_case` picks joint angles, the fingers taking part and where on each
fingertip (or the palm) the contact is made, computes the hand contact point and outward
normal in the palm frame with forward kinematics, places the object at a random pose and
then builds, in the object frame, an object region that passes through that point with
the opposite normal (a point, a rigidly moved Bézier patch, or a sphere cap).  The known
parameters of every contact are returned with the configuration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from conftest import random_angles
from prehension.geometry.bezier import BezierPatch
from prehension.geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from prehension.geometry.rotations import make_transform, orthonormal_frame, rotation_about
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.model import GraspObject
from prehension.tasks.model import Configuration, Contact, Task
from prehension.solvers.local.verifier import LocalVerifier

DEG = np.pi / 180.0
OTHER_FINGERS = ("index", "middle", "ring")
OBJECT_KINDS = ("point", "bezier", "cap")
PATCH_DEGREES = ((1, 1), (2, 3), (3, 3))


def height_field_patch(rng, m: int, n: int, size: float = 20.0, bump: float = 3.0, jitter: float = 0.0) -> BezierPatch:
    """A gently curved patch ``z = f(x, y)`` over a square of side ``size`` [mm].

    Control points lie on an evenly spaced grid in x (along u) and y (along v), so that
    ``x`` and ``y`` are linear in ``u`` and ``v`` and ``p_u x p_v`` has z-component
    ``size^2 > 0`` everywhere: the patch is always regular.  ``jitter`` (a fraction of
    the grid spacing) moves the grid points a little in x and y.
    """
    x = np.linspace(-size / 2, size / 2, m + 1)
    y = np.linspace(-size / 2, size / 2, n + 1)
    X, Y = np.meshgrid(x, y, indexing="ij")
    if jitter:
        X = X + rng.uniform(-jitter, jitter, X.shape) * size / max(m, 1)
        Y = Y + rng.uniform(-jitter, jitter, Y.shape) * size / max(n, 1)
    Z = rng.uniform(-bump, bump, (m + 1, n + 1))
    return BezierPatch(np.stack([X, Y, Z], axis=-1))


def random_rotation(rng) -> np.ndarray:
    return Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()


def frame_rotation(a: np.ndarray, b: np.ndarray, spin: float = 0.0) -> np.ndarray:
    """A rotation that maps the unit vector ``a`` onto ``b`` (then spins about ``b``)."""
    A, B = orthonormal_frame(a), orthonormal_frame(b)
    return rotation_about(b, spin) @ B @ A.T


def active_mask(hand, fingers) -> np.ndarray:
    mask = np.zeros(hand.n_dof, dtype=bool)
    for f in fingers:
        for link in hand.finger(f).links:
            mask[list(hand.chain_dofs(link))] = True
    return mask


def idle_angles(hand) -> np.ndarray:
    return np.clip(0.0, hand.lower, hand.upper)


def random_cap_params(cap: SphereCap, rng, max_fraction: float = 0.95) -> np.ndarray:
    """Parameters (2,) of a cap whose normal lies strictly inside the cone (rejection)."""
    lo, hi = cap.param_bounds()
    while True:
        ag = rng.uniform(lo, hi)
        n = cap.normals(ag)[0]
        if n @ cap.axis >= np.cos(max_fraction * cap.half_angle):
            return ag


def cap_params_at_angle(cap: SphereCap, rng, angle: float) -> np.ndarray:
    """Parameters (2,) whose normal makes exactly ``angle`` [rad] with the cap axis."""
    e1, e2, m = cap.frame.T
    phi = rng.uniform(0, 2 * np.pi)
    n = np.cos(angle) * m + np.sin(angle) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    ag = cap.params_for_normal(n)[0]
    assert np.allclose(cap.normals(ag)[0], n, atol=1e-12)
    return ag


def object_region_through(kind: str, point: np.ndarray, normal: np.ndarray, rng, st=None) -> tuple[Region, np.ndarray]:
    """An object region through ``point`` with outward unit ``normal`` (object frame).

    Returns the region and the parameters at which it passes through the point.
    """
    if kind == "point":
        return PointRegion(point, normal), np.zeros(0)
    if kind == "bezier":
        m, n = PATCH_DEGREES[rng.integers(len(PATCH_DEGREES))]
        patch = height_field_patch(rng, m, n)
        st = rng.uniform(0.2, 0.8, 2) if st is None else np.asarray(st, dtype=float)
        p0, n0 = BezierRegion(patch).evaluate(st)
        R = frame_rotation(n0[0], normal, rng.uniform(-np.pi, np.pi))
        region = BezierRegion(patch.transformed(R, point - R @ p0[0]))
        return region, st
    if kind == "cap":
        radius = rng.uniform(5.0, 40.0)
        tilt_axis = np.cross(normal, rng.normal(size=3))
        axis = rotation_about(tilt_axis, rng.uniform(0, 30) * DEG) @ normal
        cap = SphereCap(point - radius * normal, radius, axis, rng.uniform(45.0, 120.0) * DEG)
        return cap, cap.params_for_normal(normal)[0]
    raise ValueError(kind)


@dataclass
class FKCase:
    task: Task
    config: Configuration  # with the known contact parameters
    fingers: tuple[str, ...]
    hand_regions: tuple[str, ...]
    object_kinds: tuple[str, ...]
    hand_points: np.ndarray  # (C, 3) palm frame
    hand_normals: np.ndarray  # (C, 3) palm frame, outward from the hand

    def with_pose(self, T) -> Configuration:
        return Configuration(self.config.joint_angles, T, self.config.contact_params)

    def without_params(self) -> Configuration:
        return Configuration(self.config.joint_angles, self.config.T_palm_object)


def build_fk_case(
    hand,
    rng,
    *,
    fingers=None,
    q=None,
    palm=None,
    kinds=None,
    hand_params=None,
    object_st=None,
) -> FKCase:
    """A task whose contacts hold at a known configuration.

    Args:
        hand: the hand (the SA hand: regions ``<finger>_tip`` and ``palm``).
        rng: numpy Generator.
        fingers: fingers taking part (default: the thumb and 1-3 random others).
        q: joint angles (default: random within limits and couplings; fingers not
            taking part at their idle values).  Used as given, even outside limits.
        palm: whether to add a palm contact (default: random, 1 in 4).
        kinds: object region kind per contact (default: random among point/bezier/cap).
        hand_params: per contact, hand parameters to use instead of random ones.
        object_st: per contact, Bézier parameters (for "bezier" contacts) or None.
    """
    if fingers is None:
        k = int(rng.integers(1, 4))
        fingers = ("thumb", *rng.choice(OTHER_FINGERS, size=k, replace=False).tolist())
    fingers = tuple(fingers)
    if q is None:
        q = np.where(active_mask(hand, fingers), random_angles(hand, rng, 1)[0], idle_angles(hand))
    q = np.asarray(q, dtype=float)
    if palm is None:
        palm = bool(rng.random() < 0.25)
    regions = tuple(f"{f}_tip" for f in fingers) + (("palm",) if palm else ())
    C = len(regions)
    if kinds is None:
        kinds = tuple(OBJECT_KINDS[i] for i in rng.integers(len(OBJECT_KINDS), size=C))
    kinds = tuple(kinds)
    pose = forward_kinematics(hand, q)
    R = random_rotation(rng)
    t = rng.uniform(-80.0, 80.0, 3) + np.array([60.0, 0.0, 120.0])
    T = make_transform(R, t)
    obj_regions, contacts, params, points, normals = {}, [], [], [], []
    for i, name in enumerate(regions):
        hreg = hand.region(name)
        hp = random_cap_params(hreg.region, rng) if hand_params is None or hand_params[i] is None else np.asarray(hand_params[i], dtype=float)
        p_link, n_link = hreg.region.evaluate(hp)
        li = hand.link_index(hreg.link)
        p_palm, n_palm = pose.points(li, p_link)[0], pose.directions(li, n_link)[0]
        p_obj, n_obj = R.T @ (p_palm - t), -(R.T @ n_palm)
        st = None if object_st is None else object_st[i]
        region, op = object_region_through(kinds[i], p_obj, n_obj, rng, st)
        obj_regions[f"o{i}"] = region
        contacts.append(Contact(name, f"o{i}"))
        params.append((hp, op))
        points.append(p_palm)
        normals.append(n_palm)
    task = Task("fk", hand, GraspObject("fk-object", obj_regions), tuple(contacts), fingers)
    config = Configuration(q, T, tuple(params))
    return FKCase(task, config, fingers, regions, kinds, np.array(points), np.array(normals))


# -- boxes of the complete solver around known configurations ---------------------------
def perturbed(rng, config: Configuration, size: float) -> Configuration:
    """The configuration with every joint angle and the object pose moved a little."""
    q = config.joint_angles + size * rng.normal(size=config.joint_angles.shape)
    T = config.T_palm_object.copy()
    T[:3, :3] = T[:3, :3] @ Rotation.from_rotvec(size * rng.normal(size=3)).as_matrix()
    T[:3, 3] += 100.0 * size * rng.normal(size=3)
    return Configuration(q, T, config.contact_params)


def box_around(rng, form, points, scale):
    """A random box of the system holding every one of ``points`` (S, n), grown by up to
    ``scale`` of each variable's initial width on either side."""
    s = form.system
    width = s.upper - s.lower
    lower = np.maximum(s.lower, points.min(axis=0) - scale * rng.uniform(0, 1, s.n) * width)
    upper = np.minimum(s.upper, points.max(axis=0) + scale * rng.uniform(0, 1, s.n) * width)
    return lower, upper


def search_path(form, x, depth: int = 4):
    """The boxes the search processes on its way down to the system point ``x`` (split
    without verifying, ``sigma`` 0.3), each :class:`BoxOutcome`, the child holding ``x`` next."""
    from prehension.solvers.complete.search import BranchAndPruneOptions, process_box

    options = BranchAndPruneOptions(verifier=LocalVerifier(), all_solutions=True, sigma=0.3)
    lower, upper = form.system.lower.copy(), form.system.upper.copy()
    for d in range(depth):
        out = process_box(form, lower, upper, d, options)
        yield out
        if out.kind != "split":
            return
        lower, upper = next((lo, hi) for lo, hi in out.children if np.all(lo <= x + 1e-9) and np.all(x <= hi + 1e-9))
