"""Contact regions proposed on a bare mesh: force-closure point sets grown into patches.

:func:`propose_regions` turns a closed mesh and a :class:`~.hand_side.HandSide` into
ranked candidate sets of ``K`` object contact regions, in four steps:

1. **Sample** ``samples`` points on the surface, area-uniform and seeded
   (:func:`trimesh.sample.sample_surface`), each with its face's outward normal; a point
   from which a step of :data:`~prehension.objects.pick.OUTSIDE_STEP_MM` along the normal
   does not leave the solid (an internal wall of overlapping parts) is dropped.
2. **Antipodal pairs**: points ``i, j`` whose line lies inside both friction cones
   (``-n_i . u >= cos(atan mu)`` and ``n_j . u >= cos(atan mu)`` with ``u`` the unit vector
   from ``i`` to ``j``), at least the hand's gap and at most its largest span apart.  The
   narrowest antipodal pair (gap ignored) is what :class:`NoGraspError` reports when no
   pair fits in the hand.
3. **K-point sets**: for ``K >= 3``, each of ``attempts`` sets starts from a random pair,
   takes one end (at random) as the fingers' side and adds ``K - 2`` random points near it
   (within three gaps) whose normals lie within 45 deg of its (fingers side by side), every
   two points on one side between the gap and the largest span apart.  A set lists the
   other end first: the *opposing* contact (a thumb's, see :mod:`.hand_side`).  Each set is scored by the Ferrari-Canny ``epsilon`` of its contacts
   (:func:`~prehension.quality.contact_quality`, friction ``mu``, torques about the
   solid's centroid scaled by its radius) and kept only in force closure.  For ``K = 2``
   (which needs torsional friction to be force closure) the score is how antipodal the
   pair is, ``min(-n_i . u, n_j . u)``.
4. **Distinct and grown**: best first, a set is kept when its points lie at least
   ``distinct_mm`` (Hausdorff distance) from those of every set kept before; each point
   of a kept set is grown into a degree-2 Bézier patch of radius ``patch_mm`` fitted to
   the mesh by :func:`~prehension.objects.pick.region_from_mesh` (the fit ``prehension
   region`` makes, which refuses a patch whose normal points into the object); a fit that
   fails or strays from the surface more than 0.4 mm (the object's surface tolerance is 0.5) is
   tried at half the radius, then as a point with its normal.

Everything is seeded: the same mesh, hand and seed give the same sets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PrehensionError
from ..geometry.regions import Region
from ..objects.meshes import Mesh
from ..objects.pick import OUTSIDE_STEP_MM
from ..quality.measures import force_closure
from ..quality.options import DEFAULT_FRICTION, QualityOptions
from ..quality.wrenches import primitive_wrenches
from .grow import MeshSurface
from .hand_side import HandSide

__all__ = [
    "ProposalOptions", "CandidateSet", "PointSets", "Proposal", "NoGraspError", "propose_points", "grow_set", "propose_regions",
    "sample_surface",
]  # fmt: skip

_SIDE_COS = np.cos(np.radians(45.0))  # fingers side by side: normals within 45 deg


class NoGraspError(PrehensionError):
    """No candidate set fits the hand; the message says what bound proves it."""


@dataclass(frozen=True)
class ProposalOptions:
    """How :func:`propose_regions` proposes (every field has a default).

    Attributes:
        samples: surface points sampled.
        attempts: random K-point sets scored (K >= 3).
        candidates: candidate sets returned at most (best first).
        patch_mm: radius of each grown patch [mm]; ``None``: 5 % of the mesh's bounding
            box diagonal, within [2, 8] mm and at most 0.4 times the hand's gap.
        distinct_mm: the Hausdorff distance between the points of two kept sets [mm];
            ``None``: twice the patch radius.
        friction: Coulomb friction of the force-closure test and of the antipodal cones.
        seed: seed of the sampling and of the random sets.
    """

    samples: int = 600
    attempts: int = 600
    candidates: int = 60
    patch_mm: float | None = None
    distinct_mm: float | None = None
    friction: float = DEFAULT_FRICTION
    seed: int = 0

    def __post_init__(self):
        for name in ("samples", "attempts", "candidates"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise PrehensionError(f"proposal options: {name} must be a positive integer, got {value!r}")
        for name in ("patch_mm", "distinct_mm"):
            value = getattr(self, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise PrehensionError(f"proposal options: {name} must be a positive number of mm (or None), got {value!r}")
        if not (np.isfinite(self.friction) and self.friction > 0):
            raise PrehensionError(f"proposal options: friction must be a positive number, got {self.friction!r}")


@dataclass(frozen=True, eq=False)
class CandidateSet:
    """K contact regions proposed on the object, with the points they were grown from.

    Attributes:
        regions: ``K`` object regions (object frame, mm), outward normals.
        points: (K, 3) the sampled surface points [mm].
        normals: (K, 3) their outward normals.
        score: the set's rank value (epsilon for K >= 3, antipodality for K = 2).
    """

    regions: tuple[Region, ...]
    points: np.ndarray
    normals: np.ndarray
    score: float


@dataclass(frozen=True, eq=False)
class PointSets:
    """Ranked sets of sampled surface points, before they are grown into regions.

    Attributes:
        points: (N, 3) the sampled outer surface points [mm]; ``normals`` (N, 3) outward.
        sets: index tuples into ``points``, best first, distinct.
        scores: their rank values.
        pairs, scored, narrowest_mm, patch_mm: as :class:`Proposal`'s.
    """

    points: np.ndarray
    normals: np.ndarray
    sets: tuple[tuple[int, ...], ...]
    scores: tuple[float, ...]
    pairs: int
    scored: int
    narrowest_mm: float
    patch_mm: float


@dataclass(frozen=True, eq=False)
class Proposal:
    """What :func:`propose_regions` found.

    Attributes:
        sets: the candidate sets, best first.
        samples: surface points sampled (outer ones kept).
        pairs: antipodal pairs within the hand's gap and span.
        scored: K-point sets scored.
        narrowest_mm: the narrowest antipodal pair among the samples [mm] (inf: none).
        patch_mm: the patch radius used [mm].
    """

    sets: tuple[CandidateSet, ...]
    samples: int
    pairs: int
    scored: int
    narrowest_mm: float
    patch_mm: float


def sample_surface(mesh: Mesh, count: int, seed: int, distance=None) -> tuple[np.ndarray, np.ndarray]:
    """``count`` area-uniform surface points ``(N, 3)`` [mm] and their outward face normals
    ``(N, 3)``; points of faces with the solid on both sides dropped (so ``N <= count``)."""
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    points, faces = trimesh.sample.sample_surface(tm, int(count), seed=int(seed))
    normals = np.asarray(tm.face_normals)[faces]
    if distance is not None:
        outer = distance.signed_distance(points + OUTSIDE_STEP_MM * normals) > 0
        points, normals = points[outer], normals[outer]
    return np.asarray(points, float), np.asarray(normals, float)


def _antipodal(points, normals, friction: float) -> tuple[np.ndarray, np.ndarray]:
    """The antipodal pairs of ``points (N, 3)`` with outward ``normals (N, 3)``:
    ``pairs (P, 2)`` (indices ``i < j``) and ``(P, 2)`` their width [mm] and antipodality
    ``min(-n_i . u, n_j . u)``."""
    d = points[None] - points[:, None]  # (N, N, 3): from i to j
    width = np.linalg.norm(d, axis=2)
    u = d / np.maximum(width, 1e-12)[..., None]
    cos = np.cos(np.arctan(friction))
    at_i = -np.einsum("ik,ijk->ij", normals, u)  # -n_i . u
    at_j = np.einsum("jk,ijk->ij", normals, u)  # n_j . u
    score = np.minimum(at_i, at_j)
    i, j = np.nonzero(np.triu(score >= cos, 1))
    return np.stack([i, j], axis=1), np.stack([width[i, j], score[i, j]], axis=1)


def _patch_mm(mesh: Mesh, side: HandSide, options: ProposalOptions) -> float:
    if options.patch_mm is not None:
        return float(options.patch_mm)
    diagonal = float(np.linalg.norm(mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)))
    return float(min(np.clip(0.05 * diagonal, 2.0, 8.0), 0.4 * side.gap_mm))


def _distinct(sets: list, scores: np.ndarray, points: np.ndarray, distinct_mm: float, limit: int) -> list:
    """Best first, the sets whose points lie at least ``distinct_mm`` (Hausdorff) from those
    of every set kept before; at most ``limit`` of them (a few spare for failed fits)."""
    kept: list = []
    for k in np.argsort(-scores, kind="stable"):
        p = points[list(sets[k])]
        far = True
        for q in kept:
            d = np.linalg.norm(p[:, None] - points[list(q)][None], axis=2)
            if max(d.min(axis=1).max(), d.min(axis=0).max()) < distinct_mm:
                far = False
                break
        if far:
            kept.append(sets[k])
            if len(kept) >= limit:
                break
    return kept


def _random_sets(points, normals, pairs, k: int, side: HandSide, attempts: int, rng) -> list[tuple[int, ...]]:
    """Up to ``attempts`` distinct index sets of ``k`` points: a random antipodal pair, one
    end of it (at random) the *fingers' side* with ``k - 2`` points added near it, facing as
    it does; each set ordered ``(the other end, the fingers' end, the added points)``."""
    dist = np.linalg.norm(points[:, None] - points[None], axis=2)
    facing = normals @ normals.T >= _SIDE_COS
    fits = ((dist >= side.gap_mm) | (normals @ normals.T <= 0)) & (dist <= side.max_span_mm)
    near = dist <= min(3.0 * side.gap_mm, side.max_span_mm)
    out: dict[frozenset, tuple[int, ...]] = {}
    for _ in range(attempts):
        a, b = (int(x) for x in pairs[rng.integers(len(pairs))])
        chosen = [a, b] if rng.integers(2) else [b, a]
        while len(chosen) < k:
            free = np.flatnonzero(facing[chosen[1]] & near[chosen[1]] & fits[chosen].all(axis=0))
            if free.size == 0:
                break
            chosen.append(int(rng.choice(free)))
        if len(chosen) == k:
            out.setdefault(frozenset(chosen), tuple(chosen))
    return [out[key] for key in sorted(out, key=sorted)]


def _scores(sets, points, normals, centre, radius: float, friction: float) -> np.ndarray:
    """The force-closure LP margin ``t*`` of each set's contacts (-inf when not force closure)."""
    options = QualityOptions(friction=friction)
    out = np.full(len(sets), -np.inf)
    for n, s in enumerate(sets):
        idx = list(s)
        test = force_closure(primitive_wrenches(points[idx], -normals[idx], centre, radius, options).reshape(-1, 6))
        if test.force_closure:
            out[n] = test.margin
    return out


def _no_pair(hand_name: str, samples: int, narrowest_mm: float, side: HandSide, friction: float) -> NoGraspError:
    cone = np.degrees(np.arctan(friction))
    if not np.isfinite(narrowest_mm):
        return NoGraspError(
            f"no antipodal pair on the object: among {samples} surface points, no two face each other within the "
            f"friction cone (mu {friction:g}, {cone:.0f} deg); a grasp needs opposing contacts"
        )
    return NoGraspError(
        f"the object is too large for hand {hand_name!r}: the smallest width across any antipodal pair of its "
        f"{samples} sampled surface points (normals opposed within the friction cone, mu {friction:g}, {cone:.0f} deg) is "
        f"{narrowest_mm:.4g} mm; the hand's fingertips reach at most {side.max_span_mm:.4g} mm apart (a proven span "
        "bound over the joint limits); scale the mesh (--units/--scale) if its units are not what you meant"
    )


def _reference(mesh: Mesh) -> tuple[np.ndarray, float]:
    """The solid's centroid [mm] and its largest distance to a vertex [mm] (the torque scale)."""
    import trimesh

    centre = np.asarray(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).center_mass, float)
    return centre, float(np.max(np.linalg.norm(mesh.vertices - centre, axis=1)))


