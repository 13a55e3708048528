"""Bad inputs a new user tries (issue 28, item 9 and the sweep): each gets a message that
names the problem, and exit code 2, never a traceback."""

from __future__ import annotations

import pytest

from prehension.cli import EXIT_BAD_INPUT, main


@pytest.mark.parametrize(
    "argv, what",
    [
        (["check", "{d}"], "result file"),
        (["view", "{d}", "-o", "{o}/v.html"], "result file"),
        (["simulate", "{d}"], "result file"),
        (["show", "{d}.urdf"], "hand file"),
        (["region", "{d}.stl", "--at", "0,0,0", "--radius", "2", "--units", "mm"], "mesh file"),
        (["solve", "teapot-lid-lifting", "--checkpoint", "{d}", "--resume"], "checkpoint file"),
    ],
)
def test_a_folder_given_for_a_file_is_said_to_be_a_folder(tmp_path, capsys, argv, what):
    folder = tmp_path / "given.json"
    folder.mkdir()
    (tmp_path / "given.json.urdf").mkdir()
    (tmp_path / "given.json.stl").mkdir()
    argv = [a.format(d=folder, o=tmp_path) for a in argv]
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert f"{what} " in err and "is a folder, not a file" in err and "not found" not in err


@pytest.mark.parametrize(
    "argv, flag, needs",
    [
        (["--rank", "volume"], "--rank", "needs --best N"),
        (["--starts", "3"], "--starts", "needs --best N"),
        (["--distinct-mm", "2"], "--distinct-mm", "needs --best N"),
        (["--ascent-steps", "3"], "--ascent-steps", "needs --best N"),
        (["--method", "local", "--all"], "--all", "--method local does not use it"),
        (["--method", "local", "--checkpoint", "c.json"], "--checkpoint", "--method local does not use it"),
        (["--method", "local", "--sigma", "0.2"], "--sigma", "--method local does not use it"),
        (["--method", "local", "--max-boxes", "5"], "--max-boxes", "--method local does not use it"),
        (["--method", "local", "--workers", "2"], "--workers", "--method local does not use it"),
        (["--method", "complete", "--sequence", "s.json"], "--sequence", "--method complete does not use it"),
    ],
)
def test_an_option_the_run_would_ignore_is_refused(tmp_path, capsys, argv, flag, needs):
    """Issue 28 item 9: --rank without --best and --checkpoint/--all with --method local were
    silently ignored; now argparse's error (usage, the option, what it needs; exit 2), before any work."""
    with pytest.raises(SystemExit) as exit_:
        main(["solve", "teapot-lid-lifting", "-o", str(tmp_path / "r.json"), *argv])
    err = capsys.readouterr().err
    assert exit_.value.code == EXIT_BAD_INPUT and "usage: prehension solve" in err
    assert f"error: {flag} " in err and needs in err
    assert not (tmp_path / "r.json").exists()


def test_batch_refuses_rank_without_best(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["batch", str(tmp_path), "-o", str(tmp_path / "out.jsonl"), "--rank", "found"])
    assert exit_.value.code == EXIT_BAD_INPUT and "--rank needs --best N" in capsys.readouterr().err


def _mesh_task(tmp_path, corner="[-10, -5, 15]"):
    pytest.importorskip("trimesh").creation.box(extents=(40, 20, 30)).export(tmp_path / "box.stl")
    path = tmp_path / "task.yaml"
    path.write_text(
        "prehension: task/1\nname: t\nhand: schunk-sa\nobject:\n  name: box\n  mesh: box.stl\n  units: mm\n"
        f"  regions:\n    top: {{bezier: [[{corner}, [-10, 5, 15]], [[10, -5, 15], [10, 5, 15]]]}}\n"
        "    bottom: {point: [0, 0, -15], normal: [0, 0, -1]}\n"
        "contacts:\n  - {hand: index_tip, object: top}\n  - {hand: thumb_tip, object: bottom}\nfingers: [index, thumb]\n",
        encoding="utf-8",
    )
    return path


