"""The viewer: scene building, the self-contained HTML page, the PNG, and the two commands."""

from __future__ import annotations

import dataclasses
import json
import re
import sys

import numpy as np
import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.hands.model import Capsule
from prehension.results import read_result, write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solve import solve
from prehension.tasks.library import builtin_task_names, load_builtin_task
from prehension.tasks.model import Configuration
from prehension.tessellation import REGION_LIFT_MM, capsule_mesh, region_mesh, region_solid
from prehension.viewer import build_scene, load_grasp, scene_to_html, write_html
from prehension.viewer.grasp import reference_angles
from prehension.viewer.model import BACKGROUND
from tiny_tasks import pincer_task


@pytest.fixture(scope="module")
def solved():
    """A solved built-in task (local solver, about a second)."""
    result = solve(load_builtin_task("teapot-lid-lifting"), "local")
    assert result.success
    return result


@pytest.fixture(scope="module")
def result_file(solved, tmp_path_factory):
    path = tmp_path_factory.mktemp("viewer") / "lid.json"
    write_result(solved, path, quality_entries(solved), approach_entries_of(solved))
    return path


@pytest.fixture(scope="module")
def infeasible_file(tmp_path_factory):
    """A result file without a solution: the pincer cannot span 60 mm (proven, complete solver)."""
    result = solve(pincer_task(60.0), "complete")
    assert result.status == "infeasible"
    path = tmp_path_factory.mktemp("viewer") / "pincer.json"
    write_result(result, path, quality_entries(result), approach_entries_of(result))
    return path


def _rows(points: np.ndarray) -> set:
    return {tuple(p) for p in np.round(points, 6)}


# -- scene ------------------------------------------------------------------------------
def test_capsule_mesh_is_closed_and_outward():
    capsule = Capsule([0, 0, 0], [30, 10, 5], 6.0)
    mesh = capsule_mesh(capsule)
    v, f = mesh.vertices, mesh.faces
    volume = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6
    exact = np.pi * 6**2 * np.linalg.norm([30, 10, 5]) + 4 / 3 * np.pi * 6**3
    assert 0.93 * exact < volume < exact  # positive: outward; inscribed polygon: a bit less
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)  # watertight


def test_every_link_of_the_sa_hand_is_drawn_where_the_solution_puts_it(solved):
    sol = solved.solutions[0]
    scene = build_scene(solved.task, sol)
    drawn = _rows(np.concatenate([m.vertices_mm for m in scene.layer("hand").meshes]))
    hand = solved.task.hand
    assert len(hand.links) == 14
    for link in hand.links:
        assert link.collision, link.name
        for capsule in link.collision:
            placed = capsule_mesh(capsule).transformed(sol.link_poses[link.name]).vertices
            assert _rows(placed) <= drawn, link.name


def test_contact_points_are_the_result_files(result_file):
    loaded = load_grasp(result_file)
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    stored = json.loads(result_file.read_text())["solutions"][0]["contacts"]
    layer = scene.layer("contacts")
    assert len(layer.points) == len(stored) == 2
    for dots, arrows, c in zip(layer.points, layer.arrows[::2], stored):
        np.testing.assert_allclose(dots.points_mm, [c["hand_point"], c["object_point"]], atol=1e-12)
        np.testing.assert_allclose(arrows.origins_mm[0], c["hand_point"], atol=1e-12)
        direction = arrows.vectors_mm[0] / np.linalg.norm(arrows.vectors_mm[0])
        np.testing.assert_allclose(direction, c["hand_normal"], atol=1e-9)
    assert scene.status == "solved" and "solution 1 of 1" in scene.title
    assert "max contact residual" in scene.caption[0]


