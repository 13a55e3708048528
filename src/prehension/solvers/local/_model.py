"""The kernel's model of a state: hand pose, contact rows, inequality rows, object motion.

A *state* lives in a :class:`._kernel.Workspace` ``ws``, which also holds the hand
(``ws.hand``, :class:`._layout.HandArrays`), the group's layout (``ws.lay``) and the
options (``ws.opt``): unknowns ``ws.x``, object pose
``(ws.R, ws.t)`` (``T_palm_object``), and what follows from them (joint angles ``ws.q``,
link poses ``ws.Rl``/``ws.rl``, each angle's axis ``ws.ax`` and centre ``ws.org``, palm
frame).  The twist entries of ``x`` are always 0: a step's twist ``(w, v)`` moves the
object as ``R <- Rot(w) R`` about the problem's pivot, then by ``v``.

Rows (all in mm):

* **contact rows** (:func:`contact_rows`), six per contact: ``p_h - p_o`` (hand point
  minus object point) and ``w_n (n_h + n_o)`` (the outward normals opposed), the paper's
  fingertip-centre rows ``r = p - rho n`` recombined, with their Jacobian;
* **inequality rows** (:func:`inequality_rows`): ``value - margin`` of every pair
  closer than ``margin``, with its Jacobian, for the repair phase.  Two kinds:
  self-collision of capsule pairs (:func:`self_collision_rows`, value the clearance) and
  hand-object penetration (:func:`._penetration.object_rows`, value ``sd - r`` of a
  capsule against the object's solid, its data ``ws.obj`` an
  :class:`._penetration.ObjectArrays`); a new kind is one more function with the same
  signature, called from :func:`inequality_rows`, its data in a NamedTuple beside
  :class:`._layout.HandArrays`.
"""

from __future__ import annotations

import math

import numpy as np

from ...kernels.chain import pose_chain
from ...kernels.jit import njit
from ...kernels.segments import closest_points
from . import _regions as RG
from ._layout import S_K, S_KIND, S_OFF, S_X
from ._linalg import cross, dot, fill, mat_mat, mat_vec, rot
from ._penetration import capsule_rows, object_rows, pad_rows

__all__ = ["pose_hand", "contact_rows", "contact_errors", "inequality_rows", "seeing_rows", "move", "project_all", "initial_pose"]


# -- the hand ------------------------------------------------------------------------------
@njit(cache=True)
def _angles(x, lay, q):
    """Every joint angle from the unknowns (couplings exact, idle angles held)."""
    for d in range(q.shape[0]):
        j = lay.dof_free[d]
        q[d] = lay.q_fixed[d] if j < 0 else lay.dof_ratio[d] * x[j] + lay.dof_offset[d]


@njit(cache=True)
def pose_hand(ws):
    """Joint angles and link poses of the state's unknowns (the one forward-kinematics loop,
    :func:`~prehension.kernels.chain.pose_chain`, with the kernel's closed form of ``Rot``)."""
    _angles(ws.x, ws.lay, ws.q)
    pose_chain(ws.q, ws.hand.joints, np.bool_(True), ws.Rl, ws.rl, ws.ax, ws.org, ws.tmp[0], ws.tmp[1], ws.vec)


