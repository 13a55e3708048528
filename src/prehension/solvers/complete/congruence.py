r"""The frame-free pair test: can two contacts be made at all, whatever the object's pose?

For two contacts ``a, b`` whose hand regions are fingertip sphere caps (or points), a
grasp makes the *hand side* -- the fingertip centres ``c_a, c_b`` and the contact normals
``h_a, h_b`` (outward from the hand), in the frame of the links' common ancestor --
congruent to the *object side* -- ``c = o + r nu`` and ``h = -nu`` of the object regions,
in the object frame.  Quantities that rotations preserve must agree; those that do not
involve the pose of the palm in the object frame, which the complete solver's system
must search (and which makes its relaxations loose near the reach frontier, where a
continuum of poses nearly works).  With ``d = c_b - c_a`` (``D = |d|``), each cap's
normal lying within ``beta`` of its axis ``m`` and ``phi_a`` the angle between ``d`` and
``h_a``:

.. math::

    |d^{hand}|^2 = |d^{obj}|^2, \qquad
    d^{hand} \cdot m_a \ge D \cos(\phi_a + \beta_a)
      = \cos\beta_a\, (d \cdot h_a)^{obj} - \sin\beta_a\, |d \times h_a|^{obj},

likewise for ``b`` (with ``-d``), ``m_a . m_b >= cos(gamma + beta_a + beta_b)`` for the
angle ``gamma`` between the normals, and, for a hand *point* region (a fixed normal), the
equations ``d . h`` (and, for two points, ``h_a . h_b`` and ``d . (h_a x h_b)``, which then
make the test exact).  For two fingertip caps touching points (a pinch) these conditions
are also exact: they say the line between the fingertip centres lies in both cones.

The test searches the few variables these depend on -- the joint angles below the links'
common ancestor (couplings folded in, :func:`prehension.hands.reach.pair_kinematics`) and
the object regions' parameters -- by branch and prune:

* on each box, every quantity is an affine form (:mod:`.affine`): a first-order Taylor
  expansion at the centre with a remainder from bounds on the second derivatives (lever
  arms for the hand's points, 1 for unit vectors turned by joints, Bézier control nets
  for the object's patches: ``|d2 nu| <= 2|N''|/n + 5|N'|^2/n^2`` with ``n`` a lower bound
  of ``|N|`` over the patch, the sphere's radius and 1 for an object cap);
* a box is discarded when a condition cannot hold on it; otherwise the conditions narrow
  the box (interval propagation on the affine forms) and it is split through the
  dimension that contributes most to the condition closest to excluding it.

If every box is discarded the pair, hence the task, is infeasible: a proof that does not
depend on the pose, sound for any number of contacts (the pair's conditions are necessary
for the whole grasp).  Floating-point rounding is covered by a relative margin of 1e-9
on every comparison (as in :mod:`prehension.hands.reach`).  A box narrower than
``witness_width`` that survives means the conditions can (numerically) be met: the test
then stops without a proof.
"""

from __future__ import annotations

import functools
import heapq
import time
from dataclasses import dataclass

import numpy as np

from ...geometry.bezier import subdivide_nets
from ...geometry.regions import BezierRegion, PointRegion, SphereCap
from ...hands.reach import PairKinematics, pair_kinematics, span_bound_mm
from ...tasks.model import Task
from . import affine as af

__all__ = ["MATCHING_BOXES", "NEAR_FRONTIER_MM", "NEAR_SPAN_MM", "OUT_OF_SPAN_BOXES", "best_first_max", "object_distance_floor", "CongruenceResult", "PairProblem", "PairOutcome", "pair_problem", "prove_pair_infeasible", "prove_out_of_span",
           "object_distance_range", "congruence_test"]

_REL_PAD = 1e-9

#: Within this distance [mm] of the object side's floor, the pair test's boxes are split by
#: its conditions; farther, through an angle for the hand's distance (``distance_floor_mm``
#: of :func:`prove_pair_infeasible`).
NEAR_SPAN_MM = 1.0

#: Box budget of the object-side span test (:func:`prove_out_of_span`) of each pair in
#: :func:`congruence_test`, apart from the pair test's own: its boxes cost ~40 us (four
#: dimensions, no kinematics); far from the span it stops after a few, within a tenth of
#: a millimetre of it strongly curved patches need many (guitar-tuning at t* + 4 mm: 91,000
#: boxes, 3.5 s).
OUT_OF_SPAN_BOXES = 100_000

#: The twist condition (:func:`twist_possible`) is evaluated on a box only when the hand
#: side's ``d`` varies over it by less than this fraction of its length: on wider boxes its
#: interval bounds of the dihedral angles are too loose to prune (the lid at t* + 2 mm: every
#: box it pruned varied by under 0.036 |d|), and it costs as much as the other conditions.
TWIST_RELATIVE_SPREAD = 0.05


#: A pair whose object side's floor of the fingertip centres' distance comes within this of
#: the hand's span [mm] is near the reach frontier: the matching gets the pair's whole budget
#: (at most :data:`MATCHING_BOXES`) instead of a quarter, so that the search's first pair
#: test (20,000 boxes) runs its extremes and hand stage (``matching.EXTREMES_FROM``) and
#: decides the frontier families at the first box instead of the sixteenth.  No pair of the
#: built-in tasks comes within 32 mm (their floors are 0-128 mm, their spans 150-241 mm).
NEAR_FRONTIER_MM = 10.0

#: At most this many boxes (both sides) of the pair test by matching ranges (:mod:`.matching`)
#: per pair: on a pair that can be made, its boxes survive on both sides and matching them
#: costs more than linearly (guitar-holding, 100,000 boxes: 26 s more than the product test's);
#: the lid needs 21,166 at t* + 1 mm and 27,782 at t* + 0.5 mm.
MATCHING_BOXES = 40_000


# -- region kinds: second-derivative bounds -------------------------------------------------------
def _net_max(net: np.ndarray) -> float:
    return float(np.linalg.norm(net.reshape(-1, 3), axis=1).max(initial=0.0))