def test_object_regions_lie_on_the_placed_object(solved):
    sol = solved.solutions[0]
    task = solved.task
    scene = build_scene(task, sol)
    meshes = scene.layer("object_regions").meshes
    assert len(meshes) == len(task.object.regions) == 2
    T = sol.T_palm_object
    for mesh, region in zip(meshes, task.object.regions.values()):
        expected = region_mesh(region).vertices @ T[:3, :3].T + T[:3, 3]
        np.testing.assert_allclose(mesh.vertices_mm, expected, atol=1e-9)
        points, normals = region.evaluate(np.array([[0.5, 0.5]]))
        centre = points[0] @ T[:3, :3].T + T[:3, 3]
        assert np.min(np.linalg.norm(mesh.vertices_mm - centre, axis=1)) <= REGION_LIFT_MM + 1e-9
    # Contact colours pair each hand region with its object region.
    hand_colors = [m.color for m in scene.layer("hand_regions").meshes]
    assert hand_colors == [m.color for m in meshes] and len(set(hand_colors)) == 2


def test_a_configuration_gives_the_same_contacts_as_its_solution(solved):
    sol = solved.solutions[0]
    scene = build_scene(solved.task, Configuration(sol.q, sol.T_palm_object))
    for dots, c in zip(scene.layer("contacts").points, sol.contacts):
        np.testing.assert_allclose(dots.points_mm[0], c.hand_point, atol=1e-6)


def test_a_task_alone_shows_the_reference_pose_with_the_object_beside_the_hand():
    task = load_builtin_task("teapot-lid-lifting")
    scene = build_scene(task)
    assert scene.status == "reference" and "reference pose" in scene.title
    hand_pts = scene.layer("hand").all_points_mm()
    object_pts = scene.layer("object").all_points_mm()
    assert object_pts[:, 0].min() > hand_pts[:, 0].max()  # beside, along the palm's +x
    q = reference_angles(task)
    assert np.all((task.hand.lower <= q) & (q <= task.hand.upper))
    layer = scene.layer("contacts")  # region centres joined by dashed lines, no contact made
    assert len(layer.lines) == len(task.contacts) and all(l.dashed for l in layer.lines)


def test_shapeless_links_are_drawn_as_segments_between_joint_centres():
    task = pincer_task(30.0)
    scene = build_scene(task)
    hand = scene.layer("hand")
    assert not hand.meshes and len(hand.lines) == 2  # palm -> j1, prox -> j2
    np.testing.assert_allclose(hand.lines[0].points_mm, [[0, 0, 0], [0, 0, 50]], atol=1e-12)
    assert not scene.layer("object").meshes  # no display mesh: only the two point regions
    assert len(scene.layer("object_regions").meshes) == 2


@pytest.mark.parametrize("name", builtin_task_names())
def test_every_builtin_task_builds_a_page_of_reasonable_size(name):
    scene = build_scene(load_builtin_task(name))
    assert {l.key for l in scene.layers} == {"hand", "object", "hand_regions", "pads", "object_regions", "contacts", "frames"}
    assert scene.layer("object").meshes and scene.layer("hand_regions").meshes
    assert len(scene_to_html(scene)) < 3_000_000


# -- HTML -------------------------------------------------------------------------------
def _scene_json(page: str) -> dict:
    match = re.search(r'<script type="application/json" id="scene-data">(.*?)</script>', page, re.S)
    return json.loads(match.group(1))


def test_the_page_is_self_contained(solved):
    page = scene_to_html(build_scene(solved.task, solved.solutions[0]))
    lowered = page.lower()
    for external in ("http://", "https://", "src=", "<link", "@import", "url(", "fetch(", "xmlhttprequest", "//cdn"):
        assert external not in lowered, external
    for placeholder in ("__TITLE__", "__VIEWER_JS__", "__SCENE_JSON__"):
        assert placeholder not in page
    data = _scene_json(page)
    assert [l["key"] for l in data["layers"]][:2] == ["hand", "object"]
    assert data["lighting"]["background"] == BACKGROUND
    vertices = np.array(data["layers"][0]["meshes"][0]["v"])
    assert np.allclose(vertices * 100, np.round(vertices * 100))  # rounded to 0.01 mm


