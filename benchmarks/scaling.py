"""Scaling out on Dask distributed: `prehension batch` at the local solver's speed, and the
other parallel searches, on local clusters of 1 and 2 worker processes.

    python benchmarks/scaling.py                  # everything (~10 min on 2 cores, a cold compile included)
    python benchmarks/scaling.py --quick          # smaller sizes, one repeat, no cold compile
    python benchmarks/scaling.py --batch-only     # the batch tables only
    python benchmarks/scaling.py --stages-only    # one process only: per task, per stage, the client alone
    python benchmarks/scaling.py --per-builtin 8  # only: each built-in task's solve, 8 copies in one batch
    python benchmarks/scaling.py --per-builtin 8 --enclosing  # and on the SA hand with enclosing capsules

**Batch** (issue 16): the built-in tasks, ``--tasks`` of them (the nine, repeated, each with
its own id), method ``local``:

1. per task, in one process without Dask (``solve_chunk`` on chunks of 64: loading,
   the batch solve, verification, the JSON record), wall and CPU time; and the same for
   ``--distinct`` tasks that are all different (inline, each object moved by its own
   offset; other ones each repeat): every task parsed, grouped, verified and its quality
   measured on its own;
2. ``run_batch`` on clusters of 1 and 2 workers (records to a journal on disk): tasks/s,
   worker-seconds per task, the workers' CPU per task, the client process's CPU per task
   (the local cluster's scheduler runs in it too), speed-up against 1 worker;
3. the client's own cost per task, alone: precomputed chunk outputs appended to a journal
   (``_Run.accept``: one write and one fsync per chunk, progress per chunk); then where a
   task's time goes in one process: the worker's seconds per stage (``ChunkOutput.stages``:
   load, solve, quality, record) and the client's write, per task;
4. bytes per record (compact and self-contained), what travels per task, Dask's cost per
   Dask task (no-op tasks), and what follows for a cluster of hundreds of workers;
5. a fresh worker's first chunk with a cold numba cache (``NUMBA_CACHE_DIR`` an empty
   folder: every kernel compiled) and with that cache warm.

**Solvers** (unless ``--batch-only``): the local solver on random SA-hand problems, the
complete solver's box search and the off-line sequence search, each inline and on 1 and 2
workers; then the local solver with several chunk sizes.

Cluster start-up and a warm-up in every process are not in the times (but in table 5).

**Per built-in** (``--per-builtin N``, alone): each built-in task ``N`` times in one
``solve_local_batch`` call (one process, warm), the solve's CPU per copy and the
re-verification's (``LocalRecord.to_result``: the one residual function, idle fingers
settled), and how many copies were solved strictly: which tasks the batch's solve stage
spends its time on.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import pickle  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from prehension.parallel import cluster  # noqa: E402

CHUNK = 64  # tasks per chunk where the benchmark chooses


# -- inputs --------------------------------------------------------------------------------------
def builtin_lines(n: int) -> list[dict]:
    """``n`` tasks: the nine built-in tasks in turn, each line with its own id."""
    from prehension.tasks.library import builtin_task_names

    names = builtin_task_names()
    return [{"id": f"{names[i % len(names)]}-{i}", "task": names[i % len(names)]} for i in range(n)]


def distinct_lines(n: int, first: int = 0) -> list[dict]:
    """``n`` different tasks written inline: the nine built-in tasks in turn, each object
    moved by its own offset (the object pose absorbs it: as solvable, but no two tasks
    alike, so that every task is parsed, grouped, verified and measured on its own);
    tasks ``first .. first + n - 1`` of that sequence (another ``first``: other tasks)."""
    from prehension.geometry.regions import BezierRegion, PointRegion, SphereCap
    from prehension.objects.model import GraspObject
    from prehension.tasks.library import builtin_task_names, load_builtin_task
    from prehension.tasks.yaml_io import task_to_dict

    def moved(region, t):
        if isinstance(region, BezierRegion):
            return BezierRegion(region.patch.transformed(np.eye(3), t))
        if isinstance(region, SphereCap):
            return SphereCap(region.center + t, region.radius, region.axis, region.half_angle)
        return PointRegion(region.point + t, region.normal)

    tasks = [load_builtin_task(name) for name in builtin_task_names()]
    lines = []
    for i in range(first, first + n):
        task, t = tasks[i % len(tasks)], np.array([0.01 * (i + 1), 0.0, 0.0])
        obj = GraspObject(task.object.name, {k: moved(r, t) for k, r in task.object.regions.items()}, task.object.primitives)
        lines.append({"id": f"distinct-{i}", "task": task_to_dict(replace(task, object=obj))})
    return lines


def wired(lines: list[dict], folder: Path, name: str = "tasks.jsonl") -> tuple[Path, list[dict]]:
    from prehension.batch import read_inputs
    from prehension.batch.run import _wire

    path = folder / name
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return path, [_wire(e) for e in read_inputs(path)]


def _warm_worker() -> None:
    """Load the compiled kernels and build the hand's tables in this process (not timed)."""
    from prehension.batch.solving import BatchOptions, solve_chunk

    solve_chunk([{"id": f"w{i}", "name": n, "source": "warm-up", "payload": {"kind": "builtin", "name": n}}
                 for i, n in enumerate(["guitar-holding", "teapot-service", "scalpel-upholding"])],
                BatchOptions(method="local"))  # fmt: skip


