"""``prehension plan``: records ``check`` accepts, task files that re-solve, resume, bad input."""

from __future__ import annotations

import json

import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main

PLAN = ["--samples", "300", "--grasps", "2"]


def box_file(tmp_path, extents=(70.0, 45.0, 30.0), name="box.stl"):
    import trimesh

    path = tmp_path / name
    trimesh.creation.box(extents=extents).export(path)
    return path


def records(path):
    return [r for r in map(json.loads, path.read_text().splitlines()) if "id" in r]


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plan")
    mesh = box_file(tmp)
    out, tasks = tmp / "grasps.jsonl", tmp / "tasks"
    code = main(["plan", str(mesh), "--hand", "sa", "--units", "mm", *PLAN, "-o", str(out), "--tasks-dir", str(tasks), "--quiet"])
    return code, mesh, out, tasks


def test_plan_writes_records_that_check_accepts(planned):
    code, _, out, _ = planned
    assert code == EXIT_OK
    rows = records(out)
    solved = [r for r in rows if r["status"] == "solved"]
    assert len(solved) == 2 and len({r["id"] for r in rows}) == len(rows)
    for r in solved:
        assert r["assignment"]["hand_regions"][0] == "thumb_tip"
        assert all(s["quality"]["force_closure"] in (True, False) for s in r["result"]["solutions"])
    assert main(["check", str(out)]) == EXIT_OK


def test_plan_task_files_solve_again(planned, tmp_path):
    from prehension.tasks.yaml_io import load_task

    _, _, out, tasks = planned
    files = sorted(tasks.glob("*.yaml"))
    names = {r["task"] for r in records(out) if r["status"] == "solved"}
    assert {f.stem for f in files} == names
    for f in files:
        task = load_task(f)
        assert len(task.contacts) == 3 and task.contacts[0].hand_region == "thumb_tip"
        assert main(["solve", str(f), "--method", "local", "-o", str(tmp_path / f"{f.stem}.json")]) == EXIT_OK


def test_plan_resumes_where_it_stopped(planned, tmp_path):
    code, mesh, out, _ = planned
    copy = tmp_path / "again.jsonl"
    copy.write_bytes(out.read_bytes())
    before = records(copy)
    assert main(["plan", str(mesh), "--hand", "sa", "--units", "mm", *PLAN, "-o", str(copy), "--quiet"]) == EXIT_OK
    assert records(copy) == before  # two grasps already: nothing more to do
    more = ["--samples", "300", "--grasps", "3"]
    assert main(["plan", str(mesh), "--hand", "sa", "--units", "mm", *more, "-o", str(copy), "--quiet"]) == EXIT_OK
    after = records(copy)
    assert after[: len(before)] == before and len({r["id"] for r in after}) == len(after)
    assert sum(r["status"] == "solved" for r in after) == 3
    # another plan's journal is refused, not mixed
    other = ["--samples", "301", "--grasps", "3"]
    assert main(["plan", str(mesh), "--hand", "sa", "--units", "mm", *other, "-o", str(copy), "--quiet"]) == EXIT_BAD_INPUT


def _error(capsys, argv) -> str:
    assert main(argv) == EXIT_BAD_INPUT
    return capsys.readouterr().err.replace("\n", " ")


def test_plan_bad_inputs(tmp_path, capsys):
    mesh = box_file(tmp_path)
    base = ["plan", str(mesh), "--hand", "sa"]
    err = _error(capsys, base + ["--units", "mm", "--fingers", "5", "-o", str(tmp_path / "a.jsonl")])
    assert "5 contacts asked for" in err and "4 fingertip regions" in err and "--fingers 2..4" in err
    assert "no units" in _error(capsys, base + ["-o", str(tmp_path / "b.jsonl")])
    assert "positive number of mm per file unit" in _error(capsys, base + ["--scale", "-2", "-o", str(tmp_path / "c.jsonl")])
    with pytest.raises(SystemExit) as info:
        main(base + ["--units", "furlong"])
    assert info.value.code == 2
    big = box_file(tmp_path, (600.0, 500.0, 450.0), "big.stl")
    err = _error(capsys, ["plan", str(big), "--hand", "sa", "--units", "mm", "--samples", "200", "-o", str(tmp_path / "d.jsonl")])
    assert "too large for hand 'schunk-sa'" in err and "smallest width across any antipodal pair" in err
    assert "fingertips reach at most" in err
    bad = tmp_path / "broken.obj"
    bad.write_text("this is not a mesh\n")
    err = _error(capsys, ["plan", str(bad), "--hand", "sa", "--units", "mm", "-o", str(tmp_path / "e.jsonl")])
    assert "broken.obj" in err
    assert "built-in objects: guitar, scalpel, teapot" in _error(capsys, ["plan", "teacup", "--hand", "sa"])
    assert "drop --units" in _error(capsys, ["plan", "teapot", "--hand", "sa", "--units", "mm"])
    err = _error(capsys, base + ["--units", "mm", "--palm", "--hand", "sa", "--fingers", "6", "-o", str(tmp_path / "f.jsonl")])
    assert "fingertip and palm regions" in err