def test_text_in_the_page_cannot_close_its_script(solved):
    scene = build_scene(solved.task, solved.solutions[0])
    scene = dataclasses.replace(scene, title="</script><script>alert(1)</script>", caption=("<!-- x",))
    page = scene_to_html(scene)
    assert page.count("</script>") == 3  # error capture, scene data, viewer
    assert _scene_json(page)["title"] == scene.title


def test_write_html_replaces_atomically(solved, tmp_path):
    path = tmp_path / "grasp.html"
    path.write_text("old")
    write_html(build_scene(solved.task, solved.solutions[0]), path)
    assert path.read_text().startswith("<!DOCTYPE html>")
    assert [p.name for p in tmp_path.iterdir()] == ["grasp.html"]


# -- command line -----------------------------------------------------------------------
def test_view_a_result_and_a_task(result_file, tmp_path, capsys):
    out = tmp_path / "lid.html"
    assert main(["view", str(result_file), "-o", str(out)]) == EXIT_OK
    assert "solved" in capsys.readouterr().out and out.stat().st_size > 10_000
    assert main(["view", "scalpel-handling", "-o", str(tmp_path / "task.html")]) == EXIT_OK
    assert "reference pose" in _scene_json((tmp_path / "task.html").read_text())["title"]


def test_a_result_without_a_solution_is_viewed_as_its_task(infeasible_file, tmp_path):
    out = tmp_path / "pincer.html"
    assert main(["view", str(infeasible_file), "-o", str(out)]) == EXIT_OK
    data = _scene_json(out.read_text())
    assert data["status"] == "infeasible" and "infeasible" in data["title"] and "showing the task" in data["title"]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["view", "missing.json"], "result file not found: missing.json"),
        (["view", "no-such-task"], "'no-such-task' is neither a built-in task"),
        (["view", "teapot-lid-lifting", "--solution", "1"], "--solution picks a solution of a result file"),
        (["view", "RESULT", "--solution", "1"], "--solution 1 is out of range: the result holds 1 solution(s)"),
        (["view", "RESULT", "--solution", "-1"], "--solution -1 is out of range"),
        (["view", "INFEASIBLE", "--solution", "0"], "the result holds no solution (status infeasible)"),
        (["view", "NOT_A_RESULT"], "not a prehension result file"),
        (["view", "MALFORMED"], "solution 0 of the result is malformed or from a different task: missing 'thumb_distal'"),
        (["view", "teapot-lid-lifting", "-o", "/no/such/folder/x.html"], "folder /no/such/folder does not exist"),
        (["render", "RESULT", "--size", "big"], "--size must be WIDTHxHEIGHT"),
        (["render", "RESULT", "--layers", "hand,wings"], "unknown layer(s) wings"),
    ],
)
def test_bad_input_is_exit_2_with_a_message(argv, message, result_file, infeasible_file, tmp_path, capsys):
    not_a_result = tmp_path / "other.json"
    not_a_result.write_text('{"prehension": "task/1"}')
    malformed = tmp_path / "malformed.json"
    data = json.loads(result_file.read_text())
    del data["solutions"][0]["link_poses"]["thumb_distal"]
    malformed.write_text(json.dumps(data))
    files = {"RESULT": result_file, "INFEASIBLE": infeasible_file, "NOT_A_RESULT": not_a_result, "MALFORMED": malformed}
    argv = [str(files.get(a, a)) for a in argv]
    if argv[0] == "render" and "-o" not in argv:
        argv += ["-o", str(tmp_path / "x.png")]
    assert main(argv) == EXIT_BAD_INPUT
    assert message in " ".join(capsys.readouterr().err.split())


def test_load_grasp_picks_the_requested_solution(result_file):
    task, data = read_result(result_file)
    loaded = load_grasp(result_file, 0)
    assert loaded.task.name == task.name and loaded.pose.note.startswith("solution 1 of 1")
    np.testing.assert_allclose(loaded.pose.T_palm_object, data["solutions"][0]["T_palm_object"])
    with pytest.raises(PrehensionError, match="out of range"):
        load_grasp(result_file, 5)