def _cpu() -> float:
    return time.process_time()


# -- 1. one process ------------------------------------------------------------------------------
def inline(entries: list[dict], self_contained: bool = False):
    """Solve every entry in this process, chunks of CHUNK: (wall s, cpu s, chunk outputs)."""
    from prehension.batch.solving import BatchOptions, solve_chunk

    options = BatchOptions(method="local", self_contained=self_contained)
    outputs = []
    wall, cpu = time.perf_counter(), _cpu()
    for s in range(0, len(entries), CHUNK):
        outputs.append(solve_chunk(entries[s : s + CHUNK], options))
    return time.perf_counter() - wall, _cpu() - cpu, outputs


# -- 2. on a cluster -----------------------------------------------------------------------------
def on_cluster(client, tasks: Path, folder: Path) -> dict:
    """One ``run_batch``: wall, and the CPU seconds of the workers and of this process."""
    from prehension.batch import BatchOptions, run_batch

    out = folder / f"out-{time.perf_counter_ns()}.jsonl"
    before = client.run(_cpu)
    wall, cpu = time.perf_counter(), _cpu()
    summary = run_batch(tasks, out, client, BatchOptions(method="local"))
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    after = client.run(_cpu)
    assert summary.remaining == 0 and summary.written == summary.tasks, summary
    return {"wall": wall, "client_cpu": cpu, "worker_cpu": sum(after[w] - before[w] for w in after if w in before),
            "solved": summary.counts.get("solved", 0), "bytes": out.stat().st_size}  # fmt: skip


def _inline_row(table: Table, label: str, runs) -> None:
    n = sum(len(o.records) for o in runs[0][2])
    wall, cpu = statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)
    solved = sum(json.loads(r.line)["status"] == "solved" for o in runs[0][2] for r in o.records)
    table.add_row(label, f"{wall:.2f}", f"{n / wall:.0f}", f"{1e3 * wall / n:.2f}", f"{1e3 * cpu / n:.2f}", "-", "",
                  f"{solved}/{n}")  # fmt: skip


def _on_clusters(tasks: Path, folder: Path, repeats: int) -> dict:
    """``{workers: [runs]}`` on a local cluster of 1, then of 2 workers (one at a time, so
    that no idle cluster shares the cores), each warmed up first."""
    results = {}
    for workers in (1, 2):
        with cluster(workers=workers) as client:
            client.run(_warm_worker)
            results[workers] = [on_cluster(client, tasks, folder) for _ in range(repeats)]
    return results


def _batch_columns(table: Table) -> Table:
    for col in ("where", "time [s]", "tasks/s", "per task [ms]", "worker CPU / task [ms]", "client CPU / task [ms]",
                "speed-up", "solved"):  # fmt: skip
        table.add_column(col, justify="left" if col == "where" else "right")
    return table


def inline_runs(args, entries: list[dict], folder: Path) -> dict:
    """``{label: [inline runs]}``: the built-in tasks, then (``--distinct``) distinct inline tasks."""
    runs = {"one process, no Dask": [inline(entries) for _ in range(args.repeats)]}
    if args.distinct:  # other tasks each repeat: none of them met before (parsed, measured afresh)
        repeats = [wired(distinct_lines(args.distinct, r * args.distinct), folder, f"distinct-{r}.jsonl")[1]
                   for r in range(args.repeats)]  # fmt: skip
        runs[f"  {args.distinct} distinct inline tasks, no Dask"] = [inline(distinct) for distinct in repeats]
    return runs


