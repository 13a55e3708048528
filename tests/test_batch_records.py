"""Batch records (issue 16): compact (each task stored once), identical whatever the
chunking and the number of workers, re-checked by `prehension check`; the worker's cache
of parsed tasks; the client's chunk writer."""

from __future__ import annotations

import json

import pytest

from prehension.batch import BatchOptions, read_inputs, read_records, read_tasks, run_batch, with_task
from prehension.batch.journal import TASK_TAG, open_journal
from prehension.batch.loading import clear_cache, load_entry
from prehension.batch.records import ChunkOutput
from prehension.batch.run import _Run, _wire
from prehension.batch.solving import solve_chunk
from prehension.cli import EXIT_CHECK_FAILED, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.tasks.library import builtin_task_names
from prehension.tasks.yaml_io import dumps_task, task_to_dict
from conftest import write_jsonl
from tiny_tasks import pincer_task

TIMES = ("seconds",)  # measured, so they depend on the chunking; nothing else may


@pytest.fixture
def tasks_file(tmp_path):
    """Built-in tasks twice (same task, other ids), pincers (one beyond reach), a YAML file twice."""
    (tmp_path / "p38.yaml").write_text(dumps_task(pincer_task(38.0)))
    lines = [{"task": n} for n in builtin_task_names()[:4]]
    lines += [{"id": f"again-{n}", "task": n} for n in builtin_task_names()[:4]]
    lines += [task_to_dict(pincer_task(d)) for d in (30.0, 44.0, 60.0)]
    lines += [{"task": "p38.yaml"}, {"id": "p38-again", "task": "p38.yaml"}]
    return write_jsonl(tmp_path / "tasks.jsonl", lines)


def without_times(record: dict) -> dict:
    out = {k: v for k, v in record.items() if k not in TIMES}
    if isinstance(out.get("result"), dict):
        out["result"] = {k: v for k, v in out["result"].items() if k not in TIMES}
    return out


def by_id(records) -> dict:
    return {r["id"]: without_times(r) for r in records}


def test_records_are_identical_whatever_the_chunking_and_the_workers(client, tasks_file, tmp_path):
    runs = {}
    for name, size in (("chunks of 1", 1), ("chunks of 5", 5), ("default", None)):
        out = tmp_path / f"{name}.jsonl"
        summary = run_batch(tasks_file, out, client, BatchOptions(method="local", chunk_size=size))
        assert summary.remaining == 0 and summary.written == 13
        runs[name] = (by_id(read_records(out)), read_tasks(out))
    entries = read_inputs(tasks_file)
    clear_cache()
    inline = solve_chunk([_wire(e) for e in entries], BatchOptions(method="local"))  # one worker, one chunk
    runs["one chunk here"] = (by_id(json.loads(r.line) for r in inline.records),
                              {ref: json.loads(line)["task"] for ref, line in inline.tasks.items()})  # fmt: skip
    first, first_tasks = runs["chunks of 1"]
    assert sorted(first) == sorted(e.id for e in entries)
    assert sum(r["status"] == "solved" for r in first.values()) == 12  # the 60 mm pincer is beyond reach
    for name, (records, tasks) in runs.items():
        assert records == first, name
        assert tasks == first_tasks, name
    # one task line per distinct task: 4 built-in tasks + 3 inline pincers + the YAML file
    assert len(first_tasks) == 8
    assert first["again-" + builtin_task_names()[0]]["task_ref"] == next(
        r["task_ref"] for i, r in first.items() if i.startswith(builtin_task_names()[0]))  # fmt: skip


def test_compact_records_are_checked_and_self_contained_ones_are_the_same(client, tasks_file, tmp_path, capsys):
    compact, whole = tmp_path / "compact.jsonl", tmp_path / "whole.jsonl"
    run_batch(tasks_file, compact, client, BatchOptions(method="local"))
    run_batch(tasks_file, whole, client, BatchOptions(method="local", self_contained=True))
    lines = compact.read_text().splitlines()
    assert sum(json.loads(line)["prehension"] == TASK_TAG for line in lines) == 8
    assert not any(json.loads(line)["prehension"] == TASK_TAG for line in whole.read_text().splitlines())
    assert compact.stat().st_size < whole.stat().st_size  # 13 records, 8 distinct tasks
    full = by_id(read_records(whole))
    for record in read_records(compact, embed_tasks=True):
        mine = without_times(record)
        mine.pop("task_ref")
        assert mine == full[record["id"]]
    assert main(["check", str(compact)]) == EXIT_OK
    assert "DOES NOT HOLD" not in capsys.readouterr().out
    # a record whose task line is gone is not silently checked against nothing
    kept = [line for line in lines if json.loads(line)["prehension"] != TASK_TAG]
    compact.write_text("\n".join(kept) + "\n")
    assert main(["check", str(compact)]) == EXIT_CHECK_FAILED
    assert "missing" in capsys.readouterr().out
    with pytest.raises(PrehensionError, match="refers to task .* which is not in the file"):
        read_records(compact, embed_tasks=True)