# -- contact rows ----------------------------------------------------------------------------
@njit(cache=True)
def _hand_side(c, ws, data, want_jac):
    """Contact ``c``'s hand point and normal (palm frame) and their Jacobian columns."""
    lay, w_n = ws.lay, ws.opt.w_n
    s = lay.sides[c, 0]
    li = lay.link[c]
    RG.evaluate(s, data, ws.x, want_jac, ws)
    mat_vec(ws.Rl[li], ws.pt, ws.ph[c])
    for i in range(3):
        ws.ph[c, i] += ws.rl[li, i]
    mat_vec(ws.Rl[li], ws.nr, ws.nh[c])
    if not want_jac:
        return
    r0 = 6 * c
    for k in range(s[S_K]):
        for i in range(3):
            ws.J[r0 + i, s[S_X] + k] = ws.Rl[li, i, 0] * ws.dpt[0, k] + ws.Rl[li, i, 1] * ws.dpt[1, k] + ws.Rl[li, i, 2] * ws.dpt[2, k]
            ws.J[r0 + 3 + i, s[S_X] + k] = w_n * (ws.Rl[li, i, 0] * ws.dnr[0, k] + ws.Rl[li, i, 1] * ws.dnr[1, k] + ws.Rl[li, i, 2] * ws.dnr[2, k])
    for jd in range(lay.chain_len[c]):  # joint columns: w_d x (p - o_d), w_d x n
        d = lay.chain[c, jd]
        col = lay.dof_free[d]
        if col < 0:
            continue
        for i in range(3):
            ws.pt[i] = ws.ph[c, i] - ws.org[d, i]
        cross(ws.ax[d], ws.pt, ws.vec)
        cross(ws.ax[d], ws.nh[c], ws.pt)
        for i in range(3):
            ws.J[r0 + i, col] += lay.dof_ratio[d] * ws.vec[i]
            ws.J[r0 + 3 + i, col] += lay.dof_ratio[d] * w_n * ws.pt[i]


@njit(cache=True)
def _object_side(c, ws, data, want_jac):
    """Contact ``c``'s object point and normal (palm frame), the rows ``f`` and their
    object-side Jacobian columns (region parameters, twist about the pivot ``ws.cp``)."""
    lay, w_n, cp = ws.lay, ws.opt.w_n, ws.cp
    s = lay.sides[c, 1]
    RG.evaluate(s, data, ws.x, want_jac, ws)
    mat_vec(ws.R, ws.pt, ws.po[c])
    for i in range(3):
        ws.po[c, i] += ws.t[i]
    mat_vec(ws.R, ws.nr, ws.no[c])
    r0 = 6 * c
    for i in range(3):
        ws.f[r0 + i] = ws.ph[c, i] - ws.po[c, i]
        ws.f[r0 + 3 + i] = w_n * (ws.nh[c, i] + ws.no[c, i])
    if not want_jac:
        return
    R, J, nf = ws.R, ws.J, lay.nf
    for k in range(s[S_K]):
        for i in range(3):
            J[r0 + i, s[S_X] + k] = -(R[i, 0] * ws.dpt[0, k] + R[i, 1] * ws.dpt[1, k] + R[i, 2] * ws.dpt[2, k])
            J[r0 + 3 + i, s[S_X] + k] = w_n * (R[i, 0] * ws.dnr[0, k] + R[i, 1] * ws.dnr[1, k] + R[i, 2] * ws.dnr[2, k])
    # d po = w x (po - cp) + v and d no = w x no, so d f_p / d w = [a]x, d f_n / d w = -w_n [no]x
    a0, a1, a2 = ws.po[c, 0] - cp[0], ws.po[c, 1] - cp[1], ws.po[c, 2] - cp[2]
    n0, n1, n2 = w_n * ws.no[c, 0], w_n * ws.no[c, 1], w_n * ws.no[c, 2]
    J[r0, nf + 1], J[r0, nf + 2], J[r0 + 1, nf], J[r0 + 1, nf + 2], J[r0 + 2, nf], J[r0 + 2, nf + 1] = -a2, a1, a2, -a0, -a1, a0
    J[r0 + 3, nf + 1], J[r0 + 3, nf + 2], J[r0 + 4, nf], J[r0 + 4, nf + 2], J[r0 + 5, nf], J[r0 + 5, nf + 1] = n2, -n1, -n2, n0, n1, -n0
    for i in range(3):
        J[r0 + i, nf + 3 + i] = -1.0


@njit(cache=True)
def contact_rows(ws, data, want_jac):
    """Rows ``ws.f`` (6C) and, if asked, their Jacobian ``ws.J`` (6C x nx); the largest
    contact distance and weighted normal error go to ``ws.err``."""
    lay, cp = ws.lay, ws.cp  # the pivot in the palm frame
    mat_vec(ws.R, data[lay.pivot_offset : lay.pivot_offset + 3], cp)
    for i in range(3):
        cp[i] += ws.t[i]
    if want_jac:
        fill(ws.J, 0.0)
    for c in range(lay.link.shape[0]):
        _hand_side(c, ws, data, want_jac)
        _object_side(c, ws, data, want_jac)
    contact_errors(ws.f, lay.link.shape[0], ws.err)


