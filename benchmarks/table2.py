"""Table 2 of Rosales et al. (IJRR 2011), re-run with prehension's complete solver.

For every built-in task and every CuikSuite problem file in ../shared/cuik-ijrr, it prints
the size of our polynomial system (n_v variables, n_e equations, d = n_v - rank of the
Jacobian at the solution found), the boxes and linear programs used and the time to the
first verified solution, next to the paper's numbers (64 cores, sigma = 0.1).  Then a
family of infeasible variants (contact regions moved beyond the hand's reach) with the
time to certify each, and the speed-up of two worker processes over one on the slowest
task.  Times are wall-clock on this machine; rerun to compare, and read ratios rather than
absolute values on a noisy machine.

    python benchmarks/table2.py                 # everything (several minutes)
    python benchmarks/table2.py --quick         # built-in tasks only, shorter limits
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from prehension.geometry.regions import BezierRegion
from prehension.objects.model import GraspObject
from prehension.paper import CUIK_FILE_TASKS, TABLE2
from prehension.solvers.complete.embedding import embed
from prehension.solvers.complete.formulation import build_system
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.tasks.cuik_import import import_world
from prehension.tasks.library import builtin_task_names, load_builtin_task
from prehension.tasks.model import Task

SHARED = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr"


def _tasks(include_shared: bool) -> list[tuple[str, Task, str]]:
    rows = [(name, load_builtin_task(name), name) for name in builtin_task_names()]
    if include_shared and SHARED.is_dir():
        for path in sorted(SHARED.glob("*/*/*.world")):
            key = f"{path.parent.parent.name}/{path.parent.name}"
            rows.append((f"file {key}", import_world(path), CUIK_FILE_TASKS[key]))
    return rows


def _dimension(task: Task, result) -> str:
    if not result.solutions:
        return "-"
    form = build_system(task)
    return str(form.system.solution_dimension(embed(form, result.solutions[0].configuration())))


def run_feasible(console: Console, include_shared: bool, limit: float) -> list[tuple[str, Task, float]]:
    table = Table(title="Table 2: first verified solution (depth first, sigma = 0.1, one process)")
    for col in ("task", "n_v", "n_e", "d", "paper n_v,n_e,d", "status", "boxes", "LPs", "time [s]", "paper [s]"):
        table.add_column(col, justify="right" if col not in ("task", "status") else "left")
    timings = []
    for label, task, paper_name in _tasks(include_shared):
        result = solve_complete(task, BranchAndPruneOptions(time_limit_s=limit))
        paper = TABLE2[paper_name]
        s = result.stats
        table.add_row(
            label, str(s["n_variables"]), str(s["n_equations"]), _dimension(task, result),
            f"{paper.n_v},{paper.n_e},{paper.d}", result.status, str(s["boxes"]), str(s["lps"]),
            f"{result.seconds:.2f}", f"{paper.seconds:g}",
        )  # fmt: skip
        timings.append((label, task, result.seconds))
    console.print(table)
    times = [t for _, _, t in timings]
    console.print(f"median time to first solution: {np.median(times):.2f} s; max {max(times):.2f} s "
                  f"(paper: median {np.median([r.seconds for r in TABLE2.values()]):.0f} s on 64 cores)")  # fmt: skip
    return timings


def _moved(task: Task, region: str, offset_mm) -> Task:
    regions = dict(task.object.regions)
    regions[region] = BezierRegion(regions[region].patch.transformed(np.eye(3), np.asarray(offset_mm, float)))
    obj = GraspObject(task.object.name, regions, task.object.primitives)
    return Task(f"{task.name} ({region} +{np.linalg.norm(offset_mm):g} mm)", task.hand, obj,
                task.contacts, task.fingers, task.description, task.idle_angles)  # fmt: skip


def infeasible_variants() -> list[Task]:
    lid, tuning = load_builtin_task("teapot-lid-lifting"), load_builtin_task("guitar-tuning")
    upholding = load_builtin_task("scalpel-upholding")
    return [
        _moved(lid, "knob_back", (0, 0, 600)),
        _moved(upholding, "grip_top", (0, 600, 0)),
        _moved(tuning, "key_lower_face", (0, 0, -600)),
        _moved(lid, "knob_back", (0, 0, 350)),
        _moved(lid, "knob_back", (0, 0, 300)),
    ]


def run_infeasible(console: Console, limit: float) -> None:
    table = Table(title=f"Infeasible variants: time to certify (limit {limit:g} s)")
    for col in ("task", "status", "boxes", "LPs", "time [s]"):
        table.add_column(col)
    for task in infeasible_variants():
        result = solve_complete(task, BranchAndPruneOptions(time_limit_s=limit))
        s = result.stats
        table.add_row(task.name, result.status, str(s["boxes"]), str(s["lps"]), f"{result.seconds:.2f}")
    console.print(table)


def run_speedup(console: Console, task: Task, label: str, limit: float) -> None:
    table = Table(title=f"Workers on the slowest task ({label})")
    for col in ("workers", "status", "boxes", "time [s]", "speed-up"):
        table.add_column(col)
    base = None
    for workers in (1, 2):
        started = time.perf_counter()
        if workers == 1:
            result = solve_complete(task, BranchAndPruneOptions(time_limit_s=limit))
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                result = solve_complete(task, BranchAndPruneOptions(time_limit_s=limit), executor=pool, workers=workers)
        seconds = time.perf_counter() - started
        base = base or seconds
        table.add_row(str(workers), result.status, str(result.stats["boxes"]), f"{seconds:.2f}", f"{base / seconds:.2f}")
    console.print(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="built-in tasks only, 30 s limits, no variants")
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds per task")
    args = parser.parse_args()
    console = Console(width=140)
    limit = 30.0 if args.quick else args.time_limit
    timings = run_feasible(console, include_shared=not args.quick, limit=limit)
    if args.quick:
        return
    run_infeasible(console, limit)
    label, task, _ = max(timings, key=lambda row: row[2])
    run_speedup(console, task, label, limit)


if __name__ == "__main__":
    main()