# -- PNG --------------------------------------------------------------------------------
def test_render_writes_a_picture_that_is_not_blank(result_file, tmp_path, capsys):
    image = pytest.importorskip("matplotlib.image")
    out = tmp_path / "lid.png"
    assert main(["render", str(result_file), "-o", str(out), "--size", "360x280", "--azim", "50"]) == EXIT_OK
    assert "360x280" in capsys.readouterr().out
    pixels = image.imread(out)[..., :3]
    assert pixels.shape == (280, 360, 3)
    background = np.array([int(BACKGROUND[i : i + 2], 16) for i in (1, 3, 5)]) / 255
    differs = np.abs(pixels - background).max(axis=2) > 8 / 255
    assert differs.mean() > 0.08
    assert len(np.unique(np.round(pixels[differs] * 31), axis=0)) > 40  # shaded: many colours


def test_render_without_matplotlib_says_what_to_install(result_file, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # "import matplotlib" now fails
    assert main(["render", str(result_file), "-o", str(tmp_path / "x.png")]) == EXIT_BAD_INPUT
    assert 'pip install "prehension[plot]"' in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_a_hand_alone_can_be_viewed(tmp_path, capsys):
    """`view HAND` / `render HAND`: a built-in hand or a hand file, with its regions."""
    from prehension.cli import EXIT_OK, main
    from prehension.hands.sa_hand import schunk_sa_hand
    from prehension.viewer import build_hand_scene

    scene = build_hand_scene(schunk_sa_hand())
    keys = [layer.key for layer in scene.layers]
    assert keys == ["hand", "hand_regions", "frames"]
    assert len(scene.layers[1].meshes) == len(schunk_sa_hand().regions)
    assert "thumb" in scene.caption[0] and "thumb_tip" in scene.caption[0]
    out = tmp_path / "sa.html"
    assert main(["view", "sa", "-o", str(out)]) == EXIT_OK
    assert "schunk-sa" in out.read_text()


def test_a_region_kind_the_scene_does_not_know_is_drawn_as_nothing_and_has_no_solid():
    from prehension.geometry.regions import Region

    class Blob(Region):
        pass

    assert region_mesh(Blob()).faces.shape == (0, 3)
    with pytest.raises(TypeError, match="Blob"):
        region_solid(Blob())


# -- stages: pre-grasp, grasp, squeeze ----------------------------------------------------
def test_the_stored_pre_grasp_and_squeeze_are_drawn_at_their_angles(result_file):
    from prehension.viewer.grasp import link_poses

    loaded = load_grasp(result_file)
    stored = json.loads(result_file.read_text())["solutions"][0]
    task = loaded.task
    assert [s.name for s in loaded.pose.stages] == ["pregrasp", "squeeze"]
    scene = build_scene(task, loaded.pose, status=loaded.status)
    assert [key for key, _ in scene.stages] == ["pregrasp", "grasp", "squeeze"] and scene.stage == "grasp"
    for name in ("pregrasp", "squeeze"):
        q = np.array([stored[name]["joint_angles_rad"][d] for d in task.hand.dof_names])
        layer = scene.layer(f"hand_{name}")
        assert layer.stage == name and not layer.visible
        drawn = _rows(np.concatenate([m.vertices_mm for m in layer.meshes]))
        poses = link_poses(task, q)
        for link in task.hand.links:
            for capsule in link.collision:
                assert _rows(capsule_mesh(capsule).transformed(poses[link.name]).vertices) <= drawn, (name, link.name)
    hand = _rows(np.concatenate([m.vertices_mm for m in scene.layer("hand").meshes]))
    assert hand != _rows(np.concatenate([m.vertices_mm for m in scene.layer("hand_pregrasp").meshes]))  # the fingers moved
    assert "backed off 15 mm" in dict(scene.stages)["pregrasp"] and "push 10 mm" in dict(scene.stages)["squeeze"]


def test_one_stage_is_shown_at_a_time(result_file):
    from prehension.viewer.stages import with_stage

    loaded = load_grasp(result_file)
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    shown = lambda s: {l.key for l in s.layers if l.visible and l.stage is not None}  # noqa: E731
    assert shown(scene) == {"hand", "hand_regions", "pads"} & {l.key for l in scene.layers}
    assert shown(with_stage(scene, "pregrasp")) == {"hand_pregrasp"}
    assert shown(with_stage(scene, "squeeze")) == {"hand_squeeze"}
    unstaged = {l.key for l in scene.layers if l.stage is None and l.visible}
    assert {"object", "contacts"} <= unstaged == {l.key for l in with_stage(scene, "pregrasp").layers if l.stage is None and l.visible}
    data = scene_to_html(with_stage(scene, "squeeze"))
    scene_json = _scene_json(data)
    assert scene_json["stage"] == "squeeze" and [s["key"] for s in scene_json["stages"]] == ["pregrasp", "grasp", "squeeze"]
    assert {l["key"]: l["visible"] for l in scene_json["layers"] if l["stage"]}["hand_squeeze"] is True
    with pytest.raises(PrehensionError, match="no stage 'pregrasp' to show.*stores no pre-grasp or squeeze"):
        with_stage(build_scene(load_builtin_task("teapot-lid-lifting")), "pregrasp")


def test_a_result_without_stored_stages_is_drawn_as_before(result_file, tmp_path):
    data = json.loads(result_file.read_text())
    for key in ("pregrasp", "squeeze"):
        del data["solutions"][0][key]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(data))
    loaded = load_grasp(old)
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    assert loaded.pose.stages == () and scene.stages == () and all(l.stage is None for l in scene.layers)
    data["solutions"][0]["pregrasp"] = {"joint_angles_rad": {}}  # malformed: named, not a traceback
    old.write_text(json.dumps(data))
    with pytest.raises(PrehensionError, match="solution 0 of the result is malformed"):
        load_grasp(old)