def batch_table(args, tasks: Path, entries: list[dict], runs: dict, folder: Path) -> Table:
    n = len(entries)
    title = f"prehension batch, {n} built-in tasks (the nine in turn), method local: medians of {args.repeats}"
    table = _batch_columns(Table(title=title))
    for label, label_runs in runs.items():
        _inline_row(table, label, label_runs)
    if args.stages_only:
        return table
    results = _on_clusters(tasks, folder, args.repeats)
    base = statistics.median(r["wall"] for r in results[1])
    for workers, rs in results.items():
        med = {k: statistics.median(r[k] for r in rs) for k in ("wall", "client_cpu", "worker_cpu")}
        table.add_row(
            f"{workers} worker{'s' if workers > 1 else ''}", f"{med['wall']:.2f}", f"{n / med['wall']:.0f}",
            f"{1e3 * med['wall'] * workers / n:.2f}", f"{1e3 * med['worker_cpu'] / n:.2f}", f"{1e3 * med['client_cpu'] / n:.2f}",
            f"{base / med['wall']:.2f}x", f"{rs[0]['solved']}/{n}",
        )  # fmt: skip
    table.caption = ("per task = wall x workers / tasks (worker-seconds per task, Dask and the client included); "
                     "the client process also runs the local cluster's scheduler and nannies")  # fmt: skip
    return table


# -- 1b. where a task's time goes ----------------------------------------------------------------
def stages_table(runs: dict, client_s: float) -> Table:
    """Per task, the worker's CPU seconds in each stage (``ChunkOutput.stages``, medians over
    the repeats) and the client's cost (table 3): what a task costs beyond its solve."""
    from prehension.batch.records import STAGES

    table = Table(title="Where a task's time goes, one process, no Dask (CPU ms per task; medians of the repeats)")
    for col in ("tasks", *STAGES, "write (client)", "beyond the solve", "all", "beyond the solve, wall"):
        table.add_column(col, justify="left" if col == "tasks" else "right")
    for label, label_runs in runs.items():
        n = sum(len(o.records) for o in label_runs[0][2])

        def per_task(stage: str, which: int) -> float:
            return 1e3 * statistics.median(sum(o.stages[stage][which] for o in r[2]) for r in label_runs) / n

        ms = {s: per_task(s, 1) for s in STAGES}
        ms["write (client)"] = 1e3 * client_s
        beyond = sum(v for k, v in ms.items() if k != "solve")
        beyond_wall = sum(per_task(s, 0) for s in STAGES if s != "solve") + ms["write (client)"]
        table.add_row(label.strip().replace(", no Dask", "").replace("one process", "the built-in tasks"),
                      *(f"{ms[k]:.3f}" for k in ms), f"{beyond:.3f}", f"{beyond + ms['solve']:.3f}", f"{beyond_wall:.3f}")  # fmt: skip
    table.caption = ("load: parse (or find in the worker's cache) the task; solve: the local batch call and each "
                     "answer's verification; quality: the stored quality of each solution (measured once per "
                     "distinct grasp); record: the result as a JSON line; write: the client's own cost per task "
                     "(table 3: the largest of its loop wall, its CPU and the wall until fsynced), on another process; "
                     "CPU of the worker's thread, wall in the last column (above it when the machine is busy)")  # fmt: skip
    return table


# -- 3. the client alone -------------------------------------------------------------------------
def client_table(outputs, folder: Path, repeats: int) -> tuple[Table, float]:
    """Precomputed chunk outputs appended to a fresh journal, as the client does: the loop's
    wall time, then the CPU (loop and writer thread) and wall time until all is fsynced."""
    from prehension.batch.journal import open_journal
    from prehension.batch.run import _Run

    n = sum(len(o.records) for o in outputs)
    loops, cpus, walls = [], [], []
    for _ in range(repeats):
        with open_journal(folder / f"client-{time.perf_counter_ns()}.jsonl") as (journal, _):
            run = _Run(n, 0, lambda p: None, journal)
            wall, cpu = time.perf_counter(), _cpu()
            for output in outputs:
                run.accept(output)
            loops.append(time.perf_counter() - wall)
            run.close()  # the writer thread: what is still queued, written and fsynced
            walls.append(time.perf_counter() - wall)
            cpus.append(_cpu() - cpu)
    table = Table(title=f"The client alone: {n} precomputed records in {len(outputs)} chunks appended to a journal, "
                        f"medians of {repeats}")  # fmt: skip
    for col in ("client loop, wall / task [us]", "CPU / task, loop + writer [us]", "until all fsynced, wall / task [us]",
                "records/s the client can take"):  # fmt: skip
        table.add_column(col, justify="right")
    loop, cpu, wall = (statistics.median(x) for x in (loops, cpus, walls))
    worst = max(loop, cpu, wall)
    table.add_row(f"{1e6 * loop / n:.1f}", f"{1e6 * cpu / n:.1f}", f"{1e6 * wall / n:.1f}", f"{n / worst:,.0f}")
    table.caption = ("the loop queues each chunk for the writer thread (one write + one fsync for what is queued) and "
                     "moves on; records/s from the largest of the three")  # fmt: skip
    return table, worst / n