def _nets_max(nets: np.ndarray) -> np.ndarray:
    """:func:`_net_max` of each of a batch of nets ``(B, ..., 3)`` ``(B,)``."""
    return np.linalg.norm(nets.reshape(len(nets), -1, 3), axis=2).max(axis=1, initial=0.0)


def _hodograph(net: np.ndarray, axis: int) -> np.ndarray:
    """Control net of the derivative of a Bézier patch along ``axis`` (zeros for degree 0)."""
    deg = net.shape[axis] - 1
    if deg == 0:
        return np.zeros_like(net)
    return deg * np.diff(net, axis=axis)


def _patch_bounds(patch) -> tuple[float, float] | None:
    """``(M_point, M_normal)`` bounds on the second partials of a patch's point and unit normal
    over the whole patch, or None when ``|N|`` cannot be bounded away from 0."""
    P = patch.control_points
    second = [_hodograph(_hodograph(P, 0), 0), _hodograph(_hodograph(P, 0), 1), _hodograph(_hodograph(P, 1), 1)]
    Q = patch.normal_patch().control_points
    mean = Q.reshape(-1, 3).mean(axis=0)
    if np.linalg.norm(mean) == 0.0:
        return None
    n_min = float((Q.reshape(-1, 3) @ (mean / np.linalg.norm(mean))).min())  # |N| >= N . u >= this
    if n_min <= 0.0:
        return None
    g1 = max(_net_max(_hodograph(Q, 0)), _net_max(_hodograph(Q, 1)))
    g2 = max(_net_max(_hodograph(_hodograph(Q, i), j)) for i, j in ((0, 0), (0, 1), (1, 1)))
    return max(_net_max(n) for n in second), 2.0 * g2 / n_min + 5.0 * g1 * g1 / n_min**2


@functools.lru_cache(maxsize=64)
def _normal_net(patch) -> np.ndarray:
    """The control net of a patch's normal patch (asked for on every batch of boxes)."""
    return patch.normal_patch().control_points