def test_with_task_puts_the_task_back_where_a_result_file_has_it():
    record = {"id": "a", "task_ref": "r1", "result": {"prehension": "result/1", "units": {}, "frames": "", "status": "solved"}}
    whole = with_task(record, {"r1": {"name": "t"}})
    assert list(whole["result"]) == ["prehension", "units", "frames", "task", "status"]
    assert "task" not in record["result"]  # a copy
    assert with_task({"id": "b", "result": None}, {}) == {"id": "b", "result": None}


def test_the_journal_keeps_task_lines_through_a_repair(tmp_path):
    path = tmp_path / "out.jsonl"
    task = {"prehension": TASK_TAG, "ref": "r1", "task": {"name": "t"}}
    recs = [{"prehension": "batch/1", "id": f"t{i}", "status": s, "task_ref": "r1", "result": None}
            for i, s in enumerate(("solved", "error", "gave_up"))]  # fmt: skip
    torn = b'{"prehension":"batch-task/1","ref":"r2","ta'
    path.write_bytes("".join(json.dumps(x) + "\n" for x in [task] + recs).encode() + torn)
    with open_journal(path) as (journal, state):
        assert state.task_refs == {"r1"} and set(state.done) == {"t0", "t2"}
        assert any("torn" in n for n in state.notes) and any("solved again" in n for n in state.notes)
        assert journal.task_refs == {"r1"}
    assert read_tasks(path) == {"r1": {"name": "t"}} and [r["id"] for r in read_records(path)] == ["t0", "t2"]


def test_the_client_writes_each_task_line_once_and_each_record_once(tmp_path):
    from prehension.batch.records import RecordLine

    def line(i, ref):
        return RecordLine(f"t{i}", "solved", ref, json.dumps({"prehension": "batch/1", "id": f"t{i}", "task_ref": ref}).encode() + b"\n")

    tasks = {r: json.dumps({"prehension": TASK_TAG, "ref": r, "task": {}}).encode() + b"\n" for r in ("a", "b")}
    with open_journal(tmp_path / "out.jsonl") as (journal, _):
        run = _Run(4, 0, None, journal)
        run.accept(ChunkOutput([line(0, "a"), line(1, "a")], {"a": tasks["a"]}))
        run.accept(ChunkOutput([line(1, "a"), line(2, "b"), line(3, "a")], tasks))  # t1 again: a re-run chunk
        run.close()
    kinds = [(d["prehension"], d.get("id") or d.get("ref")) for d in map(json.loads, (tmp_path / "out.jsonl").read_text().splitlines())]
    assert kinds == [(TASK_TAG, "a"), ("batch/1", "t0"), ("batch/1", "t1"), (TASK_TAG, "b"), ("batch/1", "t2"), ("batch/1", "t3")]
    assert run.counts == {"solved": 4}


def test_a_worker_parses_each_distinct_task_once(tasks_file):
    clear_cache()
    entries = {e.id: e for e in read_inputs(tasks_file)}
    yaml = [e for e in entries.values() if e.name == "p38"]
    builtin = [e for e in entries.values() if e.name == builtin_task_names()[0]]
    assert load_entry(yaml[0].payload) is load_entry(yaml[1].payload)
    assert load_entry(builtin[0].payload).task is load_entry(builtin[1].payload).task
    a, b = load_entry(yaml[0].payload), load_entry(builtin[0].payload)
    assert a.ref != b.ref and a.task_dict == task_to_dict(pincer_task(38.0))
    assert json.loads(a.task_line) == {"prehension": TASK_TAG, "ref": a.ref, "task": a.task_dict}


def test_a_write_error_reaches_the_client(tmp_path):
    from prehension.batch.journal import Appender

    with open_journal(tmp_path / "out.jsonl") as (journal, _):
        journal._fh.close()  # what a vanished disk looks like to the writer thread
        appender = Appender(journal)
        appender.put([b"{}\n"])
        with pytest.raises(PrehensionError, match="cannot write the batch output .*out.jsonl"):
            appender.close()


