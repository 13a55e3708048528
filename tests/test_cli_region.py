"""``prehension region`` and a task on a mesh file solved from the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import SHARED
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.geometry.regions import BezierRegion, PointRegion
from prehension.objects.meshes import Mesh
from prehension.objects.pick import region_from_mesh
from prehension.tasks.format.yaml_text import parse_yaml
from prehension.tasks.yaml_io import region_from_dict

BLOCK = SHARED / "objects" / "random" / "003.obj"
requires_objects = pytest.mark.skipif(not BLOCK.is_file(), reason="shared/objects not present beside the checkout")


def test_region_from_mesh_fits_a_sphere_outward():
    import trimesh

    ball = trimesh.creation.icosphere(subdivisions=5, radius=30.0)
    mesh = Mesh(ball.vertices, ball.faces)
    picked = region_from_mesh(mesh, at=(0, 0, 31), radius=10.0, degree=2)
    assert isinstance(picked.region, BezierRegion) and picked.region.patch.degree == (2, 2)
    assert picked.max_deviation_mm < 0.05  # a quadratic follows the sphere closely
    p, n = picked.region.evaluate(np.array([[0.5, 0.5], [0.1, 0.9]]))
    np.testing.assert_allclose(np.sum(p * n, axis=1) / np.linalg.norm(p, axis=1), 1.0, atol=1e-3)  # outward, radial
    flat = region_from_mesh(mesh, at=(0, 0, 31), radius=10.0, degree=1)
    assert flat.max_deviation_mm > 10 * picked.max_deviation_mm  # a plane cannot
    point = region_from_mesh(mesh, at=(0, 0, 31), radius=10.0, point=True)
    assert isinstance(point.region, PointRegion) and point.region.normal[2] > 0.999
    faces = region_from_mesh(mesh, faces=np.flatnonzero(ball.triangles_center[:, 2] > 27), degree=2)
    assert faces.max_deviation_mm < 0.5 and faces.normal[2] > 0.999  # the square's corners overhang the cap


def test_region_from_mesh_refuses_bad_requests():
    import trimesh

    from prehension.errors import InvalidObject

    box = trimesh.creation.box(extents=(20.0, 20.0, 20.0))
    mesh = Mesh(box.vertices, box.faces)
    with pytest.raises(InvalidObject, match=r"is 40 mm from the object.s outer surface, farther than the radius \(5 mm\)"):
        region_from_mesh(mesh, at=(0, 0, 50), radius=5.0)
    with pytest.raises(InvalidObject, match="degree must be an integer from 1 to 6"):
        region_from_mesh(mesh, at=(0, 0, 10), radius=5.0, degree=9)
    with pytest.raises(InvalidObject, match="give a surface point 'at' and a positive 'radius'"):
        region_from_mesh(mesh, at=(0, 0, 10))


@requires_objects
def test_cli_region_prints_a_snippet_that_reads_back(capsys):
    assert main(["region", str(BLOCK), "--at", "1,-13,30.4", "--radius", "2", "--degree", "1", "--scale", "10", "--name", "top"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "largest deviation from the mesh" in out
    region = region_from_dict(parse_yaml(out, "out")["top"], "out")
    assert isinstance(region, BezierRegion)
    assert main(["region", str(BLOCK), "--at", "1,-13,30.4", "--point", "--units", "cm"]) == EXIT_OK
    assert "point:" in capsys.readouterr().out
    assert main(["region", str(BLOCK), "--at", "1,2", "--radius", "2", "--scale", "10"]) == EXIT_BAD_INPUT
    assert "--at takes three numbers" in capsys.readouterr().err
    assert main(["region", str(BLOCK), "--at", "1,2,3", "--radius", "2"]) == EXIT_BAD_INPUT
    assert "a mesh file carries no units" in capsys.readouterr().err


PINCH = """\
prehension: task/1
name: pinch-003
hand: schunk-sa
object:
  name: block
  mesh: {mesh}
  scale: 10            # mm per file unit
  regions:
    top: {{bezier: [[[-0.01, -14.35, 30.31], [0.01, -11.6, 30.14]], [[2.73, -14.35, 30.58], [2.75, -11.6, 30.41]]]}}
    bottom: {{bezier: [[[-7.13, -13.18, -10.54], [-7.13, -10.58, -10.54]], [[-9.73, -13.18, -10.39], [-9.73, -10.58, -10.39]]]}}
contacts:
  - {{hand: thumb_tip, object: top}}
  - {{hand: index_tip, object: bottom}}
fingers: [thumb, index]
"""


@requires_objects
def test_a_task_on_a_mesh_file_in_14_lines_solves_from_the_cli(tmp_path, capsys):
    path = tmp_path / "pinch.yaml"
    path.write_text(PINCH.format(mesh=BLOCK), encoding="utf-8")
    assert len(path.read_text().splitlines()) <= 15
    out = tmp_path / "pinch.json"
    assert main(["solve", str(path), "--method", "local", "-o", str(out), "--quiet"]) == EXIT_OK
    data = json.loads(out.read_text())
    assert data["status"] == "solved" and data["solutions"][0]["worst"]["object_collision"] <= 0.5
    assert main(["check", str(out)]) == EXIT_OK


def test_a_pick_next_to_a_thin_walls_rim_keeps_its_own_side():
    """A 0.5 mm slab picked on its top face 1 mm from the rim (the rim and the bottom face
    within the radius): the patch is the top face's, normal +z, outward everywhere."""
    import trimesh

    slab = trimesh.creation.box(extents=(40.0, 40.0, 0.5))
    mesh = Mesh(slab.vertices, slab.faces)
    picked = region_from_mesh(mesh, at=(19.0, 0.0, 0.25), radius=4.0, degree=1)
    _, n = picked.region.evaluate(np.array([[0.5, 0.5], [0.0, 0.0], [1.0, 1.0]]))
    assert np.all(n[:, 2] > 0.999) and picked.max_angle_deg < 1.0


@requires_objects
def test_regions_picked_on_the_random_solids_never_point_into_them(rng):
    """Seeded picks on the five random solids (overlapping parts: internal walls, thin
    walls, edges): every region returned points out of the solid at every point of a 9 x 9
    grid (a step along its normal from the closest surface point leaves the solid); the
    others are refused with a message naming the reason."""
    from prehension.errors import InvalidObject
    from prehension.objects.distance import MeshDistance
    from prehension.objects.mesh_io import load_mesh

    returned = 0
    for path in sorted((SHARED / "objects" / "random").glob("*.obj")):
        mesh = load_mesh(path, 10.0)
        distance = MeshDistance(mesh.vertices, mesh.faces)
        tri = mesh.vertices[mesh.faces]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        for _ in range(12):
            at = rng.dirichlet([1, 1, 1]) @ tri[rng.choice(len(area), p=area / area.sum())]
            try:
                picked = region_from_mesh(mesh, at=at, radius=float(rng.choice([3.0, 6.0, 10.0])),
                                          degree=int(rng.integers(1, 4)), distance=distance)  # fmt: skip
            except InvalidObject as exc:
                assert any(w in str(exc) for w in ("points into the object", "covers the face", "outer surface", "too few surface samples"))
                continue
            returned += 1
            t = np.linspace(0, 1, 9)
            p, n = picked.region.evaluate(np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2))
            _, q = distance.signed_distance(p, closest=True)
            assert np.all(distance.signed_distance(q + 0.05 * n) > 0)
    assert returned >= 30
