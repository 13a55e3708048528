"""Posed scenes out (GLB, OBJ, PLY): re-read by trimesh, one named node per link and the object."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")

from prehension.cli import main  # noqa: E402
from prehension.cli.codes import EXIT_BAD_INPUT, EXIT_OK  # noqa: E402
from prehension.interop.scene import OBJECT_NODE, capsule_mesh, grasp_scene, scene_bytes  # noqa: E402
from prehension.results import read_result  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "quality" / "box-four-fingers.result.json"


@pytest.fixture(scope="module")
def example():
    task, data = read_result(EXAMPLE)
    entry = data["solutions"][0]
    q = np.array([entry["joint_angles_rad"][d] for d in task.hand.dof_names])
    return task, entry, q


def capsule_box(cap, T) -> tuple[np.ndarray, np.ndarray]:
    """The exact axis-aligned box of a capsule posed by T [mm]."""
    ends = np.array([cap.a, cap.b]) @ T[:3, :3].T + T[:3, 3]
    return ends.min(axis=0) - cap.radius, ends.max(axis=0) + cap.radius


def test_a_capsule_mesh_lies_on_its_capsule(sa_hand):
    for link in sa_hand.links:
        for cap in link.collision:
            mesh = capsule_mesh(cap)
            ab = cap.b - cap.a
            t = np.clip((mesh.vertices - cap.a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
            d = np.linalg.norm(mesh.vertices - (cap.a + t[:, None] * ab), axis=1)
            np.testing.assert_allclose(d, cap.radius, rtol=1e-9)


@pytest.mark.parametrize("units,scale", [("m", 1e-3), ("mm", 1.0)])
def test_a_glb_scene_reads_back_with_every_link_where_the_result_puts_it(example, units, scale):
    task, entry, q = example
    data = scene_bytes(grasp_scene(task, q, np.array(entry["T_palm_object"]), units), "glb")
    scene = trimesh.load(io.BytesIO(data), file_type="glb")
    with_shapes = {link.name for link in task.hand.links if link.collision}
    assert set(scene.graph.nodes_geometry) == with_shapes | {OBJECT_NODE}
    T_object_palm = np.linalg.inv(np.array(entry["T_palm_object"]))
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for link in task.hand.links:
        T = T_object_palm @ np.array(entry["link_poses"][link.name])  # what the result says [mm]
        if link.name in with_shapes:
            got, _ = scene.graph.get(link.name)
            np.testing.assert_allclose(got[:3, :3], T[:3, :3], atol=1e-9)
            np.testing.assert_allclose(got[:3, 3], T[:3, 3] * scale, atol=1e-9 * max(scale, 1e-3))
        for cap in link.collision:
            a, b = capsule_box(cap, T)
            lo, hi = np.minimum(lo, a), np.maximum(hi, b)
    obj = task.object.display_mesh().vertices
    lo, hi = np.minimum(lo, obj.min(axis=0)), np.maximum(hi, obj.max(axis=0))
    # the tessellated capsules lie within their capsules and reach them within 1% of a radius
    np.testing.assert_allclose(scene.bounds, np.array([lo, hi]) * scale, atol=0.3 * scale)
    object_geometry = scene.geometry[scene.graph[OBJECT_NODE][1]]
    np.testing.assert_allclose(object_geometry.bounds, np.array([obj.min(axis=0), obj.max(axis=0)]) * scale, atol=1e-9)


def test_obj_and_ply_hold_the_same_posed_geometry(example):
    task, entry, q = example
    scene = grasp_scene(task, q, np.array(entry["T_palm_object"]))
    glb = trimesh.load(io.BytesIO(scene_bytes(scene, "glb")), file_type="glb")
    obj_text = scene_bytes(scene, "obj").decode()
    names = [line[2:].strip() for line in obj_text.splitlines() if line.startswith("o ")]
    assert set(names) == set(glb.graph.nodes_geometry)  # one named object per link and the object
    for fmt in ("obj", "ply"):
        mesh = trimesh.load(io.BytesIO(scene_bytes(scene, fmt)), file_type=fmt, force="mesh")
        np.testing.assert_allclose(mesh.bounds, glb.bounds, atol=1e-9)


def test_the_export_command_writes_scenes_and_refuses_what_it_should(tmp_path):
    out = tmp_path / "grasp.glb"
    assert main(["export", str(EXAMPLE), "--format", "glb", "-o", str(out), "--stage", "pregrasp"]) == EXIT_OK
    assert set(trimesh.load(out).graph.nodes_geometry) >= {"palm", OBJECT_NODE}
    before = out.read_bytes()
    assert main(["export", str(EXAMPLE), "--format", "glb", "-o", str(out)]) == EXIT_BAD_INPUT  # exists: no --force
    assert out.read_bytes() == before
    assert main(["export", str(EXAMPLE), "--format", "glb", "-o", str(out), "--force", "--units", "mm"]) == EXIT_OK
    assert main(["export", str(EXAMPLE), "--format", "ply", "-o", str(tmp_path / "x.glb")]) == EXIT_BAD_INPUT  # suffix
    assert main(["export", str(EXAMPLE), "--format", "glb", "-o", str(tmp_path / "y.glb"), "--solution", "7"]) == EXIT_BAD_INPUT
    with pytest.raises(SystemExit):  # argparse names the valid formats
        main(["export", str(EXAMPLE), "--format", "stl", "-o", str(tmp_path / "z.stl")])
