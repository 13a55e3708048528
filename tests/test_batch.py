"""prehension batch on a local Dask cluster: inputs and ids, the journal, resume, a killed worker.

One cluster of two worker processes serves the whole module (starting one costs seconds).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import time

import numpy as np
import pytest

from prehension.batch import BatchOptions, read_inputs, read_records, run_batch, task_seed
from prehension.batch.journal import open_journal
from prehension.cli import EXIT_BAD_INPUT, EXIT_GAVE_UP, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.solve import SolveOptions, solve
from prehension.tasks.library import builtin_task_names
from prehension.tasks.yaml_io import dumps_task, task_to_dict
from prehension.solvers.local.verifier import LocalVerifier
from conftest import write_jsonl
from tiny_tasks import pincer_task

PINCER_MM = (30.0, 35.0, 40.0, 44.0, 46.0, 60.0)  # 60 mm: beyond reach, the local solver gives up


@pytest.fixture
def twenty_tasks(tmp_path):
    """Nine built-in tasks, six pincers written inline, and five built-ins again with ids."""
    lines = [{"task": name} for name in builtin_task_names()]
    lines += [task_to_dict(pincer_task(d)) for d in PINCER_MM]
    lines += [{"id": f"again-{i}", "task": name} for i, name in enumerate(builtin_task_names()[:5])]
    return write_jsonl(tmp_path / "tasks.jsonl", lines)


def solved_alone(entry, method="local", seed=0) -> dict:
    """What solving the entry's task in this process gives: status and joint angles."""
    from prehension.batch.inputs import entry_task

    result = solve(entry_task(entry.payload), SolveOptions(method=method, seed=task_seed(seed, entry.id)))
    return {"status": result.status, "q": [s.q for s in result.solutions]}


def assert_same_as_alone(records, entries, method="local"):
    by_id = {r["id"]: r for r in records}
    assert sorted(by_id) == sorted(e.id for e in entries) and len(records) == len(entries)  # each task exactly once
    for entry in entries:
        record, alone = by_id[entry.id], solved_alone(entry, method)
        assert record["status"] == alone["status"], entry.id
        q = [list(s["joint_angles_rad"].values()) for s in record["result"]["solutions"]]
        assert len(q) == len(alone["q"])
        for mine, theirs in zip(q, alone["q"]):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-12)


# -- inputs and ids (no cluster) ----------------------------------------------------------
def test_ids_are_stable_under_reordering_and_change_with_the_task(tmp_path):
    lines = [{"task": "teapot-service"}, task_to_dict(pincer_task(30)), {"id": "x", "task": "guitar-tuning"}]
    a = write_jsonl(tmp_path / "a.jsonl", lines)
    b = write_jsonl(tmp_path / "b.jsonl", lines[::-1])
    c = write_jsonl(tmp_path / "c.jsonl", [task_to_dict(pincer_task(31))])
    ids_a, ids_b = [e.id for e in read_inputs(a)], [e.id for e in read_inputs(b)]
    assert sorted(ids_a) == sorted(ids_b) and "x" in ids_a
    assert ids_a[0].startswith("teapot-service-") and ids_a[1].startswith("pincer-30-")
    assert read_inputs(c)[0].id != ids_a[1]
    assert task_seed(0, "x") != task_seed(1, "x") and task_seed(0, "x") == task_seed(0, "x")


def test_a_folder_of_task_files_is_an_input(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "p30.yaml").write_text(dumps_task(pincer_task(30)))
    (tmp_path / "p40.yaml").write_text(dumps_task(pincer_task(40)))
    (tmp_path / ".hidden.yaml").write_text("not read")
    entries = read_inputs(tmp_path)
    assert [e.name for e in entries] == ["p40", "sub/p30"]
    assert entries[1].payload["kind"] == "yaml" and "prehension: task/1" in entries[1].payload["text"]


@pytest.mark.parametrize(
    "line, message",
    [
        ('{"task": "teapot-service"', r"tasks.jsonl:2: not valid JSON"),
        ('["teapot-service"]', r"tasks.jsonl:2: a line must be a JSON object"),
        ('{"task": "no-such-task"}', r"tasks.jsonl:2: 'no-such-task' is neither a built-in task"),
        ('{"task": "missing.yaml"}', r"tasks.jsonl:2: task file not found: .*missing.yaml"),
        ('{"tusk": "teapot-service"}', r"tasks.jsonl:2: a line is"),
        ('{"id": 7, "task": "teapot-service"}', r"tasks.jsonl:2: \"id\" must be a non-empty string"),
        ('{"task": "guitar-tuning"}', r"tasks.jsonl:2: task id 'guitar-tuning-\w+' is already used by .*tasks.jsonl:1"),
    ],
)
def test_malformed_input_names_file_and_line(tmp_path, line, message):
    path = tmp_path / "tasks.jsonl"
    path.write_text('{"task": "guitar-tuning"}\n' + line + "\n")
    with pytest.raises(PrehensionError, match=message):
        read_inputs(path)


