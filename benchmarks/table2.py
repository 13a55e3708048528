"""Table 2 of Rosales et al. (IJRR 2011), re-run with prehension's complete solver.

For every built-in task and every CuikSuite problem file in ../shared/cuik-ijrr, it prints
the size of our polynomial system (n_v variables, n_e equations, d = n_v - rank of the
Jacobian at the solution found), the boxes and linear programs used and the time to the
first verified solution, next to the paper's numbers (64 cores, sigma = 0.1).  Then a
family of infeasible variants (contact regions moved beyond the hand's reach, down to
10 mm past the last solved one) with the time to certify each, patches turned to face
away, and the speed-up of two worker processes over one on the longest searches.  The
times go to table2.png when matplotlib is installed.  Times are wall-clock on this machine; rerun to compare, and read ratios rather than
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

from prehension.paper import CUIK_FILE_TASKS, TABLE2
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.solvers.local.verifier import LocalVerifier
from prehension.tasks.cuik_import import import_world
from prehension.tasks.library import builtin_task_names, load_builtin_task
from prehension.tasks.model import Task
from prehension.tasks.variants import move_object_region, turn_object_region

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
        result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit))
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


def infeasible_variants() -> list[tuple[Task, str]]:
    """Regions moved beyond the hand's reach, nearest the frontier last, with what we know.

    The frontier of teapot-lid-lifting along z: see :func:`frontier_variants`.
    """
    lid, tuning = load_builtin_task("teapot-lid-lifting"), load_builtin_task("guitar-tuning")
    upholding = load_builtin_task("scalpel-upholding")
    return [
        (move_object_region(lid, "knob_back", (0, 0, 600)), "far"),
        (move_object_region(upholding, "grip_top", (0, 600, 0)), "far"),
        (move_object_region(tuning, "key_lower_face", (0, 0, -600)), "far"),
        (move_object_region(lid, "knob_back", (0, 0, 300)), "just beyond reach"),
        (move_object_region(lid, "knob_back", (0, 0, 200)), "just beyond reach"),
        (move_object_region(lid, "knob_back", (0, 0, 180)), "just beyond reach"),
        (move_object_region(lid, "knob_back", (0, 0, 170)), "10 mm past the last solved (+160)"),
        (move_object_region(lid, "knob_back", (0, 0, 168)), "8 mm past the last solved (+160)"),
    ]


def facing_away_variants() -> list[Task]:
    """Patches turned by 180 degrees: the hand reaches around them (hand-object collisions
    are not part of the problem, as in the paper), so these stay feasible."""
    handling, transport = load_builtin_task("scalpel-handling"), load_builtin_task("teapot-transportation")
    return [
        turn_object_region(handling, "grip_side", (1, 0, 0), 180),
        turn_object_region(handling, "grip_top", (0, 1, 0), 180),
        turn_object_region(transport, "body_front", (0, 1, 0), 180),
    ]


def frontier_variants() -> list[Task]:
    """Either side of the lid's frontier: +160 mm is solved, +165 mm neither solved nor
    certified within the limit (the closest miss says how near the search came)."""
    lid = load_builtin_task("teapot-lid-lifting")
    return [move_object_region(lid, "knob_back", (0, 0, dz)) for dz in (160, 165)]


def _closest_miss(result) -> str:
    best = result.stats.get("best_residual")
    return "-" if best is None else f"{best['contact_mm']:.2g} mm, {best['normal_deg']:.2g} deg"


def run_infeasible(console: Console, limit: float) -> list[tuple[str, Task, float]]:
    """The variants; returns (name, task, seconds) of those certified infeasible."""
    table = Table(title=f"Infeasible variants: time to certify (limit {limit:g} s, one process)")
    for col in ("task", "kind", "status", "boxes", "LPs", "time [s]", "closest miss"):
        table.add_column(col)
    families = infeasible_variants() + [(t, "frontier") for t in frontier_variants()]
    families += [(t, "facing away") for t in facing_away_variants()]
    certified = []
    for task, kind in families:
        result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit))
        s = result.stats
        table.add_row(task.name, kind, result.status, str(s["boxes"]), str(s["lps"]), f"{result.seconds:.2f}",
                      _closest_miss(result))  # fmt: skip
        if result.status == "infeasible":
            certified.append((task.name, task, result.seconds))
    console.print(table)
    return certified


def run_speedup(console: Console, jobs: list[tuple[str, Task, BranchAndPruneOptions]]) -> None:
    """1 and 2 worker processes on the same searches: same boxes (checked), time ratio."""
    table = Table(title="Worker processes on the longest searches (outcomes taken in one-process order)")
    for col in ("search", "workers", "status", "boxes", "LPs", "time [s]", "speed-up", "same answer"):
        table.add_column(col)
    for label, task, options in jobs:
        solve_complete(task, options)  # warm the span cache and numba in this process
        runs = []
        for workers in (1, 2):
            started = time.perf_counter()
            if workers == 1:
                result = solve_complete(task, options)
            else:
                with ProcessPoolExecutor(max_workers=workers) as pool:
                    pool.submit(build_system, task).result()  # start and warm the workers first
                    started = time.perf_counter()
                    result = solve_complete(task, options, executor=pool, workers=workers)
            runs.append((workers, result, time.perf_counter() - started))
        (_, base, t1), _ = runs
        for workers, result, seconds in runs:
            same = result.status == base.status and result.stats["boxes"] == base.stats["boxes"]
            table.add_row(label, str(workers), result.status, str(result.stats["boxes"]), str(result.stats["lps"]),
                          f"{seconds:.2f}", f"{t1 / seconds:.2f}", "yes" if same else "NO")  # fmt: skip
    console.print(table)


def plot_times(feasible: list[tuple[str, Task, float]], variants: list[tuple[str, Task, float]], png: Path) -> None:
    """Our time to the first solution beside the paper's, and the certification times."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (pip install matplotlib)")
        return
    builtin = [(label, t) for label, _, t in feasible if not label.startswith("file ")]
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    x = np.arange(len(builtin))
    a.bar(x - 0.2, [TABLE2[label].seconds for label, _ in builtin], 0.4, label="paper (64 cores)", color="#b0b7c3")
    a.bar(x + 0.2, [t for _, t in builtin], 0.4, label="prehension (1 core)", color="#c0392b")
    a.set_yscale("log")
    a.set_xticks(x, [label for label, _ in builtin], rotation=30, ha="right")
    a.set_ylabel("time to first verified solution [s]")
    a.set_title("Table 2: first solution, built-in tasks")
    a.legend()
    a.grid(axis="y", alpha=0.3)
    names = [name.split("(")[-1].rstrip(")") for name, _, _ in variants]
    b.barh(np.arange(len(variants)), [t for _, _, t in variants], color="#2c7fb8")
    b.set_yticks(np.arange(len(variants)), names)
    b.set_xscale("log")
    b.set_xlabel("time to certify infeasible [s]")
    b.set_title("Infeasible variants")
    b.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print(f"plot written to {png}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="built-in tasks only, 30 s limits, no variants")
    parser.add_argument("--time-limit", type=float, default=60.0, help="seconds per task")
    parser.add_argument("--png", type=Path, default=Path(__file__).with_name("table2.png"), help="plot file")
    args = parser.parse_args()
    console = Console(width=150)
    limit = 30.0 if args.quick else args.time_limit
    timings = run_feasible(console, include_shared=not args.quick, limit=limit)
    if args.quick:
        return
    variants = run_infeasible(console, limit)
    plot_times(timings, variants, args.png)
    hardest = max(variants, key=lambda row: row[2])
    slowest = max(timings, key=lambda row: row[2])
    run_speedup(console, [
        (f"certify {hardest[0]}", hardest[1], BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit)),
        (f"first solution, {slowest[0]}", slowest[1], BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit)),
        ("all solutions of scalpel-upholding, 40 boxes", load_builtin_task("scalpel-upholding"),
         BranchAndPruneOptions(verifier=LocalVerifier(), order="breadth", all_solutions=True, max_boxes=40)),
    ])  # fmt: skip


if __name__ == "__main__":
    main()
