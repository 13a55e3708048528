"""export then import-grasps then check: other tools' grasps judged as prehension's own."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from prehension.cli import main
from prehension.cli.codes import EXIT_APPROXIMATE, EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_OK
from prehension.interop.records import records_from_result
from prehension.results import read_result
from prehension.verification import verify_result

HERE = Path(__file__).resolve().parents[1] / "examples" / "quality"
EXAMPLE, TASK = HERE / "box-four-fingers.result.json", HERE / "box-four-fingers.yaml"
OUT = {"dexgraspbench": "g.npy", "dexgraspnet": "g_net.npy", "json-m": "g.json"}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exported")
    for fmt, name in OUT.items():
        assert main(["export", str(EXAMPLE), "--format", fmt, "-o", str(folder / name), "--solution", "0"]) == EXIT_OK
    return folder


@pytest.fixture(scope="module")
def box_mesh(tmp_path_factory):
    """The example's box as a bare OBJ mesh in mm."""
    trimesh = pytest.importorskip("trimesh")
    task, _ = read_result(EXAMPLE)
    mesh = task.object.display_mesh()
    path = tmp_path_factory.mktemp("mesh") / "box.obj"
    trimesh.Trimesh(mesh.vertices, mesh.faces).export(path)
    return path


def records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_every_format_comes_back_as_the_same_grasp_and_check_re_verifies_it(exported, tmp_path):
    out = tmp_path / "imported.jsonl"
    files = [str(exported / n) for n in OUT.values()]
    assert main(["import-grasps", *files, "--object", str(TASK), "-o", str(out)]) == EXIT_OK
    task, data = read_result(EXAMPLE)
    want = data["solutions"][0]
    lines = records(out)
    assert [line["status"] for line in lines] == ["solved"] * 3
    for line in lines:
        got = line["result"]["solutions"][0]
        assert max(abs(got["joint_angles_rad"][d] - want["joint_angles_rad"][d]) for d in task.hand.dof_names) <= 1e-9
        assert np.max(np.abs(np.array(got["T_palm_object"]) - want["T_palm_object"])) <= 1e-6
        assert line["result"]["method"] == "imported" and "claimed" in got["imported"]
    bench, net, m = (line["result"]["solutions"][0] for line in lines)
    assert "pregrasp" in bench and "pregrasp" in m and "pregrasp" not in net  # DexGraspNet carries the grasp only
    assert bench["pregrasp"]["collision_free"] == want["pregrasp"]["collision_free"]
    assert main(["check", str(out)]) == EXIT_OK


def test_a_grasp_on_a_bare_mesh_has_its_contacts_measured(exported, box_mesh, tmp_path):
    out = tmp_path / "mesh.jsonl"
    args = ["import-grasps", str(exported / "g.npy"), "--hand", "sa", "--object", str(box_mesh), "--mesh-scale", "1"]
    assert main([*args, "-o", str(out)]) == EXIT_OK
    (line,) = records(out)
    solution = line["result"]["solutions"][0]
    measured = {m["hand_region"]: m for m in solution["imported"]["measured"]}
    assert "measured" in solution["imported"]["contacts"]
    for contact in solution["contacts"]:  # the four fingertips of the task touch the box
        assert abs(measured[contact["name"]]["distance_mm"]) < 1e-6 and measured[contact["name"]]["penetration_mm"] < 1e-6
    assert len(solution["contacts"]) == 4 and line["status"] == "solved"
    assert main(["check", str(out)]) == EXIT_OK
    # millimetres read as metres: the hand 1000x too far (mesh 1000x too large) touches nothing
    assert main([*args[:-1], "1000", "-o", str(tmp_path / "m.jsonl")]) == EXIT_BAD_INPUT
    assert not (tmp_path / "m.jsonl").exists()


def test_a_grasp_that_misses_is_approximate_within_exactly_its_errors(exported, tmp_path):
    data = json.loads((exported / "g.json").read_text())
    data["grasps"][0]["grasp_qpos"][0] += 0.0005  # the palm 0.5 mm off along the object's x
    moved = tmp_path / "moved.json"
    moved.write_text(json.dumps(data))
    out = tmp_path / "moved.jsonl"
    assert main(["import-grasps", str(moved), "--object", str(TASK), "-o", str(out)]) == EXIT_OK
    (line,) = records(out)
    result = line["result"]
    assert line["status"] == "approximate" and "does not hold strictly" in result["message"]
    tol = result["solutions"][0]["tolerances"]
    assert 0.1 < tol["contact_mm"] < 1.0  # loosened to the worst contact, no further
    assert verify_result(result, reprove=False).holds
    single = tmp_path / "moved.result.json"
    single.write_text(json.dumps(result))
    assert main(["check", str(single)]) == EXIT_APPROXIMATE  # never "solved"
    result["solutions"][0]["tolerances"]["contact_mm"] = tol["contact_mm"] / 2  # a claim that is false
    single.write_text(json.dumps(result))
    assert main(["check", str(single)]) == EXIT_CHECK_FAILED


