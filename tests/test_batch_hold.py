"""prehension batch --hold: each task as solve --hold, on the cluster; the verdict stored and re-checked."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from prehension.batch import BatchOptions, read_inputs, read_records, run_batch, task_seed  # noqa: E402
from prehension.batch.inputs import entry_task  # noqa: E402
from prehension.batch_extras import hold_task  # noqa: E402
from prehension.best import BestOptions, solve_best  # noqa: E402
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main  # noqa: E402
from prehension.cli.codes import EXIT_CHECK_FAILED  # noqa: E402
from prehension.errors import PrehensionError  # noqa: E402
from prehension.hold import hold_first  # noqa: E402
from prehension.results import SolveResult  # noqa: E402
from prehension.sim import SimOptions  # noqa: E402
from prehension.solve import SolveOptions  # noqa: E402
from prehension.tasks.yaml_io import task_to_dict  # noqa: E402
from tiny_tasks import pincer_task  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "quality"
BEST = BestOptions(n=2, starts=10)


@pytest.fixture
def tasks(tmp_path):
    lines = [{"task": str(EXAMPLES / "box-four-fingers.yaml")}, {"task": str(EXAMPLES / "box-one-face.yaml")},
             task_to_dict(pincer_task(40.0)), task_to_dict(pincer_task(60.0))]  # fmt: skip
    path = tmp_path / "tasks.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path


def test_each_record_is_what_solve_hold_answers_alone(client, tasks, tmp_path):
    out = tmp_path / "out.jsonl"
    run_batch(tasks, out, client, BatchOptions(method="local", best=BEST, hold=SimOptions()))
    records = {r["task"]: r for r in read_records(out)}
    for name in ("box-four-fingers", "box-one-face"):
        entry = next(e for e in read_inputs(tasks) if e.name == name)
        seed = task_seed(0, entry.id)
        alone = hold_first(solve_best(entry_task(entry.payload), BEST, SolveOptions(method="local", seed=seed)), SimOptions(), seed)
        record = records[name]
        assert record["held"] is alone.held and record["status"] == alone.result.status == "solved"
        stored = record["result"]["solutions"]
        assert len(stored) == len(alone.result.solutions) and [s["physics"] for s in stored] == list(alone.physics)
        for mine, theirs in zip(stored, alone.result.solutions):
            np.testing.assert_allclose(list(mine["joint_angles_rad"].values()), theirs.q, rtol=0, atol=1e-12)
        assert record["result"]["stats"]["hold"]["held"] is alone.held
    assert records["box-four-fingers"]["held"] is True and records["box-one-face"]["held"] is False
    assert records["pincer-60"]["held"] is None and records["pincer-60"]["result"]["solutions"] == []  # nothing to judge


def test_a_task_the_physics_cannot_judge_keeps_its_solutions(client, tasks, tmp_path):
    """Two points on a pincer: no solid to simulate -- the solutions stand, unjudged, and the message says why."""
    out = tmp_path / "out.jsonl"
    run_batch(tasks, out, client, BatchOptions(method="local", best=BEST, hold=SimOptions()))
    pincer = next(r for r in read_records(out) if r["task"] == "pincer-40")
    assert pincer["status"] == "solved" and pincer["held"] is None and pincer["result"]["solutions"]
    assert "physics test unavailable" in pincer["message"] and "unavailable" in pincer["result"]["stats"]["hold"]
    assert all("physics" not in s for s in pincer["result"]["solutions"])


def test_hold_task_without_solutions_judges_nothing(one_face):
    task, _ = one_face
    empty = SolveResult(task, "local", "gave_up", "none", ())
    out = hold_task(empty, SimOptions(), 0)
    assert out.held is None and out.physics is None and out.result is empty


def test_batch_options_say_what_hold_needs():
    with pytest.raises(PrehensionError, match="hold runs the candidates of best"):
        BatchOptions(hold=SimOptions())
    with pytest.raises(PrehensionError, match="give hold or simulate, not both"):
        BatchOptions(best=BEST, hold=SimOptions(), simulate=SimOptions())
    assert BatchOptions(method="local", best=BEST, hold=SimOptions()).chunk_size_for(100, 2) == 1
    with pytest.raises(PrehensionError, match="budget of hold's force-closure search"):
        BatchOptions(best=BEST, hold_closure_time_s=5.0)  # without hold
    with pytest.raises(PrehensionError, match=r">= 0 s with hold, got -1"):
        BatchOptions(best=BEST, hold=SimOptions(), hold_closure_time_s=-1.0)


def test_hold_task_passes_the_force_closure_budget_on(one_face):
    """box-one-face (every fingertip on one face: no candidate holds): with the default budget
    the complete solver proves that its regions admit no force-closure grasp, as
    ``solve --hold`` does; with 0 it is not asked."""
    task, _ = one_face
    result = solve_best(task, BEST, SolveOptions(method="local", seed=0))
    asked = hold_task(result, SimOptions(), 0)
    assert asked.held is False and asked.result.stats["hold"]["closure"]["status"] == "infeasible"
    not_asked = hold_task(result, SimOptions(), 0, 0.0)
    assert not_asked.held is False and not_asked.result.stats["hold"].get("closure") is None


def test_the_batch_command_holds_and_check_re_runs_the_verdicts(client, tasks, tmp_path, capsys):
    out = tmp_path / "out.jsonl"
    code = main(["batch", str(tasks), "-o", str(out), "--method", "local", "--scheduler", client.scheduler.address,
                 "--hold", "--starts", "10", "--best", "2"])  # fmt: skip
    assert code == EXIT_OK
    assert "hold: 1 of 2 solved tasks hold in the physics test; 1 not judged" in capsys.readouterr().out
    box = next(r for r in read_records(out) if r["task"] == "box-four-fingers")
    assert box["held"] and box["result"]["solutions"][0]["physics"]["success"]
    capsys.readouterr()
    assert main(["check", str(out)]) == EXIT_OK
    lines = out.read_text().splitlines()  # a verdict that lies: check re-runs it and says so
    for i, line in enumerate(lines):
        record = json.loads(line)
        if record.get("task") == "box-four-fingers":
            record["result"]["solutions"][0]["physics"]["pushes"][0]["held"] = False
            lines[i] = json.dumps(record)
    out.write_text("\n".join(lines) + "\n")
    assert main(["check", str(out)]) == EXIT_CHECK_FAILED


def test_batch_hold_refuses_what_it_cannot_do(tasks, tmp_path, capsys, monkeypatch):
    out = str(tmp_path / "out.jsonl")
    with pytest.raises(SystemExit):  # argparse: not allowed with --simulate
        main(["batch", str(tasks), "-o", out, "--hold", "--simulate"])
    assert "not allowed with argument" in capsys.readouterr().err
    assert main(["batch", str(tasks), "-o", out, "--hold", "--starts", "-1"]) == EXIT_BAD_INPUT
    assert "--hold runs the candidates of --best 5: --starts must be" in capsys.readouterr().err
    assert main(["batch", str(tasks), "-o", out, "--hold-closure-time", "5"]) == EXIT_BAD_INPUT
    assert "--hold-closure-time is the budget of --hold" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse: a number of seconds >= 0
        main(["batch", str(tasks), "-o", out, "--hold", "--hold-closure-time", "-1"])
    assert "must be a number of seconds >= 0" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "mujoco", None)
    assert main(["batch", str(tasks), "-o", out, "--hold"]) == EXIT_BAD_INPUT
    assert 'pip install "prehension[sim]"' in capsys.readouterr().err
    assert not Path(out).exists()