def test_the_cli_reports_bad_input_before_starting_a_cluster(tmp_path, capsys):
    path = tmp_path / "tasks.jsonl"
    path.write_text('{"task": "teapot-service"}\n\n{"task": \n')
    assert main(["batch", str(path), "-o", str(tmp_path / "out.jsonl"), "--quiet"]) == EXIT_BAD_INPUT
    assert "tasks.jsonl:3: not valid JSON" in capsys.readouterr().err
    assert not (tmp_path / "out.jsonl").exists()
    assert main(["batch", str(path), "-o", str(path)]) == EXIT_BAD_INPUT
    assert "is the input" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse: one or the other
        main(["batch", str(path), "-o", "x.jsonl", "--workers", "2", "--scheduler", "tcp://h:8786"])


# -- the journal (no cluster) -------------------------------------------------------------
def record(i, status="solved"):
    return {"prehension": "batch/1", "id": f"t{i}", "task": "t", "status": status, "result": None}


def test_the_journal_drops_a_torn_tail_and_keeps_one_record_per_task(tmp_path):
    path = tmp_path / "out.jsonl"
    lines = [record(0), record(1, "gave_up"), record(2, "invalid"), record(3, "infeasible")]
    path.write_text("".join(json.dumps(r) + "\n" for r in lines) + '{"prehension": "batch/1", "id": "t4", "sta')
    with open_journal(path) as (journal, state):
        assert dict(state.done) == {"t0": "solved", "t1": "gave_up", "t3": "infeasible"}
        assert any("torn" in n for n in state.notes)
        journal.append([record(2)])
    assert [r["id"] for r in read_records(path)] == ["t0", "t1", "t3", "t2"]
    with open_journal(path, retry_gave_up=True) as (_, state):
        assert set(state.done) == {"t0", "t2", "t3"}
    assert [r["id"] for r in read_records(path)] == ["t0", "t3", "t2"]
    assert path.read_bytes().endswith(b"\n") and not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize(
    "text, line",
    [
        ('{"task": "teapot-service"}\n' + json.dumps(record(0)) + "\n", 1),  # the input given as -o
        ('{"task": "teapot-service"}\n{"task": "guitar-tuning"}', 1),
        (json.dumps(record(0)) + "\nsome notes\n", 2),
        ('{"task": "teapot-service"}', 1),  # no newline: not a torn record either
    ],
)
def test_a_file_that_is_not_a_journal_is_left_alone(tmp_path, text, line):
    path = tmp_path / "tasks.jsonl"
    path.write_text(text)
    with pytest.raises(PrehensionError, match=rf"tasks.jsonl:{line}: not a prehension batch record"):
        with open_journal(path):
            pass
    assert path.read_text() == text


def test_what_a_crash_leaves_at_the_end_is_cut(tmp_path):
    path = tmp_path / "out.jsonl"
    good = json.dumps(record(0), separators=(",", ":")) + "\n"
    path.write_bytes(good.encode() + b"\0" * 50 + b"\n" + b'{"prehension":"batch/1","id":"t1"' + b"\0" * 9)
    with open_journal(path) as (_, state):
        assert set(state.done) == {"t0"} and len(state.notes) == 2
    assert path.read_text() == good


# -- on the cluster -----------------------------------------------------------------------
def test_a_batch_gives_what_solving_one_by_one_gives(client, twenty_tasks, tmp_path, capsys):
    out = tmp_path / "out.jsonl"
    summary = run_batch(twenty_tasks, out, client, BatchOptions(method="local"))
    entries = read_inputs(twenty_tasks)
    records = read_records(out)
    # gave up: the 60 mm pincer (every built-in solves, scalpel-incision since the SA palm lies inside its published shape)
    assert summary.written == 20 and summary.remaining == 0 and summary.counts == {"solved": 19, "gave_up": 1}
    assert_same_as_alone(records, entries)
    assert {r["seed"] for r in records} == {task_seed(0, e.id) for e in entries}
    # a record with its task line is a whole result file: `prehension check` re-verifies it alone
    one = tmp_path / "one.json"
    one.write_text(json.dumps(next(r for r in read_records(out, embed_tasks=True) if r["task"] == "pincer-40")["result"]))
    assert main(["check", str(one)]) == EXIT_OK
    # nothing left to do on a re-run
    again = run_batch(twenty_tasks, out, client, BatchOptions(method="local"))
    assert again.skipped == 20 and again.written == 0 and len(read_records(out)) == 20


