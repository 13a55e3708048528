"""The solvers on Dask (issue 6), for ``benchmarks/scaling.py``: the local solver on random
point problems, the complete solver's box search, the off-line sequence search -- each
inline and on clusters of 1 and 2 workers -- and the local solver with several chunk sizes.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from rich.table import Table

from prehension.parallel import DaskExecutor

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


def complete(task, options, client):
    from prehension.solvers.complete.search import solve_complete

    executor = DaskExecutor(client) if client is not None else None
    started = time.perf_counter()
    result = solve_complete(task, options, executor=executor, workers=executor.max_workers if executor else 1)
    return time.perf_counter() - started, (result.status, result.stats["boxes"])


def offline(client, M: int, N: int, imax: int):
    from prehension.solvers.local.offline import OfflineSearch, offline_sequence

    executor = DaskExecutor(client) if client is not None else None
    started = time.perf_counter()
    seq = offline_sequence(None, OfflineSearch(M=M, N=N, imax=imax, seed=0), executor=executor)
    return time.perf_counter() - started, tuple(map(tuple, np.round(seq.lambdas, 12).tolist()))


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
    from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
    from prehension.solvers.local import random_point_problems
    from prehension.solvers.local.verifier import LocalVerifier
    from prehension.tasks.library import load_builtin_task

    p = random_point_problems(20, seed=1)
    _solve_points(p.points, p.normals)
    solve_complete(load_builtin_task("guitar-holding"), BranchAndPruneOptions(verifier=LocalVerifier()))


def run_all(args, clients) -> Table:
    from prehension.solvers.complete.search import BranchAndPruneOptions
    from prehension.solvers.local import random_point_problems
    from prehension.solvers.local.verifier import LocalVerifier
    from prehension.tasks.library import load_builtin_task

    _warm_process()  # not timed: the first solve in a process loads kernels and builds caches
    for client in clients.values():
        if client is not None:
            client.run(_warm_process)
    table = Table(title=f"Dask local clusters on this machine: medians of {args.repeats} run(s); speed-up against 1 worker")
    for col in ("workload", "where", "time [s]", "min-max", "throughput", "speed-up", "found"):
        table.add_column(col, justify="left" if col in ("workload", "where", "found") else "right")
    problems = random_point_problems(args.problems, seed=0)
    res = measure(lambda c: local_points(problems, c, args.chunk), clients, args.repeats)
    add_rows(table, f"local solver, {args.problems} problems, chunks of {args.chunk}", args.problems, "problems/s", res,
             lambda s: f"{100 * s:.2f}% solved")  # fmt: skip
    guitar = load_builtin_task("guitar-holding")
    res = measure(lambda c: complete(guitar, BranchAndPruneOptions(verifier=LocalVerifier()), c), clients, args.repeats)
    add_rows(table, "complete solver, guitar-holding", 1, "tasks/s", res, lambda s: f"{s[0]}, {s[1]} boxes")
    hard = moved(load_builtin_task("teapot-lid-lifting"), "knob_back", (0, 0, args.hard_mm))
    res = measure(lambda c: complete(hard, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=args.boxes), c), clients, args.repeats)
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

