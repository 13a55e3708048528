"""Scenes drawn with the hand file's link meshes (issue 31 item 3): a URDF hand with mesh
links (the shared Allegro) exported as GLB and re-read by trimesh has one named node per
link and the object, each link's visual mesh vertices posed where the result's link poses
put them; a hand without meshes, a changed hand file or ``--draw capsules`` draw capsules;
the meshes change nothing a solver or a checkpoint sees."""

from __future__ import annotations

import json
import pickle
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")
from scipy.spatial import cKDTree  # noqa: E402

from conftest import HANDS_DIR  # noqa: E402
from prehension.cli import main  # noqa: E402
from prehension.cli.codes import EXIT_OK  # noqa: E402
from prehension.hands.files import load_hand_file  # noqa: E402
from prehension.hands.link_meshes import _file_triangles, link_mesh_triangles  # noqa: E402
from prehension.interop.scene import OBJECT_NODE, hand_meshes  # noqa: E402
from prehension.results import read_result  # noqa: E402

ALLEGRO = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
requires_allegro = pytest.mark.skipif(not ALLEGRO.is_file(), reason="shared/hands not present beside the checkout")


def _task_text(hand_file: Path) -> str:
    """A forward-built Allegro task (three point contacts) with a sphere drawn as the object."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_cli_hands import _short_task

    text = _short_task(f"{{urdf: {hand_file}}}", load_hand_file(hand_file), np.random.default_rng(7), ("thumb", "index", "middle"))
    return text.replace("  name: points\n", "  name: points\n  display: {primitives: [{sphere: {center: [-175, -40, -110], radius: 20}}]}\n")


@pytest.fixture(scope="module")
def allegro_result(tmp_path_factory):
    if not ALLEGRO.is_file():
        pytest.skip("shared/hands not present beside the checkout")
    work = tmp_path_factory.mktemp("allegro")
    shutil.copytree(ALLEGRO.parent, work / "hand")
    task = work / "task.yaml"
    task.write_text(_task_text(work / "hand" / ALLEGRO.name))
    result = work / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK
    assert json.loads(result.read_text())["status"] == "solved"
    return result


def _origin(elem) -> np.ndarray:
    o = elem.find("origin")
    xyz = [0.0] * 3 if o is None else [float(x) for x in o.get("xyz", "0 0 0").split()]
    rpy = [0.0] * 3 if o is None else [float(x) for x in o.get("rpy", "0 0 0").split()]
    T = trimesh.transformations.euler_matrix(*rpy, axes="sxyz")  # URDF: fixed-axis roll, pitch, yaw
    T[:3, 3] = xyz
    return T


def _visual_vertices_m(urdf: Path) -> dict[str, list[np.ndarray]]:
    """Per URDF link, its visual meshes' vertices in the link frame [m], read independently
    of prehension (the URDF's origin and the file through trimesh)."""
    out: dict[str, list[np.ndarray]] = {}
    for link in ET.parse(urdf).getroot().findall("link"):
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            v = trimesh.load(urdf.parent / mesh.get("filename"), force="mesh", process=False).vertices
            T = _origin(visual)
            out.setdefault(link.get("name"), []).append(v @ T[:3, :3].T + T[:3, 3])
    return out


def _posed(node_scene, name: str) -> np.ndarray:
    T, geometry = node_scene.graph.get(name)
    v = node_scene.geometry[geometry].vertices
    return v @ T[:3, :3].T + T[:3, 3]


@requires_allegro
def test_a_glb_of_the_allegro_has_its_link_meshes_where_the_result_puts_the_links(allegro_result, tmp_path):
    out = tmp_path / "grasp.glb"
    assert main(["export", str(allegro_result), "--format", "glb", "-o", str(out)]) == EXIT_OK
    task, data = read_result(allegro_result)
    entry = data["solutions"][0]
    hand_file = Path(task.hand.source.path)
    scene = trimesh.load(out, file_type="glb")
    assert set(scene.graph.nodes_geometry) == set(task.hand.link_names) | {OBJECT_NODE}
    T_object_palm = np.linalg.inv(np.array(entry["T_palm_object"]))
    expected: dict[str, list[np.ndarray]] = {}
    for urdf_link, parts in _visual_vertices_m(hand_file).items():
        frame = task.hand.frames.get(urdf_link)
        link = frame.link if frame is not None else urdf_link
        T_link_u = np.eye(4) if frame is None else frame.T_link_frame
        T = T_object_palm @ np.array(entry["link_poses"][link]) @ T_link_u  # [mm]
        expected.setdefault(link, []).extend(1000.0 * v @ T[:3, :3].T + T[:3, 3] for v in parts)
    assert set(expected) == set(task.hand.link_names)  # every Allegro link has a visual mesh
    for link, parts in expected.items():
        want = np.concatenate(parts) / 1000.0  # the scene is in metres
        got = _posed(scene, link)
        assert len(got) == len(want), link
        # every vertex the file has is in the scene where the result puts it, and nothing else is
        # (within 0.1 um: glTF stores vertices as float32, ~1e-8 m at 0.1 m)
        assert cKDTree(got).query(want)[0].max() < 1e-7, link
        assert cKDTree(want).query(got)[0].max() < 1e-7, link
    sphere = _posed(scene, OBJECT_NODE)
    np.testing.assert_allclose(np.linalg.norm(sphere - np.array([-0.175, -0.040, -0.110]), axis=1), 0.020, rtol=0.02)


@requires_allegro
def test_capsules_are_drawn_when_asked_or_when_the_hand_file_changed(allegro_result, tmp_path, capsys):
    task, _ = read_result(allegro_result)
    meshes, why = hand_meshes(task.hand)
    assert set(meshes) == set(task.hand.link_names) and why == ""
    capsys.readouterr()
    out = tmp_path / "caps.glb"
    assert main(["export", str(allegro_result), "--format", "glb", "-o", str(out), "--draw", "capsules"]) == EXIT_OK
    assert "links drawn as capsules" in " ".join(capsys.readouterr().out.split())
    scene = trimesh.load(out, file_type="glb")
    for link in task.hand.links:  # each vertex on one of the link's capsules, none of its visual mesh
        v = 1000.0 * scene.geometry[scene.graph.get(link.name)[1]].vertices  # link frame [mm]
        off = []
        for c in link.collision:
            ab = c.b - c.a
            t = np.clip((v - c.a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
            off.append(np.abs(np.linalg.norm(v - (c.a + t[:, None] * ab), axis=1) - c.radius))
        assert np.min(off, axis=0).max() < 1e-4, link.name  # mm; float32 in the file
    hand_file = Path(task.hand.source.path)
    moved = hand_file.with_suffix(".moved")
    hand_file.rename(moved)
    try:
        meshes, why = hand_meshes(task.hand)
        assert meshes == {} and "missing or changed" in why
        assert main(["export", str(allegro_result), "--format", "obj", "-o", str(tmp_path / "x.obj")]) == EXIT_OK
        assert "missing or changed" in " ".join(capsys.readouterr().out.split())
    finally:
        moved.rename(hand_file)


@requires_allegro
def test_the_link_meshes_change_neither_the_capsules_nor_the_task_fingerprint(allegro_result):
    from dataclasses import replace

    from prehension.solvers.complete.checkpoint import _task_digest

    hand = load_hand_file(ALLEGRO)
    assert all(link.meshes for link in hand.links)
    bare = replace(hand, links=tuple(replace(link, meshes=()) for link in hand.links))
    task, _ = read_result(allegro_result)
    assert _task_digest(replace(task, hand=hand)) == _task_digest(replace(task, hand=bare))
    again = pickle.loads(pickle.dumps(hand))  # what a worker receives: the references, not the files
    for a, b in zip(hand.links, again.links):
        assert [m.path for m in a.meshes] == [m.path for m in b.meshes]
        for m, n in zip(a.meshes, b.meshes):
            np.testing.assert_array_equal(m.T_link_mesh, n.T_link_mesh)
        np.testing.assert_array_equal([c.radius for c in a.collision], [c.radius for c in b.collision])
    assert len(pickle.dumps(hand)) < 2 * len(pickle.dumps(bare))  # no vertices travel


@requires_allegro
def test_a_link_mesh_is_read_once_and_again_when_its_file_changes(tmp_path):
    shutil.copytree(ALLEGRO.parent, tmp_path / "hand")
    hand = load_hand_file(tmp_path / "hand" / ALLEGRO.name)
    mesh = hand.links[1].meshes[0]
    v1, f1 = link_mesh_triangles(mesh)
    hits = _file_triangles.cache_info().hits
    assert np.array_equal(link_mesh_triangles(mesh)[0], v1) and _file_triangles.cache_info().hits == hits + 1
    box = trimesh.creation.box(extents=(0.01, 0.02, 0.03))
    box.export(mesh.path)  # the file changes under the same name
    v2, f2 = link_mesh_triangles(mesh)
    assert len(f2) == 12 and np.ptp(v2 @ mesh.T_link_mesh[:3, :3], axis=0) == pytest.approx([10, 20, 30])
    Path(mesh.path).unlink()
    with pytest.raises(ValueError, match="not found|no such|does not exist"):
        link_mesh_triangles(mesh)