def test_import_grasps_refuses_bad_input_by_name(exported, box_mesh, tmp_path, capsys):
    out = tmp_path / "x.jsonl"
    bench = str(exported / "g.npy")
    assert main(["import-grasps", bench, "--object", str(box_mesh), "-o", str(out)]) == EXIT_BAD_INPUT
    assert "--hand is needed" in capsys.readouterr().err
    assert main(["import-grasps", bench, "--object", "no-such-thing", "--hand", "sa", "-o", str(out)]) == EXIT_BAD_INPUT
    assert "neither a task" in capsys.readouterr().err
    assert main(["import-grasps", bench, "--object", str(TASK), "-o", bench]) == EXIT_BAD_INPUT  # never the input
    assert main(["import-grasps", str(tmp_path / "none.npy"), "--object", str(TASK), "-o", str(out)]) == EXIT_BAD_INPUT
    assert "not found" in capsys.readouterr().err
    out.write_text("keep me\n")
    assert main(["import-grasps", bench, "--object", str(TASK), "-o", str(out)]) == EXIT_BAD_INPUT
    assert out.read_text() == "keep me\n"
    assert main(["import-grasps", bench, "--object", str(TASK), "--format", "json-m", "-o", str(tmp_path / "y.jsonl")]) == EXIT_BAD_INPUT


def test_export_writes_a_dexgraspbench_folder_and_never_overwrites(tmp_path):
    task, data = read_result(EXAMPLE)
    folder = tmp_path / "bench"
    assert main(["export", str(EXAMPLE), "--format", "dexgraspbench", "-o", str(folder)]) == EXIT_OK
    n = len(records_from_result(task, data))
    assert sorted(p.name for p in folder.iterdir()) == sorted(f"{k}.npy" for k in range(n))
    assert main(["export", str(EXAMPLE), "--format", "dexgraspbench", "-o", str(folder)]) == EXIT_BAD_INPUT
    assert main(["export", str(EXAMPLE), "--format", "dexgraspbench", "-o", str(folder), "--force"]) == EXIT_OK
    one = tmp_path / "one"
    assert main(["export", str(EXAMPLE), "--format", "dexgraspbench", "-o", str(one), "--solution", str(n - 1)]) == EXIT_OK
    assert [p.name for p in one.iterdir()] == [f"{n - 1}.npy"]  # named by its solution number
    assert main(["export", str(EXAMPLE), "--format", "json-m", "-o", str(EXAMPLE)]) == EXIT_BAD_INPUT
    assert main(["export", str(EXAMPLE), "--format", "json-m", "-o", str(tmp_path / "u.json"), "--units", "mm"]) == EXIT_BAD_INPUT
    assert main(["export", str(tmp_path / "none.json"), "--format", "json-m", "-o", str(tmp_path / "a.json")]) == EXIT_BAD_INPUT


from test_special_outputs import _fingerprint, short_dir, special  # noqa: E402,F401 -- the fixtures of every output test

INTEROP_COMMANDS = {
    "export json-m": lambda d, out, e: ["export", str(EXAMPLE), "--format", "json-m", "-o", str(out), "--force"],
    "export dexgraspbench": lambda d, out, e: ["export", str(EXAMPLE), "--format", "dexgraspbench", "-o", str(out), "--solution", "0"],
    "export dexgraspnet": lambda d, out, e: ["export", str(EXAMPLE), "--format", "dexgraspnet", "-o", str(out)],
    "export glb": lambda d, out, e: ["export", str(EXAMPLE), "--format", "glb", "-o", str(out), "--force"],
    "import-grasps": lambda d, out, e: ["import-grasps", str(e / "g.npy"), "--object", str(TASK), "-o", str(out), "--force"],
}  # fmt: skip
INTEROP_SUFFIX = {"export json-m": ".json", "export glb": ".glb", "import-grasps": ".jsonl"}