@njit(cache=True)
def contact_errors(f, C, err):
    """``err = (largest |p_h - p_o|, largest w_n |n_h + n_o|)`` [mm] over the contacts."""
    err[0] = 0.0
    err[1] = 0.0
    for c in range(C):
        r0 = 6 * c
        err[0] = max(err[0], math.sqrt(f[r0] ** 2 + f[r0 + 1] ** 2 + f[r0 + 2] ** 2))
        err[1] = max(err[1], math.sqrt(f[r0 + 3] ** 2 + f[r0 + 4] ** 2 + f[r0 + 5] ** 2))


# -- inequality rows -------------------------------------------------------------------------
@njit(cache=True)
def place_capsules(ws):
    """Capsule ends (palm frame) and bounding-sphere radii of the state's hand."""
    hand = ws.hand
    for s in range(hand.cap_link.shape[0]):
        li = hand.cap_link[s]
        mat_vec(ws.Rl[li], hand.cap_a[s], ws.ends[s, 0])
        mat_vec(ws.Rl[li], hand.cap_b[s], ws.ends[s, 1])
        d2 = 0.0
        for i in range(3):
            ws.ends[s, 0, i] += ws.rl[li, i]
            ws.ends[s, 1, i] += ws.rl[li, i]
            d2 += (ws.ends[s, 1, i] - ws.ends[s, 0, i]) ** 2
        ws.half[s] = 0.5 * math.sqrt(d2) + hand.cap_radius[s]


@njit(cache=True)
def _links_apart(ws, la, lb, margin):
    hand = ws.hand
    d2 = 0.0
    for i in range(3):
        ca = ws.rl[la, i] + ws.Rl[la, i, 0] * hand.link_centre[la, 0] + ws.Rl[la, i, 1] * hand.link_centre[la, 1] + ws.Rl[la, i, 2] * hand.link_centre[la, 2]
        cb = ws.rl[lb, i] + ws.Rl[lb, i, 0] * hand.link_centre[lb, 0] + ws.Rl[lb, i, 1] * hand.link_centre[lb, 1] + ws.Rl[lb, i, 2] * hand.link_centre[lb, 2]
        d2 += (ca - cb) ** 2
    return math.sqrt(d2) >= hand.link_radius[la] + hand.link_radius[lb] + margin


@njit(cache=True)
def _clearance_row(ws, sa, sb, dist, row):
    """Row ``row`` of ``M``: gradient of the clearance of capsules ``sa``, ``sb`` in ``x``:
    ``n . (d pa/dq - d pb/dq)`` at the closest points, ``n`` from ``pb`` to ``pa``."""
    hand, lay, M = ws.hand, ws.lay, ws.M
    la, lb = hand.cap_link[sa], hand.cap_link[sb]
    for j in range(M.shape[1]):
        M[row, j] = 0.0
    for d in range(lay.dof_free.shape[0]):
        col = lay.dof_free[d]
        ma, mb = hand.moves[la, d], hand.moves[lb, d]
        if col < 0 or ma == mb:  # moves both or neither: no relative motion
            continue
        for i in range(3):
            ws.pt[i] = (ws.pa[i] if ma else ws.pb[i]) - ws.org[d, i]
        cross(ws.ax[d], ws.pt, ws.vec)
        dv = 0.0
        for i in range(3):
            dv += (ws.pa[i] - ws.pb[i]) / dist * ws.vec[i]
        M[row, col] += lay.dof_ratio[d] * (dv if ma else -dv)