def _local_patch_remainders(patch, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Per box ``(B, 2)`` of a patch's parameters, bounds ``(R_point, R_normal)`` ``(B,)`` of
    ``1/2 sum_ij |d_ij f| |delta_i| |delta_j|`` over the box for the patch's point and unit
    normal ``f`` (the remainder of a first-order Taylor form at the box's centre), from the
    control nets of the patch and of its normal patch ``N = p_u x p_v`` restricted to the box
    (:func:`~prehension.geometry.bezier.subdivide_nets`; local parameters ``t in [0, 1]^2``,
    ``|delta_i| <= 1/2``).  Second partials of the unit normal ``nu = N / |N|`` (with ``P = I -
    nu nu^T``, ``s = |N|``, ``g1_i >= |d_i N|``, ``g2_ij >= |d_ij N|``)::

        d_ij nu = [P d_ij N - d_j nu (nu . d_i N) - d_i nu (nu . d_j N)] / s - nu (d_j nu . d_i N) / s

    whose parts across and along ``nu`` are at most ``g2_ij / s + 2 g1_i g1_j / s^2`` and
    ``g1_i g1_j / s^2`` (``|d_i nu| <= g1_i / s``).  None when ``|N|`` may vanish on some box
    (``s`` from ``N . e`` with ``e`` the box's mean normal direction).  Bounds of the nets
    (convex hull property), widened by 1e-9 relative for rounding.
    """
    if not len(lo):
        return np.zeros(0), np.zeros(0)
    boxes = np.stack([lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1]], axis=1)
    P = subdivide_nets(patch.control_points, boxes)  # (B, m+1, n+1, 3)
    Q = subdivide_nets(_normal_net(patch), boxes)
    # the nets are (B, m+1, n+1, 3): u along axis 1, v along axis 2
    pairs = ((1, 1), (1, 2), (2, 2))
    weight = (1.0, 2.0, 1.0)  # uu, uv + vu, vv
    r_point = sum(w * _nets_max(_hodograph(_hodograph(P, i), j)) for w, (i, j) in zip(weight, pairs)) / 8.0
    mean = Q.reshape(len(Q), -1, 3).mean(axis=1)
    e = mean / np.maximum(np.linalg.norm(mean, axis=1, keepdims=True), 1e-300)
    s = np.einsum("bkd,bd->bk", Q.reshape(len(Q), -1, 3), e).min(axis=1)
    if not np.all(s > 0.0):
        return None
    g1 = {1: _nets_max(_hodograph(Q, 1)), 2: _nets_max(_hodograph(Q, 2))}
    r_normal = 0.0
    for w, (i, j) in zip(weight, pairs):
        across = _nets_max(_hodograph(_hodograph(Q, i), j)) / s + 2.0 * g1[i] * g1[j] / s**2
        r_normal = r_normal + w * np.hypot(across, g1[i] * g1[j] / s**2)
    r_normal = r_normal / 8.0
    pad = 1.0 + 1e-9
    return r_point * pad + 1e-300, r_normal * pad + 1e-300


def region_curvature(region) -> tuple[float, float] | None:
    """Bounds on every second partial of a region's point [mm] and unit normal over its
    parameter domain, or None when the region is not supported."""
    if isinstance(region, PointRegion):
        return 0.0, 0.0
    if isinstance(region, SphereCap):
        return float(region.radius), 1.0
    if isinstance(region, BezierRegion):
        return _patch_bounds(region.patch)
    return None


# -- one pair -----------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PairProblem:
    """The variables and constants of the pair test of contacts ``a`` and ``b``.

    The box dimensions are, in order: the pair's joint angles (sources), the parameters
    of object region ``a`` and of object region ``b``.
    """

    contacts: tuple[int, int]
    kin: PairKinematics
    hand: tuple  # per side: (region, radius [mm]) of the hand region
    objects: tuple  # per side: (region, (M_point, M_normal))
    slices: tuple  # angles, object a, object b
    lower: np.ndarray
    upper: np.ndarray
    points: tuple = ()  # per side: (link, fingertip centre or hand point in the link [mm])

    @property
    def n_dims(self) -> int:
        return len(self.lower)


def pair_problem(task: Task, a: int, b: int) -> PairProblem | None:
    """The pair test's problem, or None when a region kind is not supported (hand patches)."""
    hands, objects, centres = [], [], []
    for i in (a, b):
        hreg, oreg = task.hand_region(task.contacts[i]), task.object_region(task.contacts[i])
        curvature = region_curvature(oreg)
        if not isinstance(hreg.region, (SphereCap, PointRegion)) or curvature is None:
            return None
        radius = float(hreg.region.radius) if isinstance(hreg.region, SphereCap) else 0.0
        centres.append((hreg.link, hreg.region.center if isinstance(hreg.region, SphereCap) else hreg.region.point))
        hands.append((hreg, radius))
        objects.append((oreg, curvature))
    kin = pair_kinematics(task.hand, centres[0][0], centres[0][1], centres[1][0], centres[1][1])
    lo, hi = _angle_bounds(task, kin)
    bounds = [(lo, hi)] + [o[0].param_bounds() for o in objects]
    edges = np.cumsum([0] + [len(np.atleast_1d(x[0])) for x in bounds])
    slices = tuple(slice(int(s), int(e)) for s, e in zip(edges[:-1], edges[1:]))
    lower = np.concatenate([np.asarray(x[0], dtype=float) for x in bounds])
    upper = np.concatenate([np.asarray(x[1], dtype=float) for x in bounds])
    return PairProblem((a, b), kin, tuple(hands), tuple(objects), slices, lower, upper, tuple(centres))


def _angle_bounds(task: Task, kin: PairKinematics) -> tuple[np.ndarray, np.ndarray]:
    """The sources' limits, narrowed by the limits of the dofs they drive."""
    hand, problem = task.hand, kin.problem
    lo, hi = problem.lower.astype(float).copy(), problem.upper.astype(float).copy()
    for dof, pos, ratio, offset in problem.driven:
        if ratio != 0.0:
            ends = sorted(((hand.lower[dof] - offset) / ratio, (hand.upper[dof] - offset) / ratio))
            lo[pos], hi[pos] = max(lo[pos], ends[0] - 1e-12), min(hi[pos], ends[1] + 1e-12)
    return lo, hi


# -- affine forms of the two sides --------------------------------------------------------------------
def _zero_form(B: int, K: int) -> af.Form:
    return af.Form(np.zeros((B, 3)), np.zeros((B, 3, K)), np.zeros(B))


def _hand_forms(pp: PairProblem, zc: np.ndarray, half: np.ndarray) -> tuple[af.Form, list[af.Form]]:
    """``d = c_b - c_a`` and, per side, the cap's axis or the point's normal (common link frame)."""
    B, K = zc.shape
    sa = pp.slices[0]
    d, J, Ra, Wa, Rb, Wb = pp.kin.evaluate(zc[:, sa])
    curv = np.zeros((K, K))
    curv[sa, sa] = pp.kin.problem.curvature_mm
    Jfull = np.zeros((B, 3, K))
    Jfull[:, :, sa] = -J
    directions = []
    for side, (R, W) in enumerate(((Ra, Wa), (Rb, Wb))):
        region = pp.hand[side][0].region
        v = np.einsum("bij,j->bi", R, region.axis if isinstance(region, SphereCap) else region.normal)
        Jv = np.zeros((B, 3, K))
        Jv[:, :, sa] = np.cross(W, v[:, :, None], axis=1)
        M = np.zeros((K, K))
        M[sa, sa] = pp.kin.rotation_curvature[side]
        directions.append(af.taylor_vector(v, Jv, half, M))
    return af.taylor_vector(-d, Jfull, half, curv), directions


def _object_forms(pp: PairProblem, zc: np.ndarray, half: np.ndarray, *, local: bool = True) -> tuple[af.Form, af.Form, af.Form]:  # fmt: skip
    """``d = c_b - c_a`` with ``c = o + r nu``, ``h_a = -nu_a``, ``h_b = -nu_b`` (object frame).

    The remainders of Bézier regions come from the patch's nets over each box
    (:func:`_local_patch_remainders`) when ``local``, else from the whole patch's bounds
    (:func:`region_curvature`): ~1 ms more per batch, which the object side's searches
    repay many times (guitar-tuning's key: the distance floor within 0.01 mm in 8,000 boxes
    instead of 1.1 mm short after 20,000) but the product test of :func:`prove_pair_infeasible`,
    whose boxes are set by the joint angles, does not (guitar-holding's pair test: +0.6 s)."""
    B, K = zc.shape
    centres, normals = [], []
    for side in (0, 1):
        (region, (m_point, m_normal)), radius = pp.objects[side], pp.hand[side][1]
        sl = pp.slices[1 + side]
        o, nu = region.evaluate(zc[:, sl])
        do, dnu = region.jacobian(zc[:, sl])
        reach = half[:, sl].sum(axis=1)
        Jc, Jn = np.zeros((B, 3, K)), np.zeros((B, 3, K))
        Jc[:, :, sl], Jn[:, :, sl] = (do + radius * dnu) * half[:, None, sl], -dnu * half[:, None, sl]
        r_point, r_normal = 0.5 * m_point * reach**2, 0.5 * m_normal * reach**2
        if local and isinstance(region, BezierRegion) and half[:, sl].any():
            local = _local_patch_remainders(region.patch, zc[:, sl] - half[:, sl], zc[:, sl] + half[:, sl])
            if local is not None:
                r_point, r_normal = np.minimum(r_point, local[0]), np.minimum(r_normal, local[1])
        centres.append(af.Form(o + radius * nu, Jc, r_point + radius * r_normal))
        normals.append(af.Form(-nu, Jn, r_normal))
    return af.sub(centres[1], centres[0]), normals[0], normals[1]


def _norm_upper(v: af.Form) -> np.ndarray:
    """An upper bound of ``|v|`` over the box (B,)."""
    return np.linalg.norm(v.c, axis=1) + np.linalg.norm(v.A, axis=1).sum(axis=1) + v.rho


def _cone_condition(axis: af.Form, d: tuple[af.Form, af.Form], h: af.Form, cos_b: float, sin_b: float) -> af.Form:
    """``axis . d_hand - cos(beta) (d . h) + sin(beta) |d x h| >= 0`` (object ``d`` and ``h``),
    i.e. ``angle(d, axis) <= angle(d, h) + beta``; ``|d x h|`` enters through its upper bound
    on the box.  The cosine bound needs ``angle(d, h) + beta <= pi``: on boxes where that is
    not certain (``d . h >= -|d| cos(beta)`` not proven) the condition is dropped."""
    kappa = af.dot(d[1], h)
    f = af.sub(af.dot(axis, d[0]), _scaled(kappa, cos_b))
    # d . h >= -|d| cos(beta) on the whole box: with cos(beta) >= 0 the lower bound of |d|
    # makes it certain, with cos(beta) < 0 (beta > 90 deg) its upper bound
    d_size = _length(d[1])[0] if cos_b >= 0.0 else _norm_upper(d[1])
    valid = kappa.c - af.spread(kappa) + d_size * cos_b >= 0.0
    return af.Form(np.where(valid, f.c + sin_b * _norm_upper(af.cross(d[1], h)), np.inf), f.A, f.rho)


def _scaled(f: af.Form, s: float) -> af.Form:
    return af.Form(f.c * s, f.A * s, f.rho * abs(s))


def _conditions(pp: PairProblem, lo: np.ndarray, hi: np.ndarray):
    """Equations ``(form, pad)`` (``= 0``) and inequalities (``>= 0``) on the boxes, and the
    forms ``(d_hand, dirs, d_obj, normals)`` of the twist condition (:func:`twist_possible`)."""
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d_hand, dirs = _hand_forms(pp, zc, half)
    d_obj, h_a, h_b = _object_forms(pp, zc, half, local=False)
    equations, inequalities = _form_conditions(pp, d_hand, dirs, d_obj, h_a, h_b)
    return equations, inequalities, (d_hand, dirs, d_obj, (h_a, h_b))


def _rows(f: af.Form, rows: np.ndarray) -> af.Form:
    return af.Form(f.c[rows], f.A[rows], f.rho[rows])


def _form_conditions(pp: PairProblem, d_hand: af.Form, dirs: list, d_obj: af.Form, h_a: af.Form, h_b: af.Form):
    equations = [_difference(af.dot(d_hand, d_hand), af.dot(d_obj, d_obj))]
    inequalities = []
    caps = [isinstance(h[0].region, SphereCap) for h in pp.hand]
    for side, (h, sign) in enumerate(((h_a, 1.0), (h_b, -1.0))):
        d_h, d_o = (d_hand, d_obj) if sign > 0 else (af.neg(d_hand), af.neg(d_obj))
        if caps[side]:
            beta = pp.hand[side][0].region.half_angle
            inequalities.append(_pad(_cone_condition(dirs[side], (d_h, d_o), h, np.cos(beta), np.sin(beta))))
        else:
            equations.append(_difference(af.dot(d_h, dirs[side]), af.dot(d_o, h)))
    if not any(caps):
        equations.append(_difference(af.dot(dirs[0], dirs[1]), af.dot(h_a, h_b)))
        equations.append(_difference(af.dot(d_hand, af.cross(dirs[0], dirs[1])), af.dot(d_obj, af.cross(h_a, h_b))))
    else:
        total = sum(pp.hand[s][0].region.half_angle for s in (0, 1) if caps[s])
        if total < np.pi:  # angle(m_a, m_b) <= angle(h_a, h_b) + beta_a + beta_b
            gamma = af.dot(h_a, h_b)
            f = af.sub(af.dot(dirs[0], dirs[1]), _scaled(gamma, np.cos(total)))
            valid = gamma.c - af.spread(gamma) + np.cos(total) >= 0.0  # angle(h_a, h_b) + total <= pi
            c = np.where(valid, f.c + np.sin(total) * _norm_upper(af.cross(h_a, h_b)), np.inf)
            inequalities.append(_pad(af.Form(c, f.A, f.rho)))
    return equations, inequalities


def _difference(P: af.Form, O: af.Form):
    scale = np.abs(P.c) + np.abs(O.c) + af.spread(P) + af.spread(O)
    return af.sub(P, O), _REL_PAD * scale + _REL_PAD


def _pad(f: af.Form):
    return f, _REL_PAD * (np.abs(f.c) + af.spread(f)) + _REL_PAD


# -- the twist about the line between the fingertip centres -----------------------------------------
def _interval(f: af.Form) -> tuple[np.ndarray, np.ndarray]:
    s = af.spread(f)
    return f.c - s, f.c + s


def _mul(a: tuple, b: tuple) -> tuple[np.ndarray, np.ndarray]:
    p = np.stack([a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]])
    return p.min(axis=0), p.max(axis=0)


def _length(d: af.Form) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``|d|`` over the boxes (B,), (B,): ``|c|`` less and plus the form's spread."""
    lower = np.maximum(np.linalg.norm(d.c, axis=1) - np.linalg.norm(d.A, axis=1).sum(axis=1) - d.rho, 0.0)
    return lower, _norm_upper(d)


def _vector_spread(d: af.Form) -> np.ndarray:
    """``sum_k |A_k| + rho`` of a vector form: how far it strays from ``c`` over the box (B,)."""
    return np.linalg.norm(d.A, axis=1).sum(axis=1) + d.rho


def _axial(d: af.Form, v: af.Form, length: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``v . d / |d|`` (clipped to [-1, 1]; ``[-1, 1]`` where ``|d|`` may be 0)."""
    lo, hi = _interval(af.dot(d, v))
    ok = length[0] > 0.0
    L0, L1 = np.where(ok, length[0], 1.0), np.where(ok, length[1], 1.0)
    q = np.stack([lo / L0, lo / L1, hi / L0, hi / L1])
    return np.where(ok, np.clip(q.min(axis=0), -1.0, 1.0), -1.0), np.where(ok, np.clip(q.max(axis=0), -1.0, 1.0), 1.0)


def _half_width_upper(m_ax: tuple, h_ax: tuple, beta: float) -> np.ndarray:
    """An upper bound [rad] of the half width ``w = arccos((cos beta - m_par h_par) / (|m_perp|
    |h_perp|))`` of the arc of twists ``psi`` about ``d`` that bring a unit vector ``m`` (the
    cap's axis) within ``beta`` of ``h`` (the contact normal), from bounds of their axial
    components ``m_par = m . u``, ``h_par = h . u`` (``u = d / |d|``): ``pi`` when every twist
    may do, ``-1`` when none can (B,)."""
    prod = _mul(m_ax, h_ax)
    perp = []
    for lo, hi in (m_ax, h_ax):
        sq_hi = np.maximum(lo * lo, hi * hi)
        sq_lo = np.where((lo <= 0.0) & (hi >= 0.0), 0.0, np.minimum(lo * lo, hi * hi))
        perp.append((np.sqrt(np.maximum(1.0 - sq_hi, 0.0)), np.sqrt(np.maximum(1.0 - sq_lo, 0.0))))
    D_lo, D_hi = perp[0][0] * perp[1][0], perp[0][1] * perp[1][1]
    N_lo = np.cos(beta) - prod[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(N_lo >= 0.0, N_lo / D_hi, np.where(D_lo > 0.0, N_lo / D_lo, -np.inf))
    ratio = np.where(np.isnan(ratio), -np.inf, ratio)  # 0 / 0: the cone's edge for every twist
    ratio = ratio - (1e-9 * np.abs(np.where(np.isfinite(ratio), ratio, 0.0)) + 1e-12)
    return np.where(ratio > 1.0, -1.0, np.arccos(np.clip(ratio, -1.0, 1.0)))


def _dihedral(d: af.Form, x: af.Form, y: af.Form, length: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds ``(lo, hi)`` [rad] of the signed angle about ``d`` from the plane ``(d, x)`` to the
    plane ``(d, y)`` -- ``atan2(|d| d . (x cross y), (d cross x) . (d cross y))`` -- and
    whether they are known ``(B,)`` (not where both arguments may vanish)."""
    s = _mul(length, _interval(af.dot(d, af.cross(x, y))))
    c = _interval(af.dot(af.cross(d, x), af.cross(d, y)))
    known = ~((s[0] <= 0.0) & (s[1] >= 0.0) & (c[0] <= 0.0) & (c[1] >= 0.0))
    ref = np.arctan2(0.5 * (s[0] + s[1]), 0.5 * (c[0] + c[1]))
    corners = np.stack([np.arctan2(sv, cv) for sv in s for cv in c])
    rel = np.angle(np.exp(1j * (corners - ref)))  # the box misses 0: its corners lie within pi of ref
    return ref + rel.min(axis=0), ref + rel.max(axis=0), known


def twist_possible(pp: PairProblem, d_hand: af.Form, dirs: list, d_obj: af.Form, normals: tuple) -> np.ndarray:
    """Whether one rotation can meet both cones, per box ``(B,)``.

    The rotations taking the hand side's ``d`` onto the object side's (every grasp makes one)
    differ by a twist ``psi`` about ``d``.  Side ``i``'s cone (the normal ``h_i`` within
    ``beta_i`` of the cap's axis ``m_i``; ``beta = 0`` for a hand point) holds on an arc of
    ``psi`` of half width ``w_i`` (:func:`_half_width_upper`) centred at the azimuth of ``h_i``
    minus that of ``m_i`` about ``d``; the two arcs meet only if the dihedral angle of the
    planes ``(d, h_a), (d, h_b)`` (object side) is within ``w_a + w_b`` of that of ``(d, m_a),
    (d, m_b)`` (hand side), on the circle.  The cone conditions of :func:`_cone_condition`
    ask each arc to exist; this asks them to meet -- what makes the pair test exact for
    two fingertip caps on patches, where each cone alone can be met near the frontier but
    not both with the same pose.  Bounds are intervals from the affine forms, outward, with
    a margin of 1e-7 rad.
    """
    betas = [pp.hand[s][0].region.half_angle if isinstance(pp.hand[s][0].region, SphereCap) else 0.0 for s in (0, 1)]
    L_hand, L_obj = _length(d_hand), _length(d_obj)
    w = [_half_width_upper(_axial(d_hand, dirs[s], L_hand), _axial(d_obj, normals[s], L_obj), betas[s]) for s in (0, 1)]
    hand_lo, hand_hi, hand_known = _dihedral(d_hand, dirs[0], dirs[1], L_hand)
    obj_lo, obj_hi, obj_known = _dihedral(d_obj, normals[0], normals[1], L_obj)
    lo, hi = obj_lo - hand_hi, obj_hi - hand_lo  # the centres' difference
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    gap = np.maximum(np.abs(np.angle(np.exp(1j * mid))) - half, 0.0)
    apart = hand_known & obj_known & (half < np.pi) & (gap > w[0] + w[1] + 1e-7)
    none = (w[0] < 0.0) | (w[1] < 0.0)
    return ~(apart | none)


# -- branch and prune ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class PairOutcome:
    """Result of :func:`prove_pair_infeasible`.

    Attributes:
        proved: every box was discarded: the two contacts cannot be made together.
        boxes: boxes evaluated.
        seconds: time spent.
        stopped: why the search stopped without a proof ("" when proved): a witness box
            (the pair can be made), or a budget.
        witness: the centre of the surviving narrow box (box dimensions), or None.
    """

    proved: bool
    boxes: int
    seconds: float
    stopped: str = ""
    witness: np.ndarray | None = None


def prove_pair_infeasible(pp: PairProblem, *, max_boxes: int = 200_000, time_limit_s: float | None = None,
                          witness_width: float = 1e-7, batch: int = 256, distance_floor_mm: float = 0.0) -> PairOutcome:  # fmt: skip
    """Branch and prune over the pair's box (see the module docstring); stops without a
    proof after ``max_boxes`` boxes or ``time_limit_s`` seconds (None: no time limit).

    ``distance_floor_mm``: a proven lower bound of ``|c_b - c_a|`` over the whole object
    side (:func:`object_distance_floor`; 0: none).  The hand's distance must reach it:
    a box of angles whose span bound (:meth:`PairKinematics.distance_upper_mm`) stays
    below it is discarded, and a box whose bound exceeds it by more than
    :data:`NEAR_SPAN_MM` is split through an angle, by the span search's rule.  The object
    side is then not split where only the angles can decide (splitting both multiplies
    the boxes), and near the frontier the search is left with the few configurations near
    the hand's widest, where the cone conditions decide.
    """
    started = time.perf_counter()
    scale = np.maximum(pp.upper - pp.lower, 1e-12)
    stack_lo, stack_hi = [pp.lower[None].copy()], [pp.upper[None].copy()]
    boxes = 0
    while stack_lo:
        lo, hi = _take(stack_lo, stack_hi, batch)
        boxes += len(lo)
        lo, hi, split, score = _prune_and_contract(pp, lo, hi, distance_floor_mm)
        if len(lo) and np.any(((hi - lo) / scale).max(axis=1) < witness_width):
            k = int(np.argmin(((hi - lo) / scale).max(axis=1)))
            return PairOutcome(False, boxes, time.perf_counter() - started, "witness", 0.5 * (lo[k] + hi[k]))
        _push(stack_lo, stack_hi, lo[~split], hi[~split])
        _push(stack_lo, stack_hi, *_halves(lo[split], hi[split], score[split], scale))
        if boxes >= max_boxes or (time_limit_s is not None and time.perf_counter() - started > time_limit_s):
            return PairOutcome(False, boxes, time.perf_counter() - started, "budget")
    return PairOutcome(True, boxes, time.perf_counter() - started)


def _take(stack_lo: list, stack_hi: list, batch: int) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = stack_lo.pop(), stack_hi.pop()
    if len(lo) > batch:
        stack_lo.append(lo[:-batch])
        stack_hi.append(hi[:-batch])
        lo, hi = lo[-batch:], hi[-batch:]
    return lo, hi


def _push(stack_lo: list, stack_hi: list, lo: np.ndarray, hi: np.ndarray) -> None:
    if len(lo):
        stack_lo.append(lo)
        stack_hi.append(hi)


def _prune_and_contract(pp: PairProblem, lo: np.ndarray, hi: np.ndarray, distance_floor_mm: float = 0.0):
    """Drop the boxes that cannot hold a solution, narrow the others; returns the kept boxes,
    which of them to split (the others narrowed enough to be evaluated again) and the
    split scores ``(B, K)`` (see ``distance_floor_mm`` of :func:`prove_pair_infeasible`)."""
    far = np.zeros(len(lo), dtype=bool)
    if distance_floor_mm > 0.0:
        sa = pp.slices[0]
        reach, reach_score = pp.kin.distance_upper_mm(lo[:, sa], hi[:, sa])
        reach = reach * (1.0 + _REL_PAD) + _REL_PAD
        near = reach >= distance_floor_mm
        lo, hi, reach, reach_score = lo[near], hi[near], reach[near], reach_score[near]
        far = reach > distance_floor_mm + NEAR_SPAN_MM
    equations, cones, (d_hand, dirs, d_obj, normals) = _conditions(pp, lo, hi)
    alive = np.ones(len(lo), dtype=bool)
    for g, pad in equations:
        alive &= np.abs(g.c) <= af.spread(g) + pad
    for f, pad in cones:
        alive &= f.c + af.spread(f) + pad >= 0.0
    # the twist condition only where the others hold and the box is narrow enough for it to
    # prune (it costs as much again; a choice of effort, not of soundness)
    rows = np.flatnonzero(alive & (_vector_spread(d_hand) < TWIST_RELATIVE_SPREAD * np.linalg.norm(d_hand.c, axis=1)))
    if len(rows):
        alive[rows] = twist_possible(pp, _rows(d_hand, rows), [_rows(v, rows) for v in dirs], _rows(d_obj, rows),
                                     tuple(_rows(v, rows) for v in normals))  # fmt: skip
    eps_lo, eps_hi = -np.ones_like(lo), np.ones_like(lo)
    for _ in range(2):
        for g, pad in equations:
            af.contract_equal(g, pad, eps_lo, eps_hi)
        for f, pad in cones:
            af.contract_at_least(f, pad, eps_lo, eps_hi)
    alive &= np.all(eps_lo <= eps_hi, axis=1)
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    new_lo = np.maximum(lo, zc + half * eps_lo - 1e-12 * np.abs(zc))
    new_hi = np.minimum(hi, zc + half * eps_hi + 1e-12 * np.abs(zc))
    shrunk = ((new_hi - new_lo) < 0.7 * (hi - lo)) & (hi - lo > 0)
    score = _split_scores(equations, cones, (hi - lo) / np.maximum(pp.upper - pp.lower, 1e-12))
    if far.any():  # the angles alone decide these boxes: split them for the distance
        score[far] = 0.0
        score[np.ix_(far, np.arange(pp.slices[0].start, pp.slices[0].stop))] = 1.0 + reach_score[far]
    keep = alive & (new_lo <= new_hi).all(axis=1)
    split = ~shrunk[keep].any(axis=1)
    return new_lo[keep], new_hi[keep], split, score[keep]


def _split_scores(equations, inequalities, rel: np.ndarray) -> np.ndarray:
    """``(B, K)``: each dimension's share of the condition closest to excluding the box
    (largest ``|c| / spread`` for an equation, ``-c / spread`` for an inequality): its
    linear coefficient, plus the remainder shared in proportion to the squared relative
    widths ``rel (B, K)`` (the remainder is quadratic in the half widths)."""
    conditions = [(g, pad, np.abs(g.c)) for g, pad in equations] + [(f, pad, -f.c) for f, pad in inequalities]
    spreads = [af.spread(f) + pad for f, pad, _ in conditions]
    with np.errstate(invalid="ignore"):
        closeness = np.stack([np.nan_to_num(v / s, nan=-np.inf) for (_, _, v), s in zip(conditions, spreads)], axis=1)
    best = np.argmax(closeness, axis=1)
    rows = np.arange(len(best))
    A = np.stack([np.abs(f.A) / s[:, None] for (f, _, _), s in zip(conditions, spreads)], axis=1)[rows, best]
    rho = np.stack([f.rho / s for (f, _, _), s in zip(conditions, spreads)], axis=1)[rows, best]
    share = rel**2 / np.maximum((rel**2).sum(axis=1, keepdims=True), 1e-300)
    return A + rho[:, None] * share


def _halves(lo: np.ndarray, hi: np.ndarray, score: np.ndarray, scale: np.ndarray):
    """Both halves of every box, through the dimension with the largest score (widest, when
    every score is 0)."""
    if not len(lo):
        return lo, hi
    rel = (hi - lo) / scale
    k = np.argmax(np.where(rel > 1e-12, score + 1e-9 * rel, -1.0), axis=1)
    rows = np.arange(len(lo))
    mid = 0.5 * (lo[rows, k] + hi[rows, k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[rows, k], right_lo[rows, k] = mid, mid
    return np.concatenate([right_lo, lo]), np.concatenate([hi, left_hi])


# -- the object side alone against the hand's span ---------------------------------------------------
def object_distance_range(pp: PairProblem, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``(B,), (B,)`` [mm] of ``|c_b - c_a|`` over boxes of the pair's box dimensions (only
    the object regions' parameters matter), ``c = o + r nu`` the fingertip centre (or hand
    point) of each side when touching the object.

    With the object side's form ``d = c + sum_k A_k eps_k + B(rho)``, ``s = sum_k |A_k| + rho``
    and ``n = c / |c|``: ``|d| >= n . d >= |c| - sum_k |n . A_k| - rho`` and
    ``|d| >= |c| - s``; ``|d| <= |c| + s``.
    """
    zc, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d, _, _ = _object_forms(pp, zc, half)
    a = np.linalg.norm(d.c, axis=1)
    s = _vector_spread(d)
    n = d.c / np.maximum(a, 1e-300)[:, None]
    projected = a - np.abs(np.einsum("bi,bik->bk", n, d.A)).sum(axis=1) - d.rho
    return np.maximum(np.maximum(a - s, projected), 0.0), a + s


def object_distance_floor(pp: PairProblem, *, tol_mm: float = 0.01, max_boxes: int = 2_000, batch: int = 64,
                          span_mm: float | None = None) -> tuple[float, float, int]:  # fmt: skip
    """``(floor, best, boxes)``: a proven lower bound ``floor`` [mm] of ``|c_b - c_a|`` over
    the object regions' parameters (:func:`object_distance_range`), the smallest distance
    met at a box centre (``best >= `` the true minimum ``>= floor``) and the boxes used.

    Best-first branch and bound over the object dimensions only (at most four,
    :func:`best_first_max`) until ``best - floor <= tol_mm`` or ``max_boxes`` (the floor is
    then looser, never invalid).  Given the hand's span ``span_mm``, a tenth of the gap
    between ``best`` and the span is tolerated as well (a floor far below the span proves
    nothing and prunes little).
    """
    def tol(best: float) -> float:  # best: minus the smallest distance met
        return tol_mm if span_mm is None else max(tol_mm, 0.1 * (span_mm + best))

    bound, best, boxes = best_first_max(pp, lambda lo, hi: -object_distance_range(pp, lo, hi)[0], tol, max_boxes, batch)
    return max(-bound, 0.0) * (1.0 - _REL_PAD) - _REL_PAD, -best, boxes


def best_first_max(pp: PairProblem, upper_of, tol_of, max_boxes: int, batch: int = 64) -> tuple[float, float, int]:
    """``(bound, best, boxes)`` of the largest value of a function of the object regions'
    parameters: ``upper_of(lo, hi)`` gives upper bounds ``(B,)`` over boxes of the pair's
    full dimensions (only the object dimensions vary; on point boxes, the values).  Best-first:
    the ``batch`` boxes of largest bound are split through their widest relative object
    dimension until ``bound - best <= tol_of(best)`` (``best``: the largest value met at a
    box centre, ``<=`` the true maximum ``<= bound``) or ``max_boxes``: the bound is then
    looser, never invalid.  Boxes whose bound is within the tolerance of ``best`` stay open
    (their bounds still count) without being split."""
    dims = np.arange(pp.slices[1].start, pp.n_dims)
    scale = np.maximum(pp.upper - pp.lower, 1e-12)
    heap: list = []
    best, boxes, counter = -np.inf, 0, 0
    lo, hi = pp.lower[None].copy(), pp.upper[None].copy()
    while True:
        boxes += len(lo)
        upper = upper_of(lo, hi)
        centre = 0.5 * (lo + hi)
        best = max(best, float(upper_of(centre, centre).max()))
        for value, a, b in zip(upper, lo, hi):
            heapq.heappush(heap, (-float(value), counter, a, b))
            counter += 1
        bound, tol = -heap[0][0], tol_of(best)
        if bound - best <= tol or not dims.size or boxes >= max_boxes:
            return bound, best, boxes
        popped = [heapq.heappop(heap) for _ in range(min(batch, len(heap)))]
        take = [t for t in popped if -t[0] > best + tol] or popped[:1]
        for t in popped[len(take):]:  # the others stay open: their bounds still count
            heapq.heappush(heap, t)
        lo, hi = _halves_widest(np.array([t[2] for t in take]), np.array([t[3] for t in take]), dims, scale)


def _halves_widest(lo: np.ndarray, hi: np.ndarray, dims: np.ndarray, scale: np.ndarray):
    """Both halves of every box through its widest relative dimension among ``dims``."""
    k = dims[np.argmax(((hi - lo) / scale)[:, dims], axis=1)]
    rows = np.arange(len(lo))
    mid = 0.5 * (lo[rows, k] + hi[rows, k])
    left_hi, right_lo = hi.copy(), lo.copy()
    left_hi[rows, k], right_lo[rows, k] = mid, mid
    return np.concatenate([lo, right_lo]), np.concatenate([left_hi, hi])


def pair_span_mm(pp: PairProblem, hand, *, tight: bool = False) -> float:
    """The proven span [mm] between the pair's two hand points (fingertip centres) over the
    joint limits (:func:`prehension.hands.reach.span_bound_mm`): within 1 mm of the true
    maximum (the bound of the system's reach constraints, remembered per hand), or within
    0.05 mm when ``tight`` (about a second more per pair)."""
    (link_a, point_a), (link_b, point_b) = pp.points
    if tight:
        return span_bound_mm(hand, link_a, point_a, link_b, point_b, tol_mm=0.05, max_boxes=200_000)
    return span_bound_mm(hand, link_a, point_a, link_b, point_b)


def _span_test(pp: PairProblem, hand, max_boxes: int) -> tuple[bool, float, bool, int]:
    """``(proved, floor, witness, boxes)`` of the span test (see :func:`prove_out_of_span`): the
    tight span is computed only when the floor comes within 1 mm of the loose one."""
    pad = lambda x: x * (1.0 + _REL_PAD) + _REL_PAD  # noqa: E731
    span = pad(pair_span_mm(pp, hand))
    floor, best, boxes = object_distance_floor(pp, max_boxes=max_boxes, span_mm=span)
    if span - 1.0 < floor <= span:
        span = min(span, pad(pair_span_mm(pp, hand, tight=True)))
    return floor > span, floor, best <= span, boxes


def prove_out_of_span(pp: PairProblem, hand, *, max_boxes: int = OUT_OF_SPAN_BOXES) -> PairOutcome:
    """Whether the two contacts' fingertip centres (hand points) are always farther apart on
    the object than the hand can ever hold them, whatever the pose: the object side's floor
    (:func:`object_distance_floor`, searched alone: at most four dimensions, where the full
    pair test searches them with every joint angle of both chains) above the hand's span
    (:func:`pair_span_mm`), with a relative margin of 1e-9 for rounding.  Sound for any
    number of contacts: a grasp makes the two distances equal.  ``stopped`` is "witness"
    when a distance met on the object side is within the span.
    """
    started = time.perf_counter()
    proved, _, witness, boxes = _span_test(pp, hand, max_boxes)
    return PairOutcome(proved, boxes, time.perf_counter() - started, "" if proved else "witness" if witness else "budget")


# -- every pair of a task ---------------------------------------------------------------------------
@dataclass(frozen=True)
class CongruenceResult:
    """The pair test of a task: ``proved`` with the pair, or not, with the outcomes."""

    proved: bool
    pair: tuple[int, int] | None
    outcomes: tuple[tuple[tuple[int, int], PairOutcome], ...]

    @property
    def boxes(self) -> int:
        return sum(o.boxes for _, o in self.outcomes)


def congruence_test(task: Task, *, max_boxes: int = 200_000, time_limit_s: float | None = None) -> CongruenceResult:
    """The pair test on every pair of contacts (until one is proved infeasible): first the
    object side against the hand's span (:func:`prove_out_of_span`, at most
    :data:`OUT_OF_SPAN_BOXES` boxes, not counted in ``max_boxes``), then, without a proof,
    the test by matching ranges (:mod:`.matching`, a quarter of the pair's budget, all of it
    near the reach frontier: :data:`NEAR_FRONTIER_MM`) and the
    product test (:func:`prove_pair_infeasible`, the rest); the box budget ``max_boxes`` and the time limit are
    shared evenly by the pairs."""
    pairs = [(a, b) for a in range(len(task.contacts)) for b in range(a + 1, len(task.contacts))]
    share = max(1, max_boxes // max(1, len(pairs)))
    seconds = None if time_limit_s is None else time_limit_s / max(1, len(pairs))
    outcomes = []
    for a, b in pairs:
        pp = pair_problem(task, a, b)
        if pp is None:
            continue
        started = time.perf_counter()
        proved, floor, _, boxes = _span_test(pp, task.hand, OUT_OF_SPAN_BOXES)
        if proved:  # the object side alone is out of the hand's span
            outcome = PairOutcome(True, boxes, time.perf_counter() - started)
        else:
            outcome = _matching_then_product(pp, share, seconds, floor, pair_span_mm(pp, task.hand))
        outcomes.append(((a, b), outcome))
        if outcome.proved:
            return CongruenceResult(True, (a, b), tuple(outcomes))
    return CongruenceResult(False, None, tuple(outcomes))


def _matching_then_product(pp: PairProblem, max_boxes: int, time_limit_s: float | None, floor_mm: float,
                           span_mm: float) -> PairOutcome:  # fmt: skip
    """The pair test by matching ranges (:func:`.matching.prove_pair_by_matching`) with a quarter
    of the budget, all of it near the reach frontier (:data:`NEAR_FRONTIER_MM`; at most
    :data:`MATCHING_BOXES`; its boxes cost more on small budgets:
    guitar-holding's first pair test) and half of the time, then, without a proof, the product test with the rest; the boxes
    of both are counted."""
    from .matching import prove_pair_by_matching  # matching builds on this module's forms

    started = time.perf_counter()
    half_time = None if time_limit_s is None else 0.5 * time_limit_s
    near = span_mm - floor_mm <= NEAR_FRONTIER_MM  # the matching decides such pairs: give it all
    share = max_boxes if near else max_boxes // 4
    first = prove_pair_by_matching(pp, max_boxes=max(1, min(share, MATCHING_BOXES)), time_limit_s=half_time,
                                   distance_floor_mm=floor_mm)  # fmt: skip
    if first.proved:
        return first
    rest = None if time_limit_s is None else max(time_limit_s - (time.perf_counter() - started), 0.0)
    # the floor prunes only when the fingertips must be held wide apart (it costs a second
    # evaluation of the kinematics per box)
    floor_mm = floor_mm if floor_mm > 0.5 * span_mm else 0.0
    second = prove_pair_infeasible(pp, max_boxes=max(1, max_boxes - first.boxes), time_limit_s=rest, distance_floor_mm=floor_mm)
    return PairOutcome(second.proved, first.boxes + second.boxes, time.perf_counter() - started, second.stopped, second.witness)