@pytest.mark.parametrize("command", sorted(INTEROP_COMMANDS))
def test_export_and_import_refuse_a_special_output_and_leave_it(special, command, short_dir, exported, capsys):
    made, words, _ = special
    out = made("out" + INTEROP_SUFFIX.get(command, ".npy"))
    before = _fingerprint(out)
    assert main(INTEROP_COMMANDS[command](short_dir, out, exported)) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert words in err and out.name in err
    assert _fingerprint(out) == before
    assert not [p for p in short_dir.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_a_folder_of_grasp_files_is_read_in_natural_order(exported, tmp_path):
    from prehension.cli.import_grasps import grasp_files

    folder = tmp_path / "other_tool"
    folder.mkdir()
    for name in ("10.npy", "2.npy", "1.npy"):
        (folder / name).write_bytes((exported / "g.npy").read_bytes())
    (folder / "notes.txt").write_text("not a grasp")
    (folder / "sub").mkdir()
    assert [p.name for p in grasp_files([folder])] == ["1.npy", "2.npy", "10.npy"]
    out = tmp_path / "judged.jsonl"
    assert main(["import-grasps", str(folder), "--object", str(TASK), "-o", str(out)]) == EXIT_OK
    assert [line["id"] for line in records(out)] == ["1.npy", "2.npy", "10.npy"]
    assert [line["status"] for line in records(out)] == ["solved"] * 3
    assert main(["check", str(out)]) == EXIT_OK
    assert main(["import-grasps", str(folder / "sub"), "--object", str(TASK), "-o", str(tmp_path / "e.jsonl")]) == EXIT_BAD_INPUT


def test_metres_and_millimetres_confused_are_named_with_the_fix(exported, box_mesh, tmp_path, capsys):
    """A bare mesh 1000x off (its units misread) and a record whose pose is 1000x too small
    (metres where millimetres are expected) or too large are errors naming the fix."""
    capsys.readouterr()
    args = ["import-grasps", str(exported / "g.npy"), "--hand", "sa", "--object", str(box_mesh), "-o", str(tmp_path / "m.jsonl")]
    assert main([*args, "--mesh-scale", "1000"]) == EXIT_BAD_INPUT
    err = " ".join(capsys.readouterr().err.split())
    assert "a mesh in millimetres read as metres" in err and "give --mesh-scale 1" in err
    assert main([*args, "--mesh-scale", "0.001"]) == EXIT_BAD_INPUT
    err = " ".join(capsys.readouterr().err.split())
    assert "a mesh in metres read as millimetres" in err and "give --mesh-scale 1" in err
    data = json.loads((exported / "g.json").read_text())
    for factor, said in ((1e-3, "1000x too small (metres given where millimetres are expected?)"),
                         (1e3, "the record's lengths are metres (were millimetres written?)")):  # over 10 m: fmt: skip
        bad = json.loads(json.dumps(data))
        bad["grasps"][0]["grasp_qpos"][:3] = [v * factor for v in bad["grasps"][0]["grasp_qpos"][:3]]
        path = tmp_path / f"scaled{factor:g}.json"
        path.write_text(json.dumps(bad))
        out = tmp_path / "s.jsonl"
        code = main(["import-grasps", str(path), "--object", str(TASK), "-o", str(out)])
        err = " ".join(capsys.readouterr().err.split())
        assert code == EXIT_BAD_INPUT and said in err and "Traceback" not in err and not out.exists()
    near = json.loads(json.dumps(data))  # 0.5 mm off: a grasp that misses a little is judged, not refused
    near["grasps"][0]["grasp_qpos"][0] += 0.0005
    (tmp_path / "near.json").write_text(json.dumps(near))
    assert main(["import-grasps", str(tmp_path / "near.json"), "--object", str(TASK), "-o", str(tmp_path / "n.jsonl")]) == EXIT_OK


def test_a_pose_1000x_too_large_is_named_below_the_10_m_check():
    """A record that reaches the judge with its palm 1000x too far (a small hand, millimetres
    as metres under the 10 m check) is refused, not stored as approximate."""
    from dataclasses import replace

    from prehension.errors import InvalidTask
    from prehension.interop.imported import imported_result

    task, data = read_result(EXAMPLE)
    record = records_from_result(task, data, 0)[0]
    assert imported_result(task, record)["status"] == "solved"
    T = np.array(record.T_palm_object)
    T[:3, 3] *= 1000.0
    with pytest.raises(InvalidTask, match="1000x too large"):
        imported_result(task, replace(record, T_palm_object=T))