def propose_points(surface: MeshSurface, side: HandSide, fingers: int, options: ProposalOptions | None = None) -> PointSets:
    """Steps 1-3 and the distinct choice of step 4 of the module docstring: ranked point sets (not grown).

    Raises:
        NoGraspError: no antipodal pair fits within the hand's span (the message gives the
            narrowest pair and the span), or no set is force closure.
    """
    options = options or ProposalOptions()
    mesh = surface.mesh
    points, normals = sample_surface(mesh, options.samples, options.seed, surface.distance)
    pairs, info = _antipodal(points, normals, options.friction)
    narrowest = float(info[:, 0].min()) if len(pairs) else float("inf")
    fit = info[:, 0] <= side.max_span_mm if len(pairs) else np.zeros(0, bool)
    if not fit.any():
        raise _no_pair(side.hand.name, len(points), narrowest, side, options.friction)
    pairs, info = pairs[fit], info[fit]
    if fingers == 2:
        rng = np.random.default_rng(options.seed)
        sets = [tuple(int(x) for x in (p if rng.integers(2) else p[::-1])) for p in pairs]  # the opposing end first
        scores = info[:, 1].copy()
    else:
        sets = _random_sets(points, normals, pairs, fingers, side, options.attempts, np.random.default_rng(options.seed))
        scores = _scores(sets, points, normals, *_reference(mesh), options.friction)
    good = np.isfinite(scores)
    if not good.any():
        raise NoGraspError(
            f"none of {len(sets)} sets of {fingers} sampled surface points (built on {len(pairs)} antipodal pairs within "
            f"the hand's reach) is force closure with friction {options.friction:g}: try more samples or another seed"
        )
    patch = _patch_mm(mesh, side, options)
    kept = [s for s, g in zip(sets, good) if g]
    chosen = _distinct(kept, scores[good], points, options.distinct_mm or 2.0 * patch, options.candidates)
    score_of = dict(zip(sets, scores))
    return PointSets(points, normals, tuple(chosen), tuple(float(score_of[s]) for s in chosen),
                     len(pairs), len(sets), narrowest, patch)  # fmt: skip