def test_default_chunks_grow_with_the_input_and_stay_balanced():
    local = BatchOptions(method="local")
    assert local.chunk_size_for(1800, 2) == 64 and local.chunk_size_for(100, 2) == 13 and local.chunk_size_for(3, 16) == 1
    assert BatchOptions(method="auto").chunk_size_for(1800, 2) == 1
    assert BatchOptions(method="local", chunk_size=5).chunk_size_for(1800, 2) == 5


def test_auto_solves_a_chunk_with_the_local_solver_then_alone_what_it_did_not_solve(tmp_path):
    """A chunk under ``auto``: the local batch, then the complete solver on what is left;
    each record is what ``solve(task, "auto")`` gives alone."""
    from prehension.batch.inputs import entry_task
    from prehension.batch.solving import task_seed
    from prehension.solve import SolveOptions, solve

    bad = dict(task_to_dict(pincer_task(40.0)), name="broken", contacts=[{"hand": "tip", "object": "nowhere"}])
    path = write_jsonl(tmp_path / "t.jsonl", [task_to_dict(pincer_task(40.0)), task_to_dict(pincer_task(60.0)), bad])
    entries = read_inputs(path)
    options = BatchOptions(method="auto", time_limit_s=60)
    records = {json.loads(r.line)["task"]: json.loads(r.line) for r in solve_chunk([_wire(e) for e in entries], options).records}
    assert {k: r["status"] for k, r in records.items()} == {"pincer-40": "solved", "pincer-60": "infeasible", "broken": "invalid"}
    for entry in entries[:2]:
        alone = solve(entry_task(entry.payload), SolveOptions(seed=task_seed(0, entry.id)))
        mine = records[entry.name]
        assert (mine["message"], mine["result"]["method"]) == (alone.message, alone.method)
        assert [s["joint_angles_rad"] for s in mine["result"]["solutions"]] == [s.joint_angles for s in alone.solutions]
        # a record leaves out the pre-grasp and squeeze a result file has (docs/batch.md: their cost)
        assert not any({"pregrasp", "squeeze"} & set(s) for s in mine["result"]["solutions"])


def test_auto_solves_a_task_the_local_solver_fails_with_the_local_solver_once(tmp_path, monkeypatch):
    """Issue 29: batch follows the one ``auto`` policy (:func:`prehension.solve.complete_after_local`);
    a task the local solver fails goes on to the complete solver from the chunk's local answer,
    it is not solved by the local solver a second time (it was, before: twice)."""
    import prehension.solvers.local as local
    from prehension.solvers.local import solver

    calls = []
    real = solver.solve_local_batch

    def counted(problems, *args, **kwargs):
        calls.append([p.name for p in problems])
        return real(problems, *args, **kwargs)

    monkeypatch.setattr(solver, "solve_local_batch", counted)
    monkeypatch.setattr(local, "solve_local_batch", counted)
    path = write_jsonl(tmp_path / "t.jsonl", [task_to_dict(pincer_task(40.0)), task_to_dict(pincer_task(60.0))])
    records = solve_chunk([_wire(e) for e in read_inputs(path)], BatchOptions(method="auto")).records
    assert [r.status for r in records] == ["solved", "infeasible"]
    assert sum("pincer-60" in names for names in calls) == 1 and sum("pincer-40" in names for names in calls) == 1
    message = json.loads(records[1].line)["message"]
    assert message.startswith("the local solver found no solution (") and "complete solver: " in message


def test_a_chunk_whose_batch_call_fails_is_solved_task_by_task(tmp_path, monkeypatch):
    """A bug that only the batch call meets costs speed, not answers."""
    import prehension.solvers.local as local
    from prehension.solvers.local import solver

    path = write_jsonl(tmp_path / "t.jsonl", [task_to_dict(pincer_task(d)) for d in (30.0, 40.0, 60.0)])
    wires = [_wire(e) for e in read_inputs(path)]
    batched = solve_chunk(wires, BatchOptions(method="local"))
    real = solver.solve_local_batch

    def fails_on_many(problems, *args, **kwargs):
        if len(problems) > 1:
            raise RuntimeError("a bug in the batch path")
        return real(problems, *args, **kwargs)

    monkeypatch.setattr(local, "solve_local_batch", fails_on_many)
    monkeypatch.setattr(solver, "solve_local_batch", fails_on_many)
    alone = solve_chunk(wires, BatchOptions(method="local"))
    assert [r.status for r in alone.records] == ["solved", "solved", "gave_up"]
    assert [without_times(json.loads(r.line)) for r in alone.records] == [without_times(json.loads(r.line)) for r in batched.records]
