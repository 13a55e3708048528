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
