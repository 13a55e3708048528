"""Exact distances to a closed mesh against brute force (every triangle, winding numbers)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from prehension.objects.distance import MeshDistance
from prehension.objects.mesh_io import load_mesh
from conftest import SHARED

BUNNY = SHARED / "objects" / "bunny.obj"
requires_objects = pytest.mark.skipif(not BUNNY.is_file(), reason="shared/objects not present beside the checkout")


def _closest_on_triangles(p, tri):
    """Brute-force distance from p to each triangle (F,): dense sampling-free, by projection + edges."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d_plane = np.sum((p - a) * n, axis=1)
    q = p - d_plane[:, None] * n
    inside = np.ones(len(tri), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.sum(np.cross(v - u, q - u) * n, axis=1) >= 0
    best = np.where(inside, np.abs(d_plane), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        t = np.clip(np.sum((p - u) * (v - u), axis=1) / np.sum((v - u) ** 2, axis=1), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (u + t[:, None] * (v - u)), axis=1))
    return best


def _winding(p, tri):
    a, b, c = tri[:, 0] - p, tri[:, 1] - p, tri[:, 2] - p
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    num = np.sum(a * np.cross(b, c), axis=1)
    den = la * lb * lc + np.sum(a * b, 1) * lc + np.sum(b * c, 1) * la + np.sum(c * a, 1) * lb
    return np.sum(2 * np.arctan2(num, den)) / (4 * np.pi)


@pytest.fixture(scope="module")
def bunny():
    mesh = load_mesh(BUNNY, 100.0)  # about 90 x 140 x 200 mm
    return mesh, MeshDistance(mesh.vertices, mesh.faces)


@requires_objects
def test_signed_distance_matches_brute_force(bunny, rng):
    mesh, md = bunny
    tri = mesh.vertices[mesh.faces]
    lo, hi = mesh.vertices.min(0) - 20, mesh.vertices.max(0) + 20
    pts = rng.uniform(lo, hi, size=(300, 3))
    d = md.signed_distance(pts)
    brute = np.array([_closest_on_triangles(p, tri).min() for p in pts])
    inside = np.array([_winding(p, tri) > 0.5 for p in pts])
    np.testing.assert_allclose(np.abs(d), brute, atol=1e-9)
    assert np.array_equal(d < 0, inside)
    assert inside.sum() > 20  # the sample reaches inside


@requires_objects
def test_segment_distance_is_the_minimum_over_the_segment(bunny, rng):
    mesh, md = bunny
    lo, hi = mesh.vertices.min(0) - 20, mesh.vertices.max(0) + 20
    a = rng.uniform(lo, hi, size=(60, 3))
    b = a + rng.normal(scale=15.0, size=(60, 3))
    d = md.segment_distance(a, b)
    t = np.linspace(0, 1, 801)
    for i in range(len(a)):
        sampled = np.abs(md.signed_distance(a[i] + t[:, None] * (b[i] - a[i]))).min()
        seg = np.linalg.norm(b[i] - a[i])
        assert d[i] <= sampled + 1e-9  # a lower bound of every sample ...
        assert d[i] >= sampled - seg / 800 - 1e-9  # ... within the sampling step (1-Lipschitz)


@requires_objects
def test_long_segments_pruned_by_their_distance_to_each_box_lose_no_triangle(bunny, rng):
    """The traversal prunes a box by its distance to the segment (not to the segment's own
    box): the answer is still the minimum over every triangle, bit for bit."""
    from prehension.objects import segment_distance as D

    _, md = bunny
    m = md.arrays
    lo, hi = m.node_lo[0] - 30, m.node_hi[0] + 30
    pair = np.empty((2, 3))
    for _ in range(25):
        a = rng.uniform(lo, hi)
        b = a + rng.normal(size=3) / 1.0 * 80.0
        brute = min(D._segment_triangle_sq(a, b, m.tri[f, 0], m.tri[f, 1], m.tri[f, 2], np.empty(3)) for f in range(len(m.tri)))
        assert D.segment_distances(m, a[None], b[None])[0] == np.sqrt(brute)
        assert D.segment_closest(m, a, b, pair[0], pair[1]) == np.sqrt(brute)
        if brute > 0:
            assert np.linalg.norm(pair[0] - pair[1]) == pytest.approx(np.sqrt(brute), abs=1e-9)


@requires_objects
def test_bounded_segment_queries_are_the_unbounded_answer_below_the_bound(bunny, rng):
    """A search bounded by ``bound`` (the capsule depths search only up to the radius) gives
    the unbounded answer bit for bit when it is below the bound, and the bound otherwise."""
    from prehension.objects import segment_distance as D

    _, md = bunny
    m = md.arrays
    lo, hi = m.node_lo[0] - 20, m.node_hi[0] + 20
    pair, far = np.empty((2, 3)), 0
    for _ in range(40):
        a = rng.uniform(lo, hi)
        b = a + rng.normal(size=3) * 15.0
        exact = D._segment_query(m, a, b)
        for bound in (0.5 * np.sqrt(exact), np.sqrt(exact) + 1e-6, 2.0 * np.sqrt(exact) + 1.0):
            got = D.segment_query_within(m, a, b, bound * bound)
            assert got == (exact if exact < bound * bound else bound * bound)
            within = D.segment_closest_within(m, a, b, pair[0], pair[1], bound)
            assert within == (np.sqrt(exact) if exact < bound * bound else bound)
            far += exact >= bound * bound
    assert far >= 40  # both cases occur (the first bound is always below the distance)


def test_cube_distances_exact():
    import trimesh

    box = trimesh.creation.box(extents=(20.0, 20.0, 20.0))
    md = MeshDistance(box.vertices, box.faces)
    pts = np.array([[0, 0, 0], [15, 0, 0], [13, 14, 0], [0, 0, -9.5], [10, 10, 10]], float)
    np.testing.assert_allclose(md.signed_distance(pts), [-10, 5, np.hypot(3, 4), -0.5, 0], atol=1e-12)
    np.testing.assert_allclose(md.segment_distance([[12, -30, 0], [0, 0, 0]], [[12, 30, 0], [0, 0, 30]]), [2, 0], atol=1e-12)


def test_mesh_distance_pickles():
    import trimesh

    box = trimesh.creation.box(extents=(20.0, 20.0, 20.0))
    md = pickle.loads(pickle.dumps(MeshDistance(box.vertices, box.faces)))
    assert md.signed_distance([[0, 0, 20]])[0] == pytest.approx(10.0)


@requires_objects
def test_the_signed_distance_grid_is_within_its_spacing_of_the_exact_value(bunny, rng):
    """Trilinear on the grid: a convex combination of the cell's corner values, each within
    its distance from the point (sd is 1-Lipschitz), so within h sqrt(3) of the exact value;
    each node read holds the exact value at the node, whatever order the nodes were read in."""
    from prehension.solvers.local._sd_grid import grid_sd, grid_segment_min_sd, in_grid, new_sd_grid

    mesh, md = bunny
    m = md.arrays
    g = new_sd_grid(m)
    lo, hi = m.node_lo[0] - 15, m.node_hi[0] + 15
    pts = rng.uniform(lo, hi, size=(300, 3))
    grad = np.zeros(3)
    assert all(in_grid(g, p) for p in pts)
    approx = np.array([grid_sd(m, g, p, grad) for p in pts])
    exact = md.signed_distance(pts)
    assert np.all(np.abs(approx - exact) <= g.h * np.sqrt(3) + 1e-4)
    assert ((approx < 0) & (exact < -g.h * np.sqrt(3))).sum() > 10  # points well inside, read as inside
    filled = np.argwhere(~np.isnan(g.val))
    nodes = g.lo + g.h * filled[rng.choice(len(filled), 50, replace=False)]
    at = [tuple(((n - g.lo) / g.h).round().astype(int)) for n in nodes]
    np.testing.assert_allclose([g.val[a] for a in at], md.signed_distance(nodes), atol=1e-4)  # float32 storage
    assert not in_grid(g, m.node_hi[0] + 30.0)
    pair = np.zeros((2, 3))
    p0, p1 = pts[0], pts[0] + np.array([30.0, 0.0, 0.0])
    v = grid_segment_min_sd(m, g, p0, p1, pair)
    n = int(np.ceil(2.0 * 30.0 / g.h))  # its samples: at most half a spacing apart
    own = np.array([grid_sd(m, g, p0 + t * (p1 - p0), grad) for t in np.linspace(0, 1, n + 1)])
    assert v == pytest.approx(own.min(), abs=1e-12)
    # the trilinear function's slope is at most sqrt(3) (1-Lipschitz node values), and every
    # point of the segment lies within h/4 of a sample: dense samples are no lower than that
    ts = np.union1d(np.linspace(0, 1, 301), np.linspace(0, 1, n + 1))  # the samples among them
    dense = np.array([grid_sd(m, g, p0 + t * (p1 - p0), grad) for t in ts])
    assert dense.min() <= v + 1e-12 and v <= dense.min() + np.sqrt(3) * g.h / 4 + 1e-9
    assert abs(np.linalg.norm(pair[0] - pair[1]) - max(abs(v), 1e-6)) < 1e-9


def test_a_mesh_distance_has_one_grid_which_does_not_travel_with_it():
    """The local solver keeps one grid per mesh beside it (never on it): a pickled copy of
    the mesh gets its own, unfilled."""
    from prehension.objects.distance import MeshDistance
    from prehension.solvers.local._sd_grid import sd_grid_of

    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    md = MeshDistance(v, f)
    assert sd_grid_of(md) is sd_grid_of(md)
    assert sd_grid_of(md).val.dtype == np.float32 and np.isnan(sd_grid_of(md).val).all()
    sd_grid_of(md).val[0, 0, 0] = 1.0
    copy = pickle.loads(pickle.dumps(md))
    assert sd_grid_of(copy) is not sd_grid_of(md) and np.isnan(sd_grid_of(copy).val).all()