def test_resume_after_a_crash_and_after_ctrl_c(client, twenty_tasks, tmp_path):
    out = tmp_path / "out.jsonl"
    options = BatchOptions(method="local", chunk_size=2)
    first = run_batch(twenty_tasks, out, client, BatchOptions(method="local", chunk_size=2, max_tasks=6))
    assert first.written == 6 and first.remaining == 14 and len(read_records(out)) == 6
    lines = out.read_bytes().split(b"\n")
    fifth = [i for i, line in enumerate(lines) if line.startswith(b'{"prehension":"batch/1"')][4]
    kept = lines[: fifth + 1]  # five records and the task lines before them
    with open(out, "r+b") as fh:  # a crash in the middle of writing the sixth record
        fh.truncate(sum(len(line) + 1 for line in kept) + 40)

    def stop_after_two_chunks(p):
        if p.done >= 4:
            raise KeyboardInterrupt

    second = run_batch(twenty_tasks, out, client, options, stop_after_two_chunks)
    assert second.interrupted and second.skipped == 5 and 4 <= second.written < 15
    assert any("torn" in note for note in second.notes)
    third = run_batch(twenty_tasks, out, client, options)
    assert not third.interrupted and third.remaining == 0
    records = read_records(out)
    assert out.read_bytes().split(b"\n")[: len(kept)] == kept  # what was solved before is not solved again
    assert_same_as_alone(records, read_inputs(twenty_tasks))


def test_gave_up_is_done_unless_retried(client, tmp_path):
    tasks = write_jsonl(tmp_path / "t.jsonl", [task_to_dict(pincer_task(60.0)), task_to_dict(pincer_task(40.0))])
    out = tmp_path / "out.jsonl"
    assert run_batch(tasks, out, client, BatchOptions(method="local")).counts == {"gave_up": 1, "solved": 1}
    assert run_batch(tasks, out, client, BatchOptions(method="local")).skipped == 2
    retried = run_batch(tasks, out, client, BatchOptions(method="local", retry_gave_up=True))
    assert retried.skipped == 1 and retried.counts == {"gave_up": 1}
    assert sorted(r["status"] for r in read_records(out)) == ["gave_up", "solved"]  # still one record per task


def test_the_complete_method_and_invalid_tasks(client, tmp_path):
    bad = dict(task_to_dict(pincer_task(40.0)), name="broken", contacts=[{"hand": "tip", "object": "nowhere"}])
    tasks = write_jsonl(tmp_path / "t.jsonl", [task_to_dict(pincer_task(40.0)), task_to_dict(pincer_task(60.0)), bad])
    out = tmp_path / "out.jsonl"
    summary = run_batch(tasks, out, client, BatchOptions(method="complete", time_limit_s=60))
    assert summary.counts == {"solved": 1, "infeasible": 1, "invalid": 1} and summary.remaining == 1
    by_task = {r["status"]: r for r in read_records(out)}
    assert "t.jsonl:3" in by_task["invalid"]["message"] and "nowhere" in by_task["invalid"]["message"]
    assert by_task["infeasible"]["result"]["method"] == "complete"
    good = [e for e in read_inputs(tasks) if e.name == "pincer-40"]
    assert_same_as_alone([by_task["solved"]], good, method="complete")


def test_the_cli_on_a_running_scheduler(client, twenty_tasks, tmp_path):
    out = tmp_path / "out.jsonl"
    address = client.scheduler.address
    code = main(["batch", twenty_tasks, "-o", str(out), "--method", "local", "--scheduler", address, "--max-tasks", "3", "--quiet"])
    assert code == EXIT_GAVE_UP and len(read_records(out)) == 3  # tasks left: re-run to go on
    code = main(["batch", twenty_tasks, "-o", str(out), "--method", "local", "--scheduler", address, "--quiet"])
    assert code == EXIT_OK and len({r["id"] for r in read_records(out)}) == len(read_records(out)) == 20


def test_the_offline_search_on_the_cluster_gives_the_same_sequence(client, sa_hand):
    from prehension.parallel import DaskExecutor
    from prehension.solvers.local import LocalOptions
    from prehension.solvers.local.offline import OfflineSearch, offline_sequence

    search = OfflineSearch(M=8, N=3, imax=2, seed=5, n_samples=200, options=LocalOptions(k_max=20))
    inline = offline_sequence(sa_hand, search)
    on_cluster = offline_sequence(sa_hand, search, executor=DaskExecutor(client))
    np.testing.assert_array_equal(inline.lambdas, on_cluster.lambdas)
    for a, b in zip(inline.success, on_cluster.success):
        np.testing.assert_array_equal(a, b)