def test_a_huge_number_in_a_task_file_is_named_not_turned_into_nan(tmp_path, capsys):
    """The sweep: 1e308 in a control point overflowed (RuntimeWarning on stderr) and was then
    reported as "got nan"; now the number itself is refused with the bound."""
    assert main(["show", str(_mesh_task(tmp_path, "[1e308, -5, 15]"))]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "bezier.0.0.0: must be at most 1e+09 in size" in " ".join(err.split()) and "1e+308" in err
    assert "nan" not in err and "Warning" not in err
    assert main(["show", str(_mesh_task(tmp_path, "[-10, -5, 15]"))]) == 0


def test_huge_or_badly_indexed_meshes_are_named_without_numpy_noise(tmp_path, capsys):
    (tmp_path / "huge.obj").write_text("v 1e300 0 0\nv -1e300 0 0\nv 0 1e300 0\nv 0 0 1e300\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n")
    (tmp_path / "index.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    for name, message in (("huge.obj", "coordinates reach 1e+300 mm, more than 1e+09 mm"),
                          ("index.obj", "a face refers to a vertex the file does not have")):  # fmt: skip
        assert main(["region", str(tmp_path / name), "--at", "0,0,0", "--radius", "1", "--units", "mm"]) == EXIT_BAD_INPUT
        err = " ".join(capsys.readouterr().err.split())
        assert f"{name}: " in err and message in err and "Warning" not in err


@pytest.mark.parametrize("option", ["-o", "--html"])
def test_solve_refuses_to_write_over_the_tasks_mesh(tmp_path, capsys, option):
    """The sweep: ``solve task.yaml -o box.stl`` moved the task's own mesh aside and wrote the
    result in its place (the task then no longer loads); the mesh is an input like the task file."""
    task = _mesh_task(tmp_path)
    mesh = tmp_path / "box.stl"
    before = mesh.read_bytes()
    argv = ["solve", str(task), "--method", "local", "--quiet", option, str(mesh)]
    assert main(argv + (["-o", str(tmp_path / "r.json")] if option != "-o" else [])) == EXIT_BAD_INPUT
    assert "is an input of this command" in capsys.readouterr().err
    assert mesh.read_bytes() == before and not list(tmp_path.glob("box.stl.~*"))


def test_a_named_pipe_given_for_an_input_is_named_and_not_read(tmp_path, capsys):
    """The sweep: ``region fifo`` said "not found" (and opening it to read would wait for a writer)."""
    import os

    fifo = tmp_path / "mesh.stl"
    os.mkfifo(fifo)
    for argv in (["region", str(fifo), "--at", "0,0,0", "--radius", "1", "--units", "mm"], ["check", str(fifo)]):
        assert main(argv) == EXIT_BAD_INPUT
        err = " ".join(capsys.readouterr().err.split())
        assert "is not a regular file (a named pipe" in err and "not found" not in err


def test_a_result_file_without_its_task_is_refused_by_view_as_by_check(tmp_path, capsys):
    """The sweep: ``view`` of a result file whose 'task' was deleted crashed with a KeyError traceback."""
    import json

    result = tmp_path / "r.json"
    assert main(["solve", "teapot-lid-lifting", "--method", "local", "--quiet", "-o", str(result)]) == 0
    data = json.loads(result.read_text())
    del data["task"]
    result.write_text(json.dumps(data))
    for argv in (["view", str(result), "-o", str(tmp_path / "v.html")], ["check", str(result)]):
        assert main(argv) == EXIT_BAD_INPUT
        assert "the result file has no 'task'" in capsys.readouterr().err


def test_json_inputs_that_are_missing_folders_or_not_text_are_named(tmp_path, capsys):
    """The sweep: a missing --sequence file was an errno text, a binary result file a codec error."""
    (tmp_path / "folder.json").mkdir()
    (tmp_path / "binary.json").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(50))
    cases = [
        (["solve", "teapot-lid-lifting", "--method", "local", "--sequence", str(tmp_path / "none.json")],
         "initial-pose sequence not found"),
        (["solve", "teapot-lid-lifting", "--method", "local", "--sequence", str(tmp_path / "folder.json")], "is a folder"),
        (["check", str(tmp_path / "binary.json")], "binary.json: not a result file (not UTF-8 text"),
    ]  # fmt: skip
    for argv, message in cases:
        assert main([*argv, *(["-o", str(tmp_path / "r.json")] if argv[0] == "solve" else [])]) == EXIT_BAD_INPUT
        err = " ".join(capsys.readouterr().err.split())
        assert message in err and "Errno" not in err and "codec" not in err


def test_a_hand_or_task_folder_is_said_to_be_one(tmp_path, capsys):
    hand = tmp_path / "my_hand"
    hand.mkdir()
    (hand / "right.urdf").write_text("<robot name='r'/>")
    for argv, message in ((["show", str(hand)], "is a folder; give the hand file inside it (it holds right.urdf)"),
                          (["offline", str(hand), "-o", str(tmp_path / "s.json")], "(it holds right.urdf)"),
                          (["solve", str(tmp_path)], "is a folder, not a task; give a task file")):  # fmt: skip
        assert main(argv) == EXIT_BAD_INPUT
        assert message in " ".join(capsys.readouterr().err.split())
