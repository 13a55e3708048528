"""Result files carry the files their task names (issue 28, item 8): moved alone to another
folder, with the original mesh gone, ``check`` and ``view`` still work; a batch output
stores each mesh once (tests/test_batch.py, on its cluster); a hand read from a file needs neither the file nor its meshes."""

from __future__ import annotations

import base64
import json
import shutil
import zlib

import numpy as np
import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.hands.files import load_hand_file
from prehension.tasks.format.embedded import task_with_files
from test_cli_hands import _short_task
from test_object_meshes import KNOB_TASK, _box_file

DATA = __import__("pathlib").Path(__file__).resolve().parent / "data"


def _mesh_task(folder, name: str = "task.yaml", top_z: float = 15.0):
    """A task on a mesh file (a box, in metres) with a display mesh file beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    _box_file(folder, ".stl")
    shutil.copy(_box_file(folder, ".obj", extents=(0.01, 0.01, 0.01)), folder / "deco.obj")
    solid = "mesh: box.stl\n  units: m\n  display: {mesh_file: deco.obj}"
    text = KNOB_TASK.format(solid=solid).replace("15]", f"{top_z:g}]").replace("name: mesh-box", f"name: {name[:-5]}")
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def _check_and_view(result, tmp_path, capsys) -> str:
    capsys.readouterr()
    assert main(["check", str(result)]) == EXIT_OK
    html = tmp_path / "view.html"
    assert main(["view", str(result), "-o", str(html)]) == EXIT_OK
    assert html.stat().st_size > 10_000
    return capsys.readouterr().err


def test_a_result_moved_alone_is_checked_and_viewed_without_its_mesh(tmp_path, capsys):
    task = _mesh_task(tmp_path / "work")
    result = tmp_path / "work" / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK
    data = json.loads(result.read_text())
    paths = [data["task"]["object"]["mesh"], data["task"]["object"]["display"]["mesh_file"]]
    assert sorted(data["files"]) == sorted(paths)  # both files the task names travel with it
    assert data["files"][paths[0]]["size"] == (tmp_path / "work" / "box.stl").stat().st_size
    moved = tmp_path / "elsewhere" / "r.json"
    moved.parent.mkdir()
    shutil.move(result, moved)
    shutil.rmtree(tmp_path / "work")  # the mesh, the display mesh and the task are gone
    assert "not found" not in _check_and_view(moved, tmp_path, capsys)


def test_the_carried_mesh_is_used_even_when_the_original_has_changed(tmp_path, capsys):
    task = _mesh_task(tmp_path)
    result = tmp_path / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK
    _box_file(tmp_path, ".stl", extents=(0.4, 0.2, 0.3))  # edited after the solve: ten times larger
    _check_and_view(result, tmp_path, capsys)  # checked against the object it was solved on


def test_a_damaged_copy_is_an_error_naming_the_file(tmp_path, capsys):
    task = _mesh_task(tmp_path)
    result = tmp_path / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK
    data = json.loads(result.read_text())
    mesh = data["task"]["object"]["mesh"]
    raw = zlib.decompress(base64.b64decode(data["files"][mesh]["zlib_base64"]))
    damaged = raw[:100] + bytes([raw[100] ^ 1]) + raw[101:]  # one bit flipped in the first triangle
    data["files"][mesh]["zlib_base64"] = base64.b64encode(zlib.compress(damaged)).decode()
    result.write_text(json.dumps(data))
    capsys.readouterr()
    assert main(["check", str(result)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert f"the copy of {mesh} that the file carries does not match its SHA-256" in " ".join(err.split())
    assert "Traceback" not in err


def test_a_result_without_files_is_read_from_the_disk_as_before(tmp_path, capsys):
    task = _mesh_task(tmp_path)
    result = tmp_path / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK
    data = json.loads(result.read_text())
    del data["files"]  # as written before results carried their files
    result.write_text(json.dumps(data))
    _check_and_view(result, tmp_path, capsys)
    assert task_with_files(data["task"], None, "x") is data["task"]


@pytest.mark.parametrize("form", ["mjcf", "urdf"])
def test_a_result_of_a_hand_read_from_a_file_needs_neither_the_file_nor_its_meshes(tmp_path, capsys, form):
    from conftest import HANDS_DIR

    if form == "mjcf":
        pytest.importorskip("mujoco")
        source = DATA / "coupled_hand.xml"
    else:
        source = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
        if not source.is_file():
            pytest.skip("shared/hands not present beside the checkout")
    work = tmp_path / "work"
    shutil.copytree(source.parent, work / "hand")
    hand_file = work / "hand" / source.name
    text = _short_task(f"{{{form}: {hand_file}}}", load_hand_file(hand_file), np.random.default_rng(3), ("thumb", "index"))
    (work / "t.yaml").write_text(text)
    result = work / "r.json"
    assert main(["solve", str(work / "t.yaml"), "-o", str(result), "--quiet"]) == EXIT_OK
    moved = tmp_path / "elsewhere" / "r.json"
    moved.parent.mkdir()
    shutil.move(result, moved)
    shutil.rmtree(work)  # the hand file and its meshes are gone
    _check_and_view(moved, tmp_path, capsys)


def test_the_json_summary_does_not_print_the_carried_mesh(tmp_path, capsys):
    task = _mesh_task(tmp_path)
    capsys.readouterr()
    assert main(["solve", str(task), "-o", str(tmp_path / "r.json"), "--json"]) == EXIT_OK
    summary = json.loads(capsys.readouterr().out)
    assert summary["status"] == "solved" and "files" not in summary and "task" not in summary
    assert "files" in json.loads((tmp_path / "r.json").read_text())  # the result file has them