# -- 4. bytes, wire, Dask ------------------------------------------------------------------------
def _noop(x):
    return x


def dask_cost(client, n: int = 400) -> float:
    """Seconds per Dask task of no-op tasks, ``2 x workers`` in flight as the batch keeps them."""
    from distributed import as_completed

    from prehension.parallel import worker_count

    window, k = 2 * worker_count(client), 0
    started = time.perf_counter()
    futures = as_completed([client.submit(_noop, i, pure=False) for i in range(window)])
    k = window
    for f in futures:
        f.result()
        if k < n:
            futures.add(client.submit(_noop, k, pure=False))
            k += 1
    return (time.perf_counter() - started) / n


def dask_throughput(client, n: int = 2000) -> float:
    """Seconds per Dask task of ``n`` no-op tasks submitted at once (the scheduler's pace)."""
    from distributed import wait

    started = time.perf_counter()
    wait(client.map(_noop, range(n), pure=False))
    return (time.perf_counter() - started) / n


def wire_table(entries, outputs, whole_outputs, client, per_task_s: float, client_s: float) -> Table:
    from prehension.batch.solving import BatchOptions

    n = len(entries)
    compact = sum(len(r.line) for o in outputs for r in o.records) / n
    task_lines = {ref: len(line) for o in outputs for ref, line in o.tasks.items()}
    whole = sum(len(r.line) for o in whole_outputs for r in o.records) / n
    out_bytes = len(pickle.dumps((entries[:CHUNK], BatchOptions(method="local")))) / CHUNK
    back_bytes = statistics.mean(len(pickle.dumps(o)) / len(o.records) for o in outputs)
    dask_s, pace_s = dask_cost(client), dask_throughput(client)
    table = Table(title="What travels and what is stored, per task; and the ceilings of one client and one scheduler")
    for col in ("quantity", "value"):
        table.add_column(col, justify="left" if col == "quantity" else "right")
    rows = [
        ("record, compact (task by reference)", f"{compact:,.0f} bytes"),
        (f"task lines ({len(task_lines)} distinct tasks, once each)", f"{sum(task_lines.values()):,} bytes in all"),
        ("record, self-contained (--self-contained)", f"{whole:,.0f} bytes"),
        ("sent to a worker (pickled chunk of built-in names)", f"{out_bytes:,.0f} bytes"),
        ("back from a worker (pickled chunk output, task lines included)", f"{back_bytes:,.0f} bytes"),
        ("Dask, round trip of one Dask task (no-op, 2 per worker in flight)", f"{1e3 * dask_s:.2f} ms"),
        (f"  the same per task, in chunks of {CHUNK}", f"{1e6 * dask_s / CHUNK:.1f} us"),
        ("Dask, 2000 no-op tasks at once (scheduler and workers on these cores)", f"{1e3 * pace_s:.3f} ms per Dask task"),
        ("one worker, per task (one process, no Dask)", f"{1e3 * per_task_s:.2f} ms"),
        ("ceiling of the client alone", f"{1 / client_s:,.0f} tasks/s = {per_task_s / client_s:,.0f} workers"),
        (f"ceiling of one scheduler at ~1 ms per Dask task (Dask's docs), chunks of {CHUNK}",
         f"{CHUNK / 1e-3:,.0f} tasks/s = {per_task_s * CHUNK / 1e-3:,.0f} workers"),
        ("journal, written at the client's ceiling", f"{compact / client_s / 1e6:,.1f} MB/s"),
    ]  # fmt: skip
    for row in rows:
        table.add_row(*row)
    return table


