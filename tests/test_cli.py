"""The command line: tasks, show, import-cuik, exit codes and error messages."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import CUIK_DIR, requires_cuik
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.tasks.cuik_import import import_world
from prehension.tasks.yaml_io import load_task, task_to_dict


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    from importlib.metadata import version

    assert capsys.readouterr().out == f"prehension {version('prehension')}\n"
    assert main([]) == EXIT_OK


def test_tasks_lists_the_nine(capsys):
    assert main(["tasks"]) == EXIT_OK
    out = capsys.readouterr().out
    for name in ("scalpel-upholding", "teapot-lid-lifting", "guitar-holding", "teapot-transportation"):
        assert name in out


def test_show_prints_links_limits_contacts_and_sizes(capsys):
    assert main(["show", "teapot-lid-lifting"]) == EXIT_OK
    out = capsys.readouterr().out
    for text in ("thumb_distal", "index_mcp_flex", "knob_front", "Problem size", "219", "held at"):
        assert text in out
    assert "21" in out and "11" in out  # variables and expected dimension of our formulation


def test_unknown_task_is_bad_input(capsys):
    assert main(["show", "no-such-task"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "'no-such-task' is neither a built-in task" in err and "teapot-lid-lifting" in err


def test_malformed_task_file_is_bad_input(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("prehension: task/1\nname: x\nhand: [unclosed\n")
    assert main(["show", str(bad)]) == EXIT_BAD_INPUT
    assert "not valid YAML" in capsys.readouterr().err


@requires_cuik
def test_import_cuik_writes_a_task_that_reloads(tmp_path, capsys):
    world = CUIK_DIR / "teapot/2_contacts_index_thumb/SAHandplusTeapot.world"
    out = tmp_path / "lid.yaml"
    assert main(["import-cuik", str(world), "-o", str(out), "--couple-distal"]) == EXIT_OK
    assert "wrote" in capsys.readouterr().out
    reloaded = load_task(out)
    assert task_to_dict(reloaded) == task_to_dict(import_world(world, couple_distal=True))
    # Never overwrite a user's file silently.
    before = out.read_text()
    assert main(["import-cuik", str(world), "-o", str(out)]) == EXIT_BAD_INPUT
    assert "already exists" in capsys.readouterr().err
    assert out.read_text() == before
    assert main(["import-cuik", str(world), "-o", str(out), "--force", "--couple", "p34=p33"]) == EXIT_OK


def test_import_cuik_unsupported_joint_names_the_line(tmp_path, capsys):
    world = tmp_path / "bad.world"
    world.write_text("[LINKS]\npalm\nf\n[JOINTS]\nprismatic: palm (0,0,0)+(1,0,0) f (0,0,0)+(1,0,0) range [0,1]\n")
    assert main(["import-cuik", str(world), "-o", str(tmp_path / "x.yaml")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "bad.world:5" in err and "prismatic joint between 'palm' and 'f'" in err and "revolute and universal" in err
    assert not (tmp_path / "x.yaml").exists()


def test_console_script_runs():
    result = subprocess.run([sys.executable, "-m", "prehension.cli", "tasks"], capture_output=True, text=True)
    assert result.returncode == 0 and "guitar-playing" in result.stdout
