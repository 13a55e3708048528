"""The viewer draws a hand with mesh files as those meshes: `view` and `render` of a result
of the shared Allegro URDF put each link's visual mesh where the result puts the link, keep
the collision capsules (what every check judges) in a layer of their own, hidden at first,
draw the pre-grasp and squeeze hands the same way, paint a link into the object red, and fall
back to capsules -- saying why -- with ``--draw capsules``, a moved hand file or an
unreadable mesh."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trimesh")
from scipy.spatial import cKDTree  # noqa: E402

from prehension.cli import main  # noqa: E402
from prehension.cli.codes import EXIT_OK  # noqa: E402
from prehension.hands.link_meshes import link_mesh_triangles  # noqa: E402
from prehension.results import read_result  # noqa: E402
from prehension.tasks.format.hand_files import hand_meshes  # noqa: E402
from prehension.viewer import build_hand_scene, build_scene, load_grasp  # noqa: E402
from prehension.viewer import model as S  # noqa: E402
from prehension.viewer.grasp import link_poses  # noqa: E402
from prehension.viewer.layers import hand_drawing, hand_layer  # noqa: E402
from test_interop_scene_meshes import ALLEGRO, allegro_result, requires_allegro  # noqa: E402,F401 (a fixture)


def _vertices(layer) -> np.ndarray:
    return np.concatenate([m.vertices_mm for m in layer.meshes])


def _expected_link_vertices(task, link_poses: dict) -> np.ndarray:
    """Every vertex of every link's mesh files, placed by the result's link poses [mm]."""
    meshes, why = hand_meshes(task.hand)
    assert why == "" and set(meshes) == set(task.hand.link_names)
    parts = []
    for name, files in meshes.items():
        T = np.asarray(link_poses[name])
        parts += [link_mesh_triangles(m)[0] @ T[:3, :3].T + T[:3, 3] for m in files]
    return np.concatenate(parts)


@requires_allegro
def test_the_hand_is_drawn_as_its_link_meshes_where_the_result_puts_the_links(allegro_result):
    task, data = read_result(allegro_result)
    scene = build_scene(*_grasp(allegro_result))
    got, want = _vertices(scene.layer("hand")), _expected_link_vertices(task, data["solutions"][0]["link_poses"])
    assert len(got) == len(want)
    assert cKDTree(got).query(want)[0].max() < 1e-9 and cKDTree(want).query(got)[0].max() < 1e-9
    assert not any(m.closed for m in scene.layer("hand").meshes)  # a file's mesh may be open: drawn two-sided
    capsules = scene.layer("capsules")
    assert not capsules.visible and capsules.stage is None and all(m.closed for m in capsules.meshes)
    placed = build_scene(*_grasp(allegro_result), draw="capsules")
    np.testing.assert_array_equal(_vertices(capsules), _vertices(placed.layer("hand")))
    assert "capsules" not in {l.key for l in placed.layers}
    assert any("link meshes" in e.label for e in scene.legend)
    assert any("the checks judge the collision capsules" in line for line in scene.caption)


@requires_allegro
def test_the_stages_are_drawn_as_link_meshes_too(allegro_result):
    loaded = load_grasp(str(allegro_result), None)
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    assert loaded.pose.stages, "the result stores its pre-grasp and squeeze"
    for stage in loaded.pose.stages:
        want = _expected_link_vertices(loaded.task, link_poses(loaded.task, stage.q))
        got = _vertices(scene.layer(f"hand_{stage.name}"))
        assert len(got) == len(want) and cKDTree(got).query(want)[0].max() < 1e-9, stage.name


@requires_allegro
def test_a_link_into_the_object_is_drawn_red_as_its_mesh(allegro_result):
    task, data = read_result(allegro_result)
    poses = {k: np.asarray(v) for k, v in data["solutions"][0]["link_poses"].items()}
    drawing = hand_drawing(task.hand, hand_meshes(task.hand)[0])
    link = task.hand.link_names[3]
    layer = hand_layer(task.hand, poses, {link: 2.0}, drawing)
    red = [m for m in layer.meshes if m.color == S.PENETRATION_COLOR]
    assert len(red) == 1
    want = drawing.shapes[link].transformed(poses[link]).vertices
    np.testing.assert_array_equal(red[0].vertices_mm, want)


@requires_allegro
def test_view_and_render_draw_meshes_or_capsules_and_say_why_not(allegro_result, tmp_path, capsys):
    page = tmp_path / "g.html"
    assert main(["view", str(allegro_result), "-o", str(page)]) == EXIT_OK
    assert {"hand", "capsules", "object"} <= _page_layer_keys(page)
    assert main(["view", str(allegro_result), "-o", str(tmp_path / "c.html"), "--draw", "capsules"]) == EXIT_OK
    assert "capsules" not in _page_layer_keys(tmp_path / "c.html")
    pytest.importorskip("matplotlib")
    assert main(["render", str(allegro_result), "-o", str(tmp_path / "g.png"), "--layers", "capsules,object"]) == EXIT_OK
    assert (tmp_path / "g.png").stat().st_size > 5000
    task, _ = read_result(allegro_result)
    hand_file = Path(task.hand.source.path)
    moved = hand_file.with_suffix(".moved")
    hand_file.rename(moved)
    try:
        scene = build_scene(*_grasp(allegro_result))
    finally:
        moved.rename(hand_file)
    assert "capsules" not in {l.key for l in scene.layers}
    assert any("missing or changed" in line for line in scene.caption)


@requires_allegro
def test_an_unreadable_mesh_leaves_its_link_drawn_as_capsules_saying_so(allegro_result, tmp_path):
    task, _ = read_result(allegro_result)
    meshes, _ = hand_meshes(task.hand)
    link = task.hand.link_names[2]
    broken = tmp_path / "broken.obj"
    broken.write_text("this is not a mesh\n")
    meshes = {**meshes, link: tuple(replace(m, path=str(broken)) for m in meshes[link])}
    drawing = hand_drawing(task.hand, meshes)
    assert drawing.drawn[link] == "capsules" and drawing.meshed
    assert link in drawing.note and "cannot be read" in drawing.note
    hand = build_hand_scene(task.hand)  # a hand alone: meshes from its file
    assert "capsules" in {l.key for l in hand.layers} and any("link meshes" in e.label for e in hand.legend)


def test_a_hand_without_mesh_files_is_drawn_as_before():
    from prehension import load_builtin_task

    task = load_builtin_task("teapot-lid-lifting")
    scene = build_scene(task)
    assert "capsules" not in {l.key for l in scene.layers}
    assert all(m.closed for m in scene.layer("hand").meshes)
    assert any("collision capsules" in e.label for e in scene.legend)
    with pytest.raises(Exception, match="draw must be one of meshes, capsules"):
        build_scene(task, draw="wire")


def _grasp(result_file):
    loaded = load_grasp(str(result_file), None)
    return loaded.task, loaded.pose


def _page_layer_keys(page: Path) -> set[str]:
    """The layer keys of a page's inlined scene data (``scene_to_dict``)."""
    return set(re.findall(r'"key":"([a-z_]+)"', page.read_text()))