@njit(cache=True)
def self_collision_rows(ws, margin, row0, max_rows):
    """Rows ``clearance - margin`` of capsule pairs closer than ``margin`` [mm] into
    ``ws.M``, ``ws.g``, at most ``max_rows`` from ``row0`` (none when ``max_rows`` is 0);
    ``(rows written, smallest clearance seen)`` -- pairs skipped by the broad phase are
    farther than ``margin``.  The capsules must be placed (:func:`place_capsules`)."""
    hand = ws.hand
    nrows, cmin = 0, 1e300
    fs, ss = hand.pair_first, hand.pair_second
    for grp in range(hand.group_start.shape[0] - 1):
        p0, p1 = hand.group_start[grp], hand.group_start[grp + 1]
        if _links_apart(ws, hand.cap_link[fs[p0]], hand.cap_link[ss[p0]], margin):
            continue
        for p in range(p0, p1):
            sa, sb = fs[p], ss[p]
            d2 = 0.0
            for i in range(3):
                d2 += (ws.ends[sa, 0, i] + ws.ends[sa, 1, i] - ws.ends[sb, 0, i] - ws.ends[sb, 1, i]) ** 2
            if 0.5 * math.sqrt(d2) >= ws.half[sa] + ws.half[sb] + margin:
                continue  # bounding spheres farther apart than the margin
            dist = closest_points(ws.ends[sa, 0], ws.ends[sa, 1], ws.ends[sb, 0], ws.ends[sb, 1], ws.pa, ws.pb)
            clear = dist - hand.cap_radius[sa] - hand.cap_radius[sb]
            cmin = min(cmin, clear)
            if clear < margin and nrows < max_rows and dist > 1e-9:
                _clearance_row(ws, sa, sb, dist, row0 + nrows)
                ws.g[row0 + nrows] = clear - margin
                nrows += 1
    return nrows, cmin


@njit(cache=True)
def inequality_rows(ws, data, margin, row0, max_rows, every):
    """Every inequality row ``value - margin`` (wanted >= 0) closer than ``margin``, into
    ``ws.M``/``ws.g`` from ``row0``; see the module docstring.  Returns ``(rows written,
    smallest value seen)``.  The contact rows must be current (the pads of the contacts
    are excepted from the object's rows).  ``every`` (``np.bool_``): the idle fingers'
    capsules against the object too (:func:`._penetration.object_rows`)."""
    place_capsules(ws)
    n_self, v_self = self_collision_rows(ws, margin, row0, max_rows)
    n_obj, v_obj = object_rows(ws, data, margin, row0 + n_self, max_rows - n_self, every)
    return n_self + n_obj, min(v_self, v_obj)


@njit(cache=True)
def seeing_rows(ws, data, margin, reach, row0, max_rows):
    """The seeing steps' rows (:func:`._kernel.iterate`): :func:`inequality_rows` with the
    object's capsules (the idle fingers' too) searched up to ``reach`` [mm] instead of the
    margin, their rows written as ``value - margin``; the pads get no rows (their depth
    counts in the smallest value): a pad row holds the pad within 0.2 mm of the surface
    while its contact is still tens of millimetres off, and the answer's pads are judged
    (and repaired) afterwards with the exact rows -- measured on the built-ins and
    ``benchmarks/objects.py``'s 30 mesh tasks, 32 initial poses each: 567 clear strict
    answers of 1248 states without the pads' rows, 532 with them.  ``(rows written,
    smallest value seen)``.
    A capsule between the margin and the reach gets a row with ``g >= 0``: the step takes it
    only if it would bring the capsule within the margin (:func:`._kernel._seeing_step`)."""
    place_capsules(ws)
    n_self, v_self = self_collision_rows(ws, margin, row0, max_rows)
    if not ws.obj.active:
        return n_self, v_self
    r0 = row0 + n_self
    n_caps, v_caps = capsule_rows(ws, data, reach, r0, max_rows - n_self, np.bool_(True))
    for r in range(r0, r0 + n_caps):
        ws.g[r] += reach - margin
    v_pads = pad_rows(ws, data, r0 + n_caps, np.int64(0), np.bool_(True))[1]  # their depth only: no rows
    return n_self + n_caps, min(v_self, v_caps, v_pads)


# -- moving a state --------------------------------------------------------------------------
@njit(cache=True)
def project_all(ws, data):
    """Joint angles into their box, region parameters into their domains."""
    x, lay, margin = ws.x, ws.lay, ws.opt.cap_margin
    for j in range(lay.nf):
        x[j] = min(max(x[j], lay.lo[j]), lay.hi[j])
    for c in range(lay.sides.shape[0]):
        for s in range(2):
            side = lay.sides[c, s]
            RG.project(side[S_KIND], side[S_OFF], data, x, side[S_X], lay.lo, lay.hi, margin)


