"""The complete solver's collision prune: what it costs and what it discards.

Three tables, each run twice in one process -- with the prune (the default) and without
it (``BranchAndPruneOptions(collision_prune=False)``) -- alternating, so that both see the
same machine load:

1. **Table 2 tasks** (depth first, sigma = 0.1, one process, as ``table2.py --quick``):
   status, boxes, boxes pruned by collision and time to the first verified solution
   (the median of ``--repeats`` runs of each setting, alternating, after a warm-up).
2. **Solution-set mode** (``--solution-sets``: ``all_solutions``, a box budget, about a
   minute per task and setting): boxes split down to sigma without stopping at the first
   solution; the count of boxes the prune discarded.
3. **The pit** (``tests/tiny_tasks.py``): a palm pad that must touch the floor of a square
   pit, the palm 10 mm above the floor.  Narrower than the palm, every contact
   configuration passes through the walls: with the prune the search certifies
   "no penetration-free solution"; without it the same search cannot end (it gives up
   at three times the boxes, or leaves boxes narrower than sigma unverified).

4. **Cost of one test**: per built-in task, the number of probe points, the time to build
   them (once per search) and the median time of one prune test on the initial box
   (few probes close enough to be worth a distance query) and on the point box of the
   local solver's answer (every probe queried: the worst case).

Times are wall-clock on this machine; read ratios rather than absolute values.

    python benchmarks/collision_prune.py                    # tables 1 and 3 (a minute)
    python benchmarks/collision_prune.py --solution-sets    # and table 2 (several minutes)
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from prehension.solvers.complete.collision import collision_probes, collision_prune
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.solvers.local.verifier import LocalVerifier
from prehension.solve import solve
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.verification.residuals import Tolerances
from prehension.tasks.library import builtin_task_names, load_builtin_task

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from tiny_tasks import pit_task  # noqa: E402

SOLUTION_SET_TASKS = ("scalpel-upholding", "teapot-lid-lifting", "guitar-tuning")


def _both(task, options: BranchAndPruneOptions, repeats: int = 1):
    """``(with the prune, without it)`` results of one task, after a warm-up that builds
    what both share (the object's distance structure, the hand's reach bounds); with
    ``repeats`` > 1 the two alternate and each keeps its run of median time."""
    solve_complete(task, replace(options, max_boxes=1, time_limit_s=None, all_solutions=False))
    runs_on, runs_off = [], []
    for _ in range(repeats):
        runs_on.append(solve_complete(task, options))
        runs_off.append(solve_complete(task, replace(options, collision_prune=False)))
    median = lambda runs: sorted(runs, key=lambda r: r.seconds)[len(runs) // 2]  # noqa: E731
    return median(runs_on), median(runs_off)


def _cells(on, off) -> list[str]:
    return [f"{on.status} / {off.status}", f"{on.stats['boxes']} / {off.stats['boxes']}", str(on.stats["collision_pruned"]),
            f"{on.seconds:.2f} / {off.seconds:.2f}"]  # fmt: skip


def _table(title: str) -> Table:
    table = Table(title=title)
    for col in ("task", "status (prune / none)", "boxes (prune / none)", "pruned by collision", "time [s] (prune / none)"):
        table.add_column(col, justify="left" if col == "task" or col.startswith("status") else "right")
    return table


def run_builtin(console: Console, limit: float, repeats: int) -> None:
    table = _table(f"Built-in tasks: first verified solution (depth first, sigma = 0.1, one process; median of {repeats})")
    times_on, times_off = [], []
    for name in builtin_task_names():
        on, off = _both(load_builtin_task(name), BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=limit), repeats)
        table.add_row(name, *_cells(on, off))
        times_on.append(on.seconds), times_off.append(off.seconds)
    console.print(table)
    console.print(f"with the prune: median {np.median(times_on):.2f} s, max {max(times_on):.2f} s; "
                  f"without: median {np.median(times_off):.2f} s, max {max(times_off):.2f} s")  # fmt: skip


def run_solution_sets(console: Console, boxes: int) -> None:
    table = _table(f"Solution-set mode: the first {boxes} boxes (breadth first, sigma = 0.1)")
    for name in SOLUTION_SET_TASKS:
        options = BranchAndPruneOptions(verifier=LocalVerifier(), all_solutions=True, order="breadth", max_boxes=boxes)
        table.add_row(name, *_cells(*_both(load_builtin_task(name), options)))
    console.print(table)


def run_pits(console: Console) -> None:
    table = _table("The pit: the pad on the floor, the palm 10 mm above it (palm 100 mm long)")
    for width in (20.0, 30.0, 40.0, 240.0):
        task = pit_task(width / 2)
        solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=1))  # warm-up
        on = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
        off_options = BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=3 * on.stats["boxes"], time_limit_s=60, collision_prune=False)
        table.add_row(f"pit {width:g} mm wide", *_cells(on, solve_complete(task, off_options)))
    console.print(table)


def _median_ms(fn, repeats: int = 50) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def run_costs(console: Console) -> None:
    table = Table(title="Cost of the prune test (object_penetration_mm = 0.5)")
    for col in ("task", "probes", "of them outside the system", "build [ms]", "initial box [ms]", "point box [ms]"):
        table.add_column(col, justify="left" if col == "task" else "right")
    for name in builtin_task_names():
        task = load_builtin_task(name)
        task.object.distance, task.object.surface  # built once per object, shared by every search
        form = build_system(task)
        start = time.perf_counter()
        probes = collision_probes(form)
        build = 1e3 * (time.perf_counter() - start)
        lo, hi = form.system.lower, form.system.upper
        x = embed(form, solve(task, "local").solutions[0].configuration())
        tol = Tolerances()
        table.add_row(name, str(probes.size), str(int((probes.extra > 0).sum())), f"{build:.1f}",
                      f"{_median_ms(lambda: collision_prune(form, lo, hi, tol)):.3f}",
                      f"{_median_ms(lambda: collision_prune(form, x, x, tol)):.3f}")  # fmt: skip
    console.print(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--solution-sets", action="store_true", help="also the solution-set table (minutes)")
    parser.add_argument("--time-limit", type=float, default=30.0, help="seconds per built-in task")
    parser.add_argument("--repeats", type=int, default=3, help="runs per built-in task and setting (median)")
    parser.add_argument("--boxes", type=int, default=40, help="box budget of the solution-set table")
    args = parser.parse_args()
    console = Console(width=140)
    run_builtin(console, args.time_limit, args.repeats)
    if args.solution_sets:
        run_solution_sets(console, args.boxes)
    run_pits(console)
    run_costs(console)


if __name__ == "__main__":
    main()