# -- 5. a fresh worker -----------------------------------------------------------------------------
def first_chunk(entries: list[dict], cache_dir: str | None) -> tuple[float, float, float]:
    """A new 1-worker cluster (``NUMBA_CACHE_DIR=cache_dir``, else numba's default: the
    package's ``__pycache__``): (start-up s, first chunk s, second chunk s)."""
    from prehension.batch.solving import BatchOptions, solve_chunk

    saved = os.environ.get("NUMBA_CACHE_DIR")
    if cache_dir is not None:
        os.environ["NUMBA_CACHE_DIR"] = cache_dir  # the worker process inherits it
    try:
        started = time.perf_counter()
        with cluster(workers=1) as client:
            up = time.perf_counter() - started
            times = []
            for chunk in (entries[:CHUNK], entries[CHUNK : 2 * CHUNK]):
                t = time.perf_counter()
                client.submit(solve_chunk, chunk, BatchOptions(method="local"), pure=False).result()
                times.append(time.perf_counter() - t)
    finally:
        if saved is None:
            os.environ.pop("NUMBA_CACHE_DIR", None)
        else:
            os.environ["NUMBA_CACHE_DIR"] = saved
    return up, times[0], times[1]


def fresh_worker_table(entries: list[dict], cold: bool) -> Table:
    table = Table(title=f"A fresh worker process: its first chunk of {CHUNK} tasks (and its second)")
    for col in ("numba cache", "cluster up [s]", "first chunk [s]", "second chunk [s]"):
        table.add_column(col, justify="left" if col == "numba cache" else "right")
    with tempfile.TemporaryDirectory() as empty:
        cases = ([("cold: NUMBA_CACHE_DIR empty (compiles)", empty)] if cold else []) + [
            ("warm: NUMBA_CACHE_DIR filled by the run above" if cold else "warm: the package's __pycache__", empty if cold else None)
        ]  # fmt: skip
        for label, folder in cases:
            up, first, second = first_chunk(entries, folder)
            table.add_row(label, f"{up:.1f}", f"{first:.2f}", f"{second:.2f}")
    return table


# -- the solvers on the cluster (issue 6) ------------------------------------------------------------
def _per_builtin_rows(tasks, copies: int, opt, sequence) -> list[tuple[float, float, int]]:
    """Per task: CPU ms per copy of the solve and of the re-verification, copies solved."""
    from prehension.results import Status
    from prehension.solvers.local import solve_local_batch

    solve_local_batch(tasks, opt, sequence, list(range(len(tasks))))  # warm: compiled code, geometry caches
    rows = []
    for task in tasks:
        a = time.process_time()
        found = solve_local_batch([task] * copies, opt, sequence, list(range(copies)))
        b = time.process_time()
        results = [r.to_result(task, opt, 0.0, {}) for r in found]
        c = time.process_time()
        rows.append(((b - a) / copies * 1e3, (c - b) / copies * 1e3, sum(r.status == Status.SOLVED for r in results)))
    return rows


def per_builtin_table(copies: int, enclosing: bool = False) -> Table:
    """Each built-in task ``copies`` times in one ``solve_local_batch`` call: CPU ms per copy
    of the solve and of the re-verification, and the copies solved strictly; with
    ``enclosing``, in the same run, the same tasks on the SA hand with enclosing capsules
    (:func:`~prehension.hands.sa_enclosing.with_enclosing_capsules`, the same initial-pose
    sequence) and the ratio of the solve times."""
    from prehension.hands.sa_enclosing import with_enclosing_capsules
    from prehension.solvers.local import LocalOptions
    from prehension.solvers.local.sequence import shipped_sequence
    from prehension.tasks.library import builtin_task_names, load_builtin_task

    names = builtin_task_names()
    tasks = [load_builtin_task(n) for n in names]
    opt = LocalOptions()
    rows = _per_builtin_rows(tasks, copies, opt, None)
    columns = ["task", "solve", "verify", "solved"]
    if enclosing:
        seq = replace(shipped_sequence(tasks[0].hand), hand="schunk-sa-enclosing")
        other = _per_builtin_rows([replace(t, hand=with_enclosing_capsules(t.hand)) for t in tasks], copies, opt, seq)
        columns += ["enclosing: solve", "verify", "solved", "solve ratio"]
    table = Table(title=f"Each built-in task {copies} times in one solve_local_batch call (CPU ms per copy)")
    for column in columns:
        table.add_column(column, justify="left" if column == "task" else "right")
    for k, (name, (sv, vf, ok)) in enumerate(zip(names, rows)):
        cells = [name, f"{sv:.2f}", f"{vf:.2f}", f"{ok}/{copies}"]
        if enclosing:
            sv2, vf2, ok2 = other[k]
            cells += [f"{sv2:.2f}", f"{vf2:.2f}", f"{ok2}/{copies}", f"{sv2 / sv:.2f}"]
        table.add_row(*cells)
    mean = ["mean", f"{np.mean([r[0] for r in rows]):.2f}", f"{np.mean([r[1] for r in rows]):.2f}", ""]
    if enclosing:
        s2 = np.mean([r[0] for r in other])
        mean += [f"{s2:.2f}", f"{np.mean([r[1] for r in other]):.2f}", "", f"{s2 / np.mean([r[0] for r in rows]):.2f}"]
    table.add_row(*mean, end_section=True)
    return table