def grow_set(surface: MeshSurface, points: PointSets, k: int, tolerance_mm: float = 0.4) -> CandidateSet | None:
    """Set ``k`` of ``points`` grown into regions (``None`` when a point grows none)."""
    idx = list(points.sets[k])
    regions = [surface.grow(points.points[i], points.normals[i], points.patch_mm, tolerance_mm) for i in idx]
    if any(r is None for r in regions):
        return None
    return CandidateSet(tuple(regions), points.points[idx].copy(), points.normals[idx].copy(), points.scores[k])


def propose_regions(mesh: Mesh, side: HandSide, fingers: int, options: ProposalOptions | None = None, *,
                    distance=None, tolerance_mm: float = 0.4) -> Proposal:  # fmt: skip
    """Candidate sets of ``fingers`` object contact regions on ``mesh`` (see the module docstring).

    Args:
        mesh: a closed, outward-oriented surface, object frame [mm].
        side: the hand's candidate regions and bounds (:func:`~.hand_side.hand_side`).
        fingers: contacts per set (``K``), at most ``len(side.regions)``.
        distance: the mesh's :class:`~prehension.objects.distance.MeshDistance`, when built.
        tolerance_mm: the largest deviation of a grown patch from the mesh [mm].

    Raises:
        NoGraspError: see :func:`propose_points`.
    """
    surface = MeshSurface(mesh, distance)
    found = propose_points(surface, side, fingers, options)
    grown = [grow_set(surface, found, k, tolerance_mm) for k in range(len(found.sets))]
    sets = tuple(g for g in grown if g is not None)
    return Proposal(sets, len(found.points), found.pairs, found.scored, found.narrowest_mm, found.patch_mm)