@njit(cache=True)
def move(ws, data):
    """Apply the step ``ws.dx``: the object pose by its twist about the pivot, the other
    unknowns by ``dx``, then project the parameters back into their regions."""
    lay = ws.lay
    nf = lay.nf
    piv = data[lay.pivot_offset : lay.pivot_offset + 3]
    cp = ws.cp
    mat_vec(ws.R, piv, cp)
    w0, w1, w2 = ws.dx[nf], ws.dx[nf + 1], ws.dx[nf + 2]
    th = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if th > 0.0:
        rot(w0 / th, w1 / th, w2 / th, th, ws.tmp[0])
        mat_mat(ws.tmp[0], ws.R, ws.tmp[1])
        for i in range(3):
            for j in range(3):
                ws.R[i, j] = ws.tmp[1, i, j]
    mat_vec(ws.R, piv, ws.vec)
    for i in range(3):
        ws.t[i] += cp[i] + ws.dx[nf + 3 + i] - ws.vec[i]
    for j in range(ws.x.shape[0]):
        if j < nf or j >= nf + 6:
            ws.x[j] += ws.dx[j]
    project_all(ws, data)


# -- the initial configuration ----------------------------------------------------------------
@njit(cache=True)
def _frame_of(z, F):
    """Columns (x, y, z): a right-handed orthonormal frame whose third axis is ``z``."""
    k = 0
    for i in range(1, 3):
        if abs(z[i]) < abs(z[k]):
            k = i
    for i in range(3):  # x: the axis least aligned with z, made orthogonal to it
        F[i, 0] = (1.0 if i == k else 0.0) - z[k] * z[i]
        F[i, 2] = z[i]
    nrm = math.sqrt(F[0, 0] ** 2 + F[1, 0] ** 2 + F[2, 0] ** 2)
    for i in range(3):
        F[i, 0] /= nrm
    for i in range(3):  # y = z x x
        j, m = (i + 1) % 3, (i + 2) % 3
        F[i, 1] = z[j] * F[m, 0] - z[m] * F[j, 0]


@njit(cache=True)
def _side_point(c, side, ws, data):
    """Region point and normal of one side of contact ``c`` in its own frame -> ws.pt, ws.nr."""
    RG.evaluate(ws.lay.sides[c, side], data, ws.x, np.bool_(False), ws)


@njit(cache=True)
def _psi(ws, poo, R0):
    """Rotation about the anchor's hand normal that best aligns the object's contacts with
    the hand's: the direction ``pair_a -> pair_b`` (the paper), or every contact seen from
    the anchor (2-D Procrustes).  ``poo`` (C, 3): object points, object frame."""
    lay = ws.lay
    u = ws.nh[lay.anchor]
    sc = sd = 0.0
    av, bv = ws.tmp[0, 0], ws.tmp[0, 1]
    pair = not ws.opt.procrustes and lay.pair_a >= 0 and lay.pair_b >= 0
    for c in range(1 if pair else poo.shape[0]):
        ca, cb = (lay.pair_a, lay.pair_b) if pair else (lay.anchor, c)
        if cb == ca:
            continue
        for i in range(3):
            ws.vec[i] = poo[cb, i] - poo[ca, i]
            bv[i] = ws.ph[cb, i] - ws.ph[ca, i]
        mat_vec(R0, ws.vec, av)
        da, db = dot(av, u), dot(bv, u)
        for i in range(3):  # both in the plane normal to u
            av[i] -= da * u[i]
            bv[i] -= db * u[i]
        cross(av, bv, ws.vec)
        sc += dot(u, ws.vec)
        sd += dot(av, bv)
    return math.atan2(sc, sd) if (sc != 0.0 or sd != 0.0) else 0.0


