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
