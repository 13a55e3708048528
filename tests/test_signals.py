"""SIGTERM and SIGHUP stop a command as Ctrl-C does (issue 28, item 7): a complete search
writes its checkpoint and its partial result, a batch keeps what finished; each run resumes.

The signals are sent to a real ``prehension`` process, once it reports progress."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import prehension
from prehension.batch import read_records
from prehension.cli import EXIT_GAVE_UP, EXIT_OK
from prehension.tasks.yaml_io import dumps_task, task_to_dict
from tiny_tasks import pincer_task

SRC = str(Path(prehension.__file__).resolve().parents[1])


def _default_signals() -> None:
    """In the child: SIGTERM and SIGHUP at their default action, whatever the runner ignores
    (a CI job or ``nohup`` may start the suite with SIGHUP ignored, and an ignored signal
    stays ignored by design: cli/terminate.py)."""
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _start(argv, folder: Path, session: bool = False) -> tuple[subprocess.Popen, Path]:
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    err = folder / "stderr.txt"
    with open(folder / "stdout.txt", "wb") as out, open(err, "wb") as fh:
        proc = subprocess.Popen([sys.executable, "-m", "prehension.cli", *argv], stdout=out, stderr=fh, env=env,
                                start_new_session=session, preexec_fn=_default_signals)  # fmt: skip
    return proc, err


def _wait_for(ready, proc: subprocess.Popen, seconds: float = 120.0) -> None:
    deadline = time.monotonic() + seconds
    while not ready():
        assert proc.poll() is None, "the command ended before it could be interrupted"
        assert time.monotonic() < deadline, "the command never got going"
        time.sleep(0.2)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_signal_during_a_complete_search_writes_checkpoint_and_result(tmp_path, sig):
    task = tmp_path / "pincer.yaml"
    task.write_text(dumps_task(pincer_task(30.0)))
    ckpt, out = tmp_path / "search.json", tmp_path / "result.json"
    # sigma 0.002: a search of minutes, so it is still running when the signal arrives on a loaded machine
    argv = ["solve", str(task), "--method", "complete", "--all", "--sigma", "0.002", "--max-boxes", "1000000",
            "--time-limit", "0", "--checkpoint", str(ckpt), "-o", str(out)]  # fmt: skip
    proc, err = _start(argv, tmp_path)
    _wait_for(lambda: "complete solver: boxes" in err.read_text(errors="replace"), proc)  # searching
    proc.send_signal(sig)
    code = proc.wait(timeout=120)
    name = signal.Signals(sig).name
    result = json.loads(out.read_text())
    # as Ctrl-C: the search stopped early -- with no verified solution yet, "gave up"; with some
    # (--all keeps searching after the first), a partial description of the solution set
    if result["status"] == "gave_up":
        assert code == EXIT_GAVE_UP and result["message"].startswith(f"stopped: interrupted ({name}); search state saved")
    else:
        assert code == EXIT_OK and result["status"] == "solved"
        assert result["message"].startswith(f"partial description of the solution set (stopped: interrupted ({name}); search state saved")
    saved = json.loads(ckpt.read_text())
    assert saved["open"] and saved["boxes"] == result["stats"]["boxes"] > 0
    assert "Traceback" not in err.read_text()
    if sig != signal.SIGTERM:
        return  # the resume is the same for both signals
    # and it resumes where it stopped
    proc, _ = _start([*argv[:-2], "--resume", "--max-boxes", str(saved["boxes"] + 2), "-o", str(tmp_path / "again.json")], tmp_path)
    assert proc.wait(timeout=120) in (EXIT_OK, EXIT_GAVE_UP)
    again = json.loads((tmp_path / "again.json").read_text())
    assert again["stats"]["boxes"] == saved["boxes"] + 2 and again["stats"]["resumed"]["boxes"] == saved["boxes"]


@pytest.mark.slow  # a local cluster started twice (~25 s); Ctrl-C in a batch: tests/test_batch.py
def test_sigterm_during_a_batch_keeps_what_finished_and_the_batch_resumes(tmp_path):
    tasks = tmp_path / "tasks.jsonl"
    lines = [{"id": f"p{k}", "task": task_to_dict(pincer_task(30.0 + 0.5 * k))} for k in range(30)]
    tasks.write_text("".join(json.dumps(line) + "\n" for line in lines))
    out = tmp_path / "out.jsonl"
    argv = ["batch", str(tasks), "-o", str(out), "--method", "complete", "--workers", "1", "--chunk-size", "1"]
    proc, err = _start(argv, tmp_path)
    _wait_for(lambda: out.is_file() and b'"prehension":"batch/1"' in out.read_bytes(), proc)  # a record is in
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=120) == EXIT_GAVE_UP
    assert "interrupted" in (tmp_path / "stdout.txt").read_text() + err.read_text()
    done = read_records(out)
    assert 1 <= len(done) < 30 and "Traceback" not in err.read_text()
    proc, _ = _start(argv, tmp_path)
    assert proc.wait(timeout=300) == EXIT_OK
    records = read_records(out)
    assert sorted(r["id"] for r in records) == sorted(line["id"] for line in lines)  # each task once
    assert [r["id"] for r in records[: len(done)]] == [r["id"] for r in done]  # what finished is kept


@pytest.mark.slow  # a local cluster (~10 s)
def test_a_hang_up_of_the_whole_group_with_workers_is_a_clean_stop(tmp_path):
    """A closed terminal sends SIGHUP to every process of its group: the command saves as
    for Ctrl-C, and the cluster's processes (workers, multiprocessing's resource tracker)
    neither die first nor print tracebacks; none is left behind."""
    task = tmp_path / "pincer.yaml"
    task.write_text(dumps_task(pincer_task(30.0)))
    ckpt, out = tmp_path / "search.json", tmp_path / "result.json"
    argv = ["solve", str(task), "--method", "complete", "--all", "--sigma", "0.005", "--max-boxes", "1000000",
            "--time-limit", "0", "--workers", "2", "--checkpoint", str(ckpt), "-o", str(out)]  # fmt: skip
    proc, err = _start(argv, tmp_path, session=True)
    _wait_for(lambda: "complete solver: boxes" in err.read_text(errors="replace"), proc)
    os.killpg(proc.pid, signal.SIGHUP)
    assert proc.wait(timeout=120) == EXIT_GAVE_UP
    assert json.loads(out.read_text())["message"].startswith("stopped: interrupted (SIGHUP)") and ckpt.is_file()
    assert "Traceback" not in err.read_text() and "died unexpectedly" not in err.read_text()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        try:
            os.killpg(proc.pid, 0)  # anyone of the group left?
        except ProcessLookupError:
            break
        time.sleep(0.5)
    else:
        raise AssertionError("processes of the command's group were left behind")