@njit(cache=True)
def _object_cost(c, ws):
    """Squared residual of contact ``c`` with its object side at ``ws.pt``, ``ws.nr`` (object frame)."""
    w_n = ws.opt.w_n
    cost = 0.0
    for i in range(3):
        p = ws.R[i, 0] * ws.pt[0] + ws.R[i, 1] * ws.pt[1] + ws.R[i, 2] * ws.pt[2] + ws.t[i]
        n = ws.R[i, 0] * ws.nr[0] + ws.R[i, 1] * ws.nr[1] + ws.R[i, 2] * ws.nr[2]
        cost += (p - ws.ph[c, i]) ** 2 + (w_n * (n + ws.nh[c, i])) ** 2
    return cost


@njit(cache=True)
def _grid_object_params(ws, data, grid):
    """Each non-anchor contact's object parameters: the best of a ``grid x grid`` grid."""
    lay, margin = ws.lay, ws.opt.cap_margin
    for c in range(lay.sides.shape[0]):
        s = lay.sides[c, 1]
        i0 = s[S_X]
        if c == lay.anchor or s[S_K] == 0:
            continue
        best, ba, bb = 1e300, ws.x[i0], ws.x[i0 + 1]
        for ga in range(grid):
            for gb in range(grid):
                ws.x[i0] = lay.lo[i0] + (lay.hi[i0] - lay.lo[i0]) * (ga + 0.5) / grid
                ws.x[i0 + 1] = lay.lo[i0 + 1] + (lay.hi[i0 + 1] - lay.lo[i0 + 1]) * (gb + 0.5) / grid
                RG.project(s[S_KIND], s[S_OFF], data, ws.x, i0, lay.lo, lay.hi, margin)
                _side_point(c, np.int64(1), ws, data)
                cost = _object_cost(c, ws)
                if cost < best:
                    best, ba, bb = cost, ws.x[i0], ws.x[i0 + 1]
        ws.x[i0], ws.x[i0 + 1] = ba, bb


@njit(cache=True)
def _place_hand_points(ws, data, poo, no_anchor):
    """Hand points and normals (palm frame) at the start, object points ``poo`` and the
    anchor's object normal ``no_anchor`` (object frame) at their start parameters."""
    lay = ws.lay
    for c in range(lay.sides.shape[0]):
        RG.start_params(lay.sides[c, 1, S_KIND], ws.x, lay.sides[c, 1, S_X])
        li = lay.link[c]
        _side_point(c, np.int64(0), ws, data)
        mat_vec(ws.Rl[li], ws.pt, ws.ph[c])
        mat_vec(ws.Rl[li], ws.nr, ws.nh[c])
        _side_point(c, np.int64(1), ws, data)
        for i in range(3):
            ws.ph[c, i] += ws.rl[li, i]
            poo[c, i] = ws.pt[i]
            if c == lay.anchor:
                no_anchor[i] = ws.nr[i]


@njit(cache=True)
def initial_pose(ws, data):
    """Obtain_Initial_Conf: place the object so that the anchor contact holds exactly.

    The joint angles and hand parameters are those of ``ws.x`` (hand posed); the object
    parameters start at their default for the anchor and at the best of a small grid for
    the others; the rotation about the anchor normal is :func:`_psi`.
    """
    anchor = ws.lay.anchor
    poo = np.empty((ws.lay.sides.shape[0], 3))
    frames = np.empty((3, 3, 3))  # object normal frame, minus hand normal frame, R0
    _place_hand_points(ws, data, poo, ws.cp)
    _frame_of(ws.cp, frames[0])  # R0 maps the anchor's object normal onto minus its hand normal
    for i in range(3):
        ws.vec[i] = -ws.nh[anchor, i]
    _frame_of(ws.vec, frames[1])
    for i in range(3):
        for j in range(3):
            frames[2, i, j] = dot(frames[1, i], frames[0, j])
    u = ws.nh[anchor]
    rot(u[0], u[1], u[2], _psi(ws, poo, frames[2]), ws.tmp[1])
    mat_mat(ws.tmp[1], frames[2], ws.R)
    mat_vec(ws.R, poo[anchor], ws.vec)
    for i in range(3):
        ws.t[i] = ws.ph[anchor, i] - ws.vec[i]
    _grid_object_params(ws, data, 5)