def test_the_complete_solver_runs_its_boxes_on_the_cluster(client):
    from prehension.parallel import DaskExecutor
    from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete

    executor = DaskExecutor(client)
    for d, status in ((40.0, "solved"), (60.0, "infeasible")):
        result = solve_complete(pincer_task(d), BranchAndPruneOptions(verifier=LocalVerifier()), executor=executor, workers=executor.max_workers)
        assert result.status == status


def test_a_killed_worker_loses_nothing_and_duplicates_nothing(client, tmp_path):
    """Kill a busy worker after the first result; Dask reruns its chunks elsewhere."""
    lines = [task_to_dict(pincer_task(d)) for d in (30.0, 32.0, 34.0, 36.0, 38.0, 40.0, 42.0, 44.0, 60.0)]
    tasks = write_jsonl(tmp_path / "t.jsonl", lines + [{"task": "teapot-service"}, {"task": "scalpel-upholding"}])
    out = tmp_path / "out.jsonl"
    pids = client.run(os.getpid)
    killed = {}

    def busy_workers() -> dict:
        for _ in range(100):  # both are busy at once but for a moment between chunks
            busy = {w: list(keys) for w, keys in client.processing().items() if keys and w in pids}
            if busy:
                return busy
            time.sleep(0.05)
        return {}

    def kill_a_busy_worker(p):
        if p.done >= 1 and not killed:
            address, running = sorted(busy_workers().items())[0]
            killed[address] = running
            os.kill(pids[address], signal.SIGKILL)

    options = BatchOptions(method="local", chunk_size=1, delay_s=0.4)
    summary = run_batch(tasks, out, client, options, kill_a_busy_worker)
    (address, running), = killed.items()
    assert running, "the killed worker was running a chunk"
    assert address not in client.run(os.getpid)  # it is gone (the nanny starts a new one)
    assert summary.remaining == 0 and summary.written == 11 and "error" not in summary.counts
    assert_same_as_alone(read_records(out), read_inputs(tasks))


def test_complete_box_search_on_the_cluster_is_the_one_process_search(client):
    """Issue 6: the box search on Dask visits the same boxes and gives the same answer."""
    from prehension.parallel import DaskExecutor
    from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete

    options = BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=300)
    for task in (pincer_task(50.0), pincer_task(40.0)):  # infeasible after tens of boxes; solved
        alone = solve_complete(task, options)
        spread = solve_complete(task, options, executor=DaskExecutor(client), workers=2)
        assert (spread.status, spread.stats["boxes"], spread.stats["lps"]) == (
            alone.status, alone.stats["boxes"], alone.stats["lps"])  # fmt: skip
        if alone.solutions:
            np.testing.assert_array_equal(spread.solutions[0].q, alone.solutions[0].q)


def test_a_batch_stores_a_shared_mesh_once_and_its_output_travels_alone(client, tmp_path, capsys):
    """Issue 28, item 8: the mesh the tasks share is stored once, and the output is re-checked alone."""
    from test_portable_results import _check_and_view, _mesh_task

    folder = tmp_path / "work"
    tasks = [_mesh_task(folder, f"t{k}.yaml", top_z=15.0) for k in range(3)]  # three tasks, one mesh
    listing = folder / "tasks.jsonl"
    listing.write_text("".join(json.dumps({"task": t.name}) + "\n" for t in tasks))
    out = folder / "out.jsonl"
    argv = ["batch", str(listing), "-o", str(out), "--method", "local", "--scheduler", client.scheduler.address, "--quiet"]
    assert main(argv) == EXIT_OK
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    kinds = [line["prehension"] for line in lines]
    assert kinds.count("batch-file/1") == 2 and kinds.count("batch-task/1") == 3 and kinds.count("batch/1") == 3
    assert all("files" not in line.get("result", {}) for line in lines if line["prehension"] == "batch/1")  # compact
    moved = tmp_path / "elsewhere" / "out.jsonl"
    moved.parent.mkdir()
    shutil.move(out, moved)
    shutil.rmtree(folder)
    capsys.readouterr()
    assert main(["check", str(moved)]) == EXIT_OK
    record = read_records(moved, embed_tasks=True)[0]
    assert sorted(record["result"]["files"]) == sorted(lines[2]["files"])  # as a result file carries them
    one = tmp_path / "one.json"
    one.write_text(json.dumps(record["result"]))
    _check_and_view(one, tmp_path, capsys)
