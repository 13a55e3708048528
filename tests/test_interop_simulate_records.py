"""``prehension simulate`` of one record of a JSON-lines file (issue 31 item 3): a batch
output (compact records, their tasks on task lines) picked by position, by id or by task
name, and the records ``import-grasps`` writes; what cannot be picked is a clear error."""

from __future__ import annotations

import json
import shutil

import pytest

pytest.importorskip("mujoco")
pytest.importorskip("trimesh")

from prehension.cli import main  # noqa: E402
from prehension.cli.codes import EXIT_BAD_INPUT, EXIT_OK  # noqa: E402
from prehension.cli.simulate import EXIT_DROPPED  # noqa: E402
from test_interop_menagerie import write_gripper  # noqa: E402

SIMULATED = (EXIT_OK, EXIT_DROPPED)  # the test is that it runs on the right grasp, not that a pinch holds


@pytest.fixture(scope="module")
def batch_output(tmp_path_factory):
    """A batch output of two pinch tasks of the Menagerie-layout gripper."""
    folder = tmp_path_factory.mktemp("records")
    write_gripper(folder)
    tasks = folder / "tasks"
    tasks.mkdir()
    text = (folder / "task.yaml").read_text().replace("{mjcf: hand.xml}", f"{{mjcf: {folder / 'hand.xml'}}}")
    (tasks / "first.yaml").write_text(text)
    (tasks / "second.yaml").write_text(text.replace("name: toy-pinch", "name: toy-pinch-2").replace("[30, 30, 30]", "[28, 30, 30]")
                                       .replace("-15, 0, 0]", "-14, 0, 0]").replace("[15, 0, 0]", "[14, 0, 0]"))  # fmt: skip
    out = folder / "out.jsonl"
    assert main(["batch", str(tasks), "-o", str(out), "--workers", "1", "--quiet"]) == EXIT_OK
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["status"] for r in records if r["prehension"] == "batch/1"] == ["solved", "solved"]
    assert all("task" not in r["result"] for r in records if r["prehension"] == "batch/1")  # compact records
    return folder, out


def _simulate(tmp_path, *argv) -> tuple[int, dict | None]:
    out = tmp_path / "physics.json"
    out.unlink(missing_ok=True)
    code = main(["simulate", *map(str, argv), "-o", str(out)])
    return code, (json.loads(out.read_text()) if out.exists() else None)


def test_a_record_is_picked_by_position_id_or_task_name(batch_output, tmp_path):
    _, out = batch_output
    ids = [json.loads(line)["id"] for line in out.read_text().splitlines() if '"batch/1"' in line]
    for argv, task in ((["--record", "1"], "toy-pinch-2"), (["--task", "toy-pinch"], "toy-pinch"),
                       (["--task", "second"], "toy-pinch-2"), (["--task", ids[0]], "toy-pinch")):  # fmt: skip
        code, data = _simulate(tmp_path, out, *argv)
        assert code in SIMULATED and data["task"] == task, argv
        (grasp,) = data["grasps"]
        assert len(grasp["pushes"]) == 6 and grasp["initial_penetration_mm"] <= 0.5


def test_what_cannot_be_picked_is_refused_by_name(batch_output, tmp_path, capsys):
    folder, out = batch_output
    cases = {
        (): "holds 2 records; pick one with --record K or --task NAME",
        ("--record", "2"): "--record 2 is out of range",
        ("--task", "nope"): "no record of",
        ("--task", "toy-pinch", "--record", "0"): "not both",
    }
    for argv, message in cases.items():
        capsys.readouterr()
        assert main(["simulate", str(out), *argv]) == EXIT_BAD_INPUT
        err = " ".join(capsys.readouterr().err.split())
        assert message in err and "Traceback" not in err, argv
        if not argv:  # the listing names each record by position, id, file label and task name
            assert "0: first-" in err and "/ first / toy-pinch;" in err and "/ second / toy-pinch-2" in err
    shutil.copy(out, folder / "copy.json")  # a result file has no records to pick
    capsys.readouterr()
    assert main(["simulate", str(folder / "copy.json"), "--record", "0"]) == EXIT_BAD_INPUT
    assert "pick a record of a JSON-lines file" in " ".join(capsys.readouterr().err.split())


def test_an_import_grasps_record_is_simulated(batch_output, tmp_path):
    folder, out = batch_output
    code, _ = _simulate(tmp_path, out, "--record", "0")
    assert code in SIMULATED
    result = folder / "r.json"
    assert main(["solve", str(folder / "task.yaml"), "-o", str(result), "--quiet"]) == EXIT_OK
    npy = tmp_path / "g.npy"
    assert main(["export", str(result), "--format", "dexgraspbench", "-o", str(npy)]) == EXIT_OK
    judged = tmp_path / "judged.jsonl"
    assert main(["import-grasps", str(npy), "--object", str(folder / "task.yaml"), "-o", str(judged)]) == EXIT_OK
    code, data = _simulate(tmp_path, judged)  # one record: no --record needed
    assert code in SIMULATED and data["task"] == "toy-pinch" and len(data["grasps"][0]["pushes"]) == 6
    code, direct = _simulate(tmp_path, result)
    assert code in SIMULATED
    assert data["grasps"][0]["success"] == direct["grasps"][0]["success"]  # the same grasp, judged alike