def test_view_and_render_take_a_stage(result_file, tmp_path, capsys):
    page = tmp_path / "lid.html"
    assert main(["view", str(result_file), "-o", str(page), "--stage", "pregrasp"]) == EXIT_OK
    assert _scene_json(page.read_text())["stage"] == "pregrasp"
    image = pytest.importorskip("matplotlib.image")
    pictures = {}
    for stage in ("pregrasp", "grasp", "squeeze"):
        out = tmp_path / f"{stage}.png"
        assert main(["render", str(result_file), "-o", str(out), "--size", "360x280", "--stage", stage]) == EXIT_OK
        pictures[stage] = image.imread(out)[..., :3]
    assert np.abs(pictures["pregrasp"] - pictures["grasp"]).max() > 0.2  # the fingers stand elsewhere
    assert np.abs(pictures["squeeze"] - pictures["grasp"]).max() > 0.2
    capsys.readouterr()
    assert main(["render", "teapot-lid-lifting", "-o", str(tmp_path / "t.png"), "--stage", "squeeze"]) == EXIT_BAD_INPUT
    assert "no stage 'squeeze' to show" in capsys.readouterr().err


def test_the_picture_keys_only_the_stage_it_draws(result_file):
    from prehension.viewer.render import _legend
    from prehension.viewer.stages import with_stage

    loaded = load_grasp(result_file)
    scene = build_scene(loaded.task, loaded.pose, status=loaded.status)
    labels = lambda s: [e.label for e in _legend(s)]  # noqa: E731
    assert "hand at the pre-grasp" not in labels(scene) and "hand at the squeeze" not in labels(scene)
    assert "hand at the pre-grasp" in labels(with_stage(scene, "pregrasp"))
    assert "hand at the squeeze" in labels(with_stage(scene, "squeeze"))
    assert {e.label for e in scene.legend} >= {"hand at the pre-grasp", "hand at the squeeze"}  # the page keys them all
