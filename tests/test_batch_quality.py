"""prehension batch with --best N and --simulate: per task, on the cluster, as alone."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from prehension.batch import BatchOptions, read_inputs, read_records, run_batch, task_seed
from prehension.batch.inputs import entry_task
from prehension.best import BestOptions, solve_best
from prehension.solve import SolveOptions
from prehension.cli import EXIT_OK, main
from prehension.quality import QualityOptions
from prehension.sim import SimOptions, simulate_grasp
from prehension.tasks.yaml_io import task_to_dict
from tiny_tasks import pincer_task

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "quality"


@pytest.fixture
def tasks(tmp_path):
    lines = [{"task": str(EXAMPLES / "box-four-fingers.yaml")}, task_to_dict(pincer_task(40.0)), task_to_dict(pincer_task(60.0))]
    path = tmp_path / "tasks.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path


def test_best_of_n_per_task_is_what_solving_alone_gives(client, tasks, tmp_path):
    best = BestOptions(n=2, starts=12, quality=QualityOptions(torsion_mm=2.0))
    out = tmp_path / "out.jsonl"
    summary = run_batch(tasks, out, client, BatchOptions(method="local", best=best, quality=best.quality))
    assert summary.counts == {"solved": 2, "gave_up": 1}
    by_id = {r["id"]: r for r in read_records(out)}
    for entry in read_inputs(tasks):
        record = by_id[entry.id]
        alone = solve_best(entry_task(entry.payload), best, SolveOptions(method="local", seed=task_seed(0, entry.id)))
        assert record["status"] == alone.status
        stored = [list(s["joint_angles_rad"].values()) for s in record["result"]["solutions"]]
        assert len(stored) == len(alone.solutions) <= 2
        for mine, theirs in zip(stored, alone.solutions):
            np.testing.assert_allclose(mine, theirs.q, rtol=0, atol=1e-12)
        if alone.solutions:
            assert record["result"]["stats"]["best"]["requested"] == 2
            assert all(s["quality"]["options"]["torsion_mm"] == 2.0 for s in record["result"]["solutions"])


def test_the_physics_test_runs_with_each_task(client, tasks, tmp_path):
    out = tmp_path / "out.jsonl"
    run_batch(tasks, out, client, BatchOptions(method="local", simulate=SimOptions()))
    records = {r["task"]: r for r in read_records(out)}
    box = records["box-four-fingers"]
    assert [p["solution"] for p in box["physics"]] == [0] and len(box["physics"][0]["pushes"]) == 6
    entry = next(e for e in read_inputs(tasks) if e.name == "box-four-fingers")
    task = entry_task(entry.payload)
    from prehension.solve import solve

    alone = solve(task, SolveOptions(method="local", seed=task_seed(0, entry.id)))
    again = simulate_grasp(task, alone.solutions[0], SimOptions(), task_seed(0, entry.id)).to_dict()
    assert box["physics"][0] == dict(solution=0, **again)  # the same numbers on a worker as here
    assert "unavailable" in records["pincer-40"]["physics"][0]  # two points: no solid to simulate
    assert records["pincer-60"]["physics"] == []  # no solution, nothing to simulate


def test_the_batch_command_takes_best_and_simulate(client, tasks, tmp_path):
    out = tmp_path / "out.jsonl"
    code = main(["batch", str(tasks), "-o", str(out), "--method", "local", "--scheduler", client.scheduler.address,
                 "--best", "2", "--starts", "8", "--simulate", "--quiet"])  # fmt: skip
    assert code == EXIT_OK
    box = next(r for r in read_records(out) if r["task"] == "box-four-fingers")
    assert 1 <= len(box["result"]["solutions"]) <= 2 and len(box["physics"]) == len(box["result"]["solutions"])
    assert main(["check", str(out)]) == EXIT_OK
