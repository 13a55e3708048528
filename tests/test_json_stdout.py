"""``--json`` prints JSON and nothing else, in a fresh process (issue 28, item 4).

HiGHS writes its banner to stdout when a process makes its first instance; inside the test
process that has long happened, so every check here runs the command line in a new
Python process and parses its whole standard output.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from prehension.tasks.yaml_io import dumps_task
from tiny_tasks import pincer_task

SRC = Path(__file__).resolve().parents[1] / "src"


def _run(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "prehension.cli", *argv], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)  # fmt: skip


def test_the_first_highs_instance_prints_nothing_on_stdout(tmp_path):
    code = "from prehension.lp import quiet_highs; h = quiet_highs(); h2 = quiet_highs(); print('only this')"
    env = dict(os.environ, PYTHONPATH=str(SRC))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout == "only this\n", out.stdout
    assert "HiGHS" not in out.stderr


@pytest.mark.parametrize("method", ["auto", "complete"])
def test_solve_json_is_json(tmp_path, method):
    """The complete solver's LPs and the force-closure LP of the quality both run."""
    task = tmp_path / "t.yaml"
    task.write_text(dumps_task(pincer_task(30.0)))
    done = _run("solve", str(task), "--method", method, "--json", "-o", str(tmp_path / "r.json"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)  # the whole of stdout
    assert summary["status"] == "solved" and "HiGHS" not in done.stdout


def test_solve_quiet_prints_nothing(tmp_path):
    done = _run("solve", "teapot-lid-lifting", "--quiet", "-o", str(tmp_path / "r.json"), cwd=tmp_path)
    assert done.returncode == 0 and done.stdout == "", done.stdout


def test_simulate_json_is_json(tmp_path):
    pytest.importorskip("mujoco")
    result = tmp_path / "r.json"
    assert _run("solve", "teapot-lid-lifting", "--quiet", "-o", str(result), cwd=tmp_path).returncode == 0
    done = _run("simulate", str(result), "--json", cwd=tmp_path)
    assert done.returncode in (0, 7), done.stderr  # 7: the object dropped; the output is JSON either way
    assert json.loads(done.stdout)["grasps"]
