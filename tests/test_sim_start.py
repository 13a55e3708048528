"""Where the physics test starts: the object's convex pieces lie on the solver's mesh next
to the hand, the initial penetration is split into the hand's own and the object's
approximation error, the coarse decomposition is cached, and an open mesh is refused."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

import prehension.sim.pieces as pieces_module
from prehension.errors import PrehensionError
from prehension.objects.distance import MeshDistance
from prehension.objects.meshes import Mesh
from prehension.objects.model import GraspObject
from prehension.quality.solid import Solid, hull_mesh, mass_properties
from prehension.sim import SimOptions, convex_pieces, simulate_grasp
from prehension.sim.pieces import decompose, refine, solid_pieces
from prehension.sim.start import APPROXIMATION_MM, _strays, solver_distance
from prehension.solve import solve
from prehension.tasks.library import load_builtin_task

QUICK = SimOptions(hold_s=0.2, squeeze_s=0.04)


def _volume(meshes) -> float:
    return mass_properties(Solid(tuple(meshes), (True,) * len(meshes), "pieces")).volume_mm3


def _local_grasp(name):
    task = load_builtin_task(name)
    result = solve(task, "local")
    assert result.success
    s = result.solutions[0]
    return task, SimpleNamespace(q=np.asarray(s.q, float), T_palm_object=np.asarray(s.T_palm_object, float), contacts=s.contacts)


@pytest.fixture(scope="module")
def guitar_tuning():
    return _local_grasp("guitar-tuning")


def test_the_guitar_starts_where_the_solver_says():
    """The coarse pieces stray off the mesh next to the hand (they fill the guitar's concavity:
    next to the local solver's answer of guitar-holding 16 mm; of guitar-tuning more than
    10 mm under the palm before 2026-11-27, 3.7 mm then, 0.7 mm since the seeing steps
    changed, its answer elsewhere), by more than the approximation allowed; refined, what
    MuJoCo sees at the start is the hand's own penetration."""
    task, grasp = _local_grasp("guitar-holding")
    coarse = [p for p, _ in solid_pieces(task.object)]
    strays = _strays(mujoco, task, grasp.T_palm_object, grasp.q, coarse, QUICK, solver_distance(task))
    assert max(strays.values()) > 4 * APPROXIMATION_MM
    report = simulate_grasp(task, grasp, QUICK)
    assert report.approximation_mm <= APPROXIMATION_MM
    assert report.object_pieces > len(coarse)
    assert report.hand_penetration_mm is not None and report.hand_penetration_mm <= 0.5  # the solver's answer is clear
    assert report.initial_penetration_mm <= report.hand_penetration_mm + APPROXIMATION_MM + 0.05
    assert report.initial_penetration_mm <= 1.0


def test_refined_pieces_lie_inside_the_solid_and_cover_its_part(rng):
    """Property over seeded picks of the guitar's coarse pieces: every refined piece's corners
    lie on or inside the solver's mesh, the pieces are convex, and they hold at least the
    exact part of the solid inside the piece they replace (and no more than that piece)."""
    task = load_builtin_task("guitar-playing")
    distance = task.object.distance
    pairs = solid_pieces(task.object)
    for k in rng.choice(len(pairs), size=min(3, len(pairs)), replace=False):
        piece, source = pairs[k]
        finer = refine(source, piece)
        assert finer, "the piece holds part of the solid"
        for part in finer:
            assert distance.signed_distance(part.vertices).max() <= 1e-3
            assert hull_mesh(part.vertices).faces.shape == part.faces.shape  # its own hull: convex
        exact = pieces_module._manifold(source) ^ pieces_module._to_manifold(piece)
        assert _volume(finer) >= exact.volume() * (1 - 1e-4)
        assert _volume(finer) <= _volume([piece]) * (1 + 1e-4)


def test_the_hand_penetration_is_measured_against_the_solvers_mesh(guitar_tuning):
    """The grasp moved 6 mm towards the palm: the hand's own penetration grows by what the
    move pushes it in, measured on the mesh, not on the pieces."""
    task, grasp = guitar_tuning
    T = grasp.T_palm_object.copy()
    normal = np.asarray(grasp.contacts[0].object_normal, float)
    T[:3, 3] += 6.0 * normal  # the first contact's finger sinks 6 mm along the normal
    report = simulate_grasp(task, SimpleNamespace(q=grasp.q, T_palm_object=T, contacts=grasp.contacts), QUICK)
    assert 5.0 <= report.hand_penetration_mm <= report.initial_penetration_mm + APPROXIMATION_MM + 0.1
    assert report.approximation_mm <= APPROXIMATION_MM


def test_the_decomposition_is_read_back_from_the_geometry_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("PREHENSION_CACHE_DIR", str(tmp_path))
    mesh = load_builtin_task("scalpel-handling").object.surface
    first = decompose(mesh)
    assert list(tmp_path.glob("*.npz"))

    def refuse(*args, **kwargs):
        raise AssertionError("decomposed again instead of reading the cache")

    import coacd

    monkeypatch.setattr(coacd, "run_coacd", refuse)
    again = decompose(mesh)
    assert len(again) == len(first)
    for a, b in zip(first, again):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    with pytest.raises(AssertionError, match="decomposed again"):
        decompose(Mesh(mesh.vertices * 2.0, mesh.faces))  # another mesh: another entry


def test_an_open_mesh_is_refused_not_decomposed(tmp_path):
    """A box without its top: refused with the reason before CoACD sees it."""
    v = np.array([(x, y, z) for x in (0, 10) for y in (0, 10) for z in (0, 10)], float)
    quads = [(0, 1, 3, 2), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]  # no (4, 6, 7, 5)
    lines = ["OFF", f"8 {len(quads)} 0"] + [" ".join(map(str, p)) for p in v] + [f"4 {a} {b} {c} {d}" for a, b, c, d in quads]
    (tmp_path / "open.off").write_text("\n".join(lines))
    obj = GraspObject("cup", {}, (), str(tmp_path / "open.off"))
    with pytest.raises(PrehensionError, match=r"needs a closed solid.*open \(4 edges"):
        convex_pieces(obj)


def test_a_large_mesh_is_simplified_within_its_tolerance_before_decomposing(monkeypatch, tmp_path):
    """Above SIMPLIFY_ABOVE triangles CoACD gets fewer, and the pieces stay within the
    stated tolerance of the mesh (plus CoACD's own filling of concavities, none on a sphere)."""
    import trimesh

    monkeypatch.setenv("PREHENSION_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(pieces_module, "SIMPLIFY_ABOVE", 1000)
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=40.0)  # 5120 triangles
    mesh = Mesh(sphere.vertices, sphere.faces)
    import coacd

    seen = []
    real = coacd.run_coacd
    monkeypatch.setattr(coacd, "run_coacd", lambda m, **kw: seen.append(len(m.indices)) or real(m, **kw))
    parts = decompose(mesh)
    assert seen and seen[0] < len(mesh.faces) / 2
    tolerance = pieces_module.SIMPLIFY_FRACTION * np.linalg.norm(np.ptp(mesh.vertices, axis=0))
    sd = MeshDistance(mesh.vertices, mesh.faces).signed_distance(np.concatenate([p.vertices for p in parts]))
    assert np.abs(sd).max() <= tolerance + 1e-6
