"""Scaling out on Dask distributed: 1 and 2 workers of a local cluster on this machine.

    python benchmarks/scaling.py              # the full run (several minutes on 2 cores)
    python benchmarks/scaling.py --quick      # smaller sizes, one repeat

Four workloads, each inline (no Dask) and on local clusters of 1 and 2 worker processes
(one thread each; BLAS pinned to one thread), medians of ``--repeats`` runs, speed-ups
against the 1-worker cluster:

1. the local solver on 10,000 random SA-hand problems (four fingertip contacts, seeded):
   ``solve_local_batch`` on chunks of ``--chunk`` problems, one Dask task per chunk;
2. ``prehension batch`` (``run_batch``): built-in and small inline tasks, method
   ``local``, records written to a journal -- the overhead of the whole path;
3. the complete solver through ``DaskExecutor``: the slowest built-in task
   (guitar-holding, depth first, time to the first solution), and a hard box search
   (teapot-lid-lifting with the knob's back face moved ``--hard-mm``, near the edge of
   feasibility) for ``--boxes`` boxes;
4. the off-line sequence search on a reduced ``M``, ``N``, ``i_max`` (same lambdas checked);

then the local solver on 2 workers with several chunk sizes.  Cluster start-up and a
warm-up solve in every process are not in the times.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

from prehension.parallel import DaskExecutor, cluster  # noqa: E402

CONFIGS = ("inline", "1 worker", "2 workers")


# -- workloads: each returns (seconds, what it found) -------------------------------------------
def _solve_points(points, normals):
    """On a worker: solve a chunk of point problems; (success (P,), q (P, n_dof))."""
    from prehension.hands.sa_hand import schunk_sa_hand
    from prehension.solvers.local import LocalOptions, PointProblems, solve_local_batch
    from prehension.solvers.local.problems import SA_FOUR_TIPS

    batch = solve_local_batch(PointProblems(schunk_sa_hand(), SA_FOUR_TIPS, points, normals), LocalOptions(), rng=0)
    q = np.array([r.joint_angles if r.success else np.full(len(schunk_sa_hand().dof_names), np.nan) for r in batch])
    return batch.success, q


def local_points(problems, client, chunk: int):
    from distributed import as_completed

    started = time.perf_counter()
    if client is None:
        success, _ = _solve_points(problems.points, problems.normals)
        return time.perf_counter() - started, float(success.mean())
    starts = range(0, len(problems), chunk)
    futures = [
        client.submit(_solve_points, problems.points[s : s + chunk], problems.normals[s : s + chunk], pure=False)
        for s in starts
    ]
    solved = sum(int(f.result()[0].sum()) for f in as_completed(futures))
    return time.perf_counter() - started, solved / len(problems)


def batch_tasks(lines, client, folder: Path):
    from prehension.batch import BatchOptions, read_inputs, run_batch
    from prehension.batch.solving import solve_chunk

    tasks = folder / "tasks.jsonl"
    tasks.write_text("".join(json.dumps(line) + "\n" for line in lines))
    out = folder / f"out-{time.perf_counter_ns()}.jsonl"
    started = time.perf_counter()
    if client is None:
        from prehension.batch.run import _wire

        records = solve_chunk([_wire(e) for e in read_inputs(tasks)], BatchOptions(method="local"))
        return time.perf_counter() - started, sum(r["status"] == "solved" for r in records) / len(records)
    summary = run_batch(tasks, out, client, BatchOptions(method="local"))
    return time.perf_counter() - started, summary.counts.get("solved", 0) / summary.written


def complete(task, options, client):
    from prehension.solvers.complete.search import solve_complete

    executor = DaskExecutor(client) if client is not None else None
    started = time.perf_counter()
    result = solve_complete(task, options, executor=executor, workers=executor.max_workers if executor else 1)
    return time.perf_counter() - started, (result.status, result.stats["boxes"])


def offline(client, M: int, N: int, imax: int):
    from prehension.solvers.local.offline import offline_sequence

    executor = DaskExecutor(client) if client is not None else None
    started = time.perf_counter()
    seq = offline_sequence(None, M, N, imax, executor, seed=0)
    return time.perf_counter() - started, tuple(map(tuple, np.round(seq.lambdas, 12).tolist()))


# -- inputs ----------------------------------------------------------------------------------
def task_lines(n: int) -> list[dict]:
    """``n`` tasks: built-in ones and inline copies of teapot-lid-lifting, each with an id."""
    from prehension.tasks.library import builtin_task_names, load_builtin_task
    from prehension.tasks.yaml_io import task_to_dict

    names = builtin_task_names()
    lid = task_to_dict(load_builtin_task("teapot-lid-lifting"))
    return [{"id": f"t{i}", "task": names[i % len(names)] if i % 2 else lid} for i in range(n)]


def moved(task, region: str, offset_mm):
    """``task`` with one object region translated (a harder, near-infeasible search)."""
    from prehension.geometry.regions import BezierRegion
    from prehension.objects.model import GraspObject
    from prehension.tasks.model import Task

    regions = dict(task.object.regions)
    regions[region] = BezierRegion(regions[region].patch.transformed(np.eye(3), np.asarray(offset_mm, float)))
    obj = GraspObject(task.object.name, regions, task.object.primitives)
    return Task(f"{task.name} ({region} +{np.linalg.norm(offset_mm):g} mm)", task.hand, obj, task.contacts, task.fingers)


# -- running and printing ----------------------------------------------------------------------
def measure(run, clients, repeats: int) -> dict:
    """``{config: (run times [s], what the first run found)}``, configs interleaved per repeat."""
    times: dict = {c: [] for c in CONFIGS}
    found: dict = {}
    for _ in range(repeats):
        for config in CONFIGS:
            seconds, what = run(clients[config])
            times[config].append(seconds)
            found.setdefault(config, what)
    return {c: (times[c], found[c]) for c in CONFIGS}


def add_rows(table: Table, workload: str, size: float, unit: str, results: dict, describe) -> None:
    base = statistics.median(results["1 worker"][0])
    for config in CONFIGS:
        times, what = results[config]
        seconds = statistics.median(times)
        spread = f"{min(times):.2f}-{max(times):.2f}" if len(times) > 1 else ""
        table.add_row(workload, config, f"{seconds:.2f}", spread, f"{size / seconds:.1f} {unit}", f"{base / seconds:.2f}",
                      describe(what))  # fmt: skip
        workload = ""


def _warm_process() -> None:
    """Load numba's compiled kernels and both solvers' caches in this process."""
    from prehension.solvers.complete.search import solve_complete
    from prehension.solvers.local import random_point_problems
    from prehension.tasks.library import load_builtin_task

    p = random_point_problems(20, seed=1)
    _solve_points(p.points, p.normals)
    solve_complete(load_builtin_task("guitar-holding"))


def warm(clients) -> None:
    """Warm this process and every worker (not timed): the first solve in a process pays
    for loading compiled kernels and building caches."""
    _warm_process()
    for client in clients.values():
        if client is not None:
            client.run(_warm_process)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--problems", type=int, default=10_000, help="local solver: random problems")
    parser.add_argument("--chunk", type=int, default=1000, help="local solver: problems per Dask task")
    parser.add_argument("--tasks", type=int, default=200, help="prehension batch: tasks")
    parser.add_argument("--boxes", type=int, default=16, help="complete solver: boxes of the hard search")
    parser.add_argument("--hard-mm", type=float, default=165.0, help="complete solver: how far the knob's back face moves")
    parser.add_argument("--chunks", type=int, nargs="+", default=(100, 250, 1000, 2500), help="chunk sizes to compare")
    parser.add_argument("--offline", type=int, nargs=3, default=(300, 6, 2), metavar=("M", "N", "IMAX"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="2000 problems, 60 tasks, 6 boxes, M N imax = 100 4 2, one repeat")
    args = parser.parse_args()
    if args.quick:
        args.problems, args.tasks, args.boxes, args.offline, args.repeats = 2000, 60, 6, (100, 4, 2), 1
    console = Console(width=160)
    started = time.perf_counter()
    with cluster(workers=1) as one, cluster(workers=2) as two:
        console.print(f"two local clusters (1 + 2 workers) up in {time.perf_counter() - started:.1f} s")
        clients = {"inline": None, "1 worker": one, "2 workers": two}
        warm(clients)
        console.print(run_all(args, clients))
        console.print(chunk_sweep(args, two))
    console.print(f"whole run: {time.perf_counter() - started:.0f} s; {os.cpu_count()} cores; "
                  f"load average at the end {os.getloadavg()[0]:.1f}")  # fmt: skip


def run_all(args, clients) -> Table:
    from prehension.solvers.complete.search import BranchAndPruneOptions
    from prehension.solvers.local import random_point_problems
    from prehension.tasks.library import load_builtin_task

    table = Table(title=f"Dask local clusters on this machine: medians of {args.repeats} run(s); speed-up against 1 worker")
    for col in ("workload", "where", "time [s]", "min-max", "throughput", "speed-up", "found"):
        table.add_column(col, justify="left" if col in ("workload", "where", "found") else "right")
    problems = random_point_problems(args.problems, seed=0)
    res = measure(lambda c: local_points(problems, c, args.chunk), clients, args.repeats)
    add_rows(table, f"local solver, {args.problems} problems, chunks of {args.chunk}", args.problems, "problems/s", res,
             lambda s: f"{100 * s:.2f}% solved")  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        lines = task_lines(args.tasks)
        res = measure(lambda c: batch_tasks(lines, c, Path(folder)), clients, args.repeats)
    add_rows(table, f"prehension batch, {args.tasks} tasks, local", args.tasks, "tasks/s", res, lambda s: f"{100 * s:.0f}% solved")
    guitar = load_builtin_task("guitar-holding")
    res = measure(lambda c: complete(guitar, BranchAndPruneOptions(), c), clients, args.repeats)
    add_rows(table, "complete solver, guitar-holding", 1, "tasks/s", res, lambda s: f"{s[0]}, {s[1]} boxes")
    hard = moved(load_builtin_task("teapot-lid-lifting"), "knob_back", (0, 0, args.hard_mm))
    res = measure(lambda c: complete(hard, BranchAndPruneOptions(max_boxes=args.boxes), c), clients, args.repeats)
    add_rows(table, f"complete solver, {hard.name}, {args.boxes} boxes", args.boxes, "boxes/s", res,
             lambda s: f"{s[0]}, {s[1]} boxes")  # fmt: skip
    M, N, imax = args.offline
    res = measure(lambda c: offline(c, M, N, imax), clients, args.repeats)
    same = len({what for _, what in res.values()}) == 1
    add_rows(table, f"off-line search, M={M} N={N} imax={imax}", imax * N * N, "poses/s", res,
             lambda s: f"lambdas {s}" + (" (same everywhere)" if same else " (DIFFER)"))  # fmt: skip
    return table


def chunk_sweep(args, client) -> Table:
    """The local solver on 2 workers with several chunk sizes (Dask's overhead per task)."""
    from prehension.solvers.local import random_point_problems

    problems = random_point_problems(args.problems, seed=0)
    table = Table(title=f"Chunk size: local solver, {args.problems} problems, 2 workers, medians of {args.repeats}")
    for col in ("problems per Dask task", "Dask tasks", "time [s]", "min-max", "problems/s"):
        table.add_column(col, justify="right")
    for chunk in args.chunks:
        times = [local_points(problems, client, chunk)[0] for _ in range(args.repeats)]
        seconds = statistics.median(times)
        table.add_row(str(chunk), str(-(-args.problems // chunk)), f"{seconds:.2f}", f"{min(times):.2f}-{max(times):.2f}",
                      f"{args.problems / seconds:.0f}")  # fmt: skip
    return table


if __name__ == "__main__":
    main()