def solvers_tables(args, clients) -> list[Table]:
    from _scaling_solvers import chunk_sweep, run_all

    one, two = clients[1], clients[2]
    return [run_all(args, {"inline": None, "1 worker": one, "2 workers": two}), chunk_sweep(args, two)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", type=int, default=1800, help="batch: built-in tasks (the nine, repeated)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--distinct", type=int, default=360, help="batch: also that many distinct inline tasks, one process")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold-cache compile (a minute or two)")
    parser.add_argument("--batch-only", action="store_true", help="only the batch tables")
    parser.add_argument("--stages-only", action="store_true", help="only one process: the batch per task, the client "
                        "alone and where a task's time goes (no cluster)")  # fmt: skip
    parser.add_argument("--problems", type=int, default=10_000, help="solvers: random point problems")
    parser.add_argument("--chunk", type=int, default=1000, help="solvers: problems per Dask task")
    parser.add_argument("--boxes", type=int, default=16, help="solvers: boxes of the hard search")
    parser.add_argument("--hard-mm", type=float, default=165.0, help="solvers: how far the knob's back face moves")
    parser.add_argument("--chunks", type=int, nargs="+", default=(100, 250, 1000, 2500), help="solvers: chunk sizes")
    parser.add_argument("--offline", type=int, nargs=3, default=(300, 6, 2), metavar=("M", "N", "IMAX"))
    parser.add_argument("--per-builtin", type=int, metavar="N", help="only: each built-in task N times in one batch solve")
    parser.add_argument("--enclosing", action="store_true", help="with --per-builtin: also on the SA hand with enclosing capsules")
    parser.add_argument("--quick", action="store_true", help="360 tasks, one repeat, no cold compile, smaller solver runs")
    args = parser.parse_args()
    if args.quick:
        args.tasks, args.repeats, args.no_cold, args.distinct = 360, 1, True, 90
        args.problems, args.boxes, args.offline = 2000, 6, (100, 4, 2)
    console = Console(width=170)
    started = time.perf_counter()
    console.print(f"load average at the start {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)")
    if args.per_builtin:
        console.print(per_builtin_table(args.per_builtin, args.enclosing))
        console.print(f"load average at the end {os.getloadavg()[0]:.1f}")
        return
    _warm_worker()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        tasks, entries = wired(builtin_lines(args.tasks), folder)
        runs = inline_runs(args, entries, folder)
        console.print(batch_table(args, tasks, entries, runs, folder))
        outputs = next(iter(runs.values()))[0][2]
        client, client_s = client_table(outputs, folder, args.repeats)
        console.print(client)
        console.print(stages_table(runs, client_s))
        if args.stages_only:
            console.print(f"whole run: {time.perf_counter() - started:.0f} s; load average at the end {os.getloadavg()[0]:.1f}")
            return
        wall, _, _ = inline(entries)
        whole = inline(entries, self_contained=True)[2]
        with cluster(workers=2) as two:
            console.print(wire_table(entries, outputs, whole, two, wall / len(entries), client_s))
        if not args.batch_only:
            with cluster(workers=1) as one, cluster(workers=2) as two:
                for t in solvers_tables(args, {1: one, 2: two}):
                    console.print(t)
        console.print(fresh_worker_table(entries, cold=not args.no_cold))
    console.print(f"whole run: {time.perf_counter() - started:.0f} s; load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
