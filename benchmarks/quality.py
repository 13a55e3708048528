"""Does the first grasp hold, and does the best of N?  Quality and physics, first vs best.

For each task it solves once (``prehension solve``: the first verified solution) and as
``solve --best N`` (up to N distinct verified solutions ranked by the Ferrari-Canny
epsilon), and prints for the first solution and for the top-ranked one: force closure,
epsilon, the physics test (DexGraspBench protocol, ``prehension simulate``: held against
how many of six pushes, or rejected for starting with more than 10 mm of hand-object
penetration) and the time each step costs; then the rates over all tasks.

Tasks: the built-in ones and the examples of ``examples/quality`` by default, or any task
names, task files (``.yaml``) and folders of task files given on the command line (mesh
objects included: the physics test reads the object's solid through
``prehension.quality.object_solid``).  Needs the ``sim`` extra.  Times are wall-clock on this
machine; read ratios rather than absolute values on a shared machine.

    python benchmarks/quality.py                          # built-in tasks + examples, best of 5
    python benchmarks/quality.py --best 10 --starts 200 my-tasks/
    python benchmarks/quality.py --torsion 5              # soft fingers in the quality measure
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

from prehension.best import BestOptions, solve_best
from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, grasp_quality, object_reference
from prehension.quality.grasp import clear_memo
from prehension.sim import SimOptions, simulate_grasp
from prehension.solve import SolveOptions, solve
from prehension.tasks.library import builtin_task_names, load_builtin_task, resolve_task

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "quality"


def _tasks(specs: list[str]):
    if not specs:
        tasks = [load_builtin_task(name) for name in builtin_task_names()]
        return tasks + [resolve_task(str(p)) for p in sorted(EXAMPLES.glob("*.yaml"))]
    tasks = []
    for spec in specs:
        path = Path(spec)
        files = sorted(path.glob("*.yaml")) if path.is_dir() else [spec]
        tasks += [resolve_task(str(f)) for f in files]
    return tasks


@dataclass
class Measured:
    """One grasp: quality, physics, and what each cost [s]."""

    closure: bool | None = None
    epsilon: float | None = None
    held: int | None = None  # pushes held of 6; None when rejected or not simulated
    rejected: bool = False
    solve_s: float = 0.0
    quality_s: float = 0.0
    physics_s: float = 0.0

    @property
    def success(self) -> bool:
        return self.held == 6


def _measure(task, solution, quality: QualityOptions, sim: SimOptions | None, solve_s: float, seed: int) -> Measured:
    m = Measured(solve_s=solve_s)
    if solution is None:
        return m
    clear_memo()  # time the measures themselves, not the memo of a grasp met before (solve --best ranks by them)
    t0 = time.perf_counter()
    q = grasp_quality(task, solution, quality)
    m.quality_s = time.perf_counter() - t0
    m.closure, m.epsilon = q.force_closure, q.epsilon
    if sim is not None:
        t0 = time.perf_counter()
        report = simulate_grasp(task, solution, sim, seed)
        m.physics_s = time.perf_counter() - t0
        m.rejected = report.rejected
        m.held = None if report.rejected else report.held
    return m


def _row(m: Measured) -> list[str]:
    if m.closure is None:
        return ["-", "-", "no solution", f"{m.solve_s:.2f}", "-", "-"]
    physics = "rejected" if m.rejected else ("-" if m.held is None else f"{m.held}/6")
    return ["yes" if m.closure else "no", f"{m.epsilon:.4f}", physics, f"{m.solve_s:.2f}", f"{1000 * m.quality_s:.1f}",
            f"{m.physics_s:.2f}"]  # fmt: skip


def run(tasks, args) -> None:
    quality = QualityOptions(torsion_mm=args.torsion)
    sim = None if args.no_sim else SimOptions()
    best_options = BestOptions(n=args.best, starts=args.starts, quality=quality)
    head = ["task", "solid [ms]", "first: FC", "eps", "physics", "solve [s]", "quality [ms]", "physics [s]",
            f"best of {args.best}: FC", "eps", "physics", "solve [s]", "found", f"N held"]  # fmt: skip
    print("| " + " | ".join(head) + " |")
    print("| " + " | ".join(["---"] + ["---:"] * (len(head) - 1)) + " |")
    firsts, bests, any_held = [], [], []
    for task in tasks:
        t0 = time.perf_counter()
        try:  # once per object (then cached): its solid, centre and radius
            object_reference(task.object)
            solid_ms = f"{1000 * (time.perf_counter() - t0):.0f}"
        except PrehensionError:
            solid_ms = "none"
        t0 = time.perf_counter()
        first = solve(task, SolveOptions(seed=args.seed))
        f = _measure(task, first.solutions[0] if first.solutions else None, quality, sim, time.perf_counter() - t0, args.seed)
        t0 = time.perf_counter()
        best = solve_best(task, best_options, SolveOptions(seed=args.seed))
        b = _measure(task, best.solutions[0] if best.solutions else None, quality, sim, time.perf_counter() - t0, args.seed)
        held_n = "-"
        if sim is not None and best.solutions:
            outcomes = [simulate_grasp(task, s, sim, args.seed).success for s in best.solutions]
            held_n = f"{sum(outcomes)}/{len(outcomes)}"
            any_held.append(any(outcomes))
        found = f"{len(best.solutions)} of {best.stats.get('best', {}).get('candidates', 0)}"
        print("| " + " | ".join([task.name, solid_ms] + _row(f) + _row(b)[:4] + [found, held_n]) + " |", flush=True)
        firsts.append(f)
        bests.append(b)
    _summary(firsts, bests, any_held, args)


def _rate(values) -> str:
    values = list(values)
    return f"{sum(values)}/{len(values)}" if values else "-"


def _summary(firsts, bests, any_held, args) -> None:
    print()
    print(f"| over {len(firsts)} tasks | force closure | median eps | physics: held all six | median solve [s] | median physics [s] |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for label, ms in (("first solution", firsts), (f"best of {args.best} (top-ranked)", bests)):
        solved = [m for m in ms if m.closure is not None]
        eps = statistics.median([m.epsilon for m in solved]) if solved else float("nan")
        held = _rate(m.success for m in solved) if not args.no_sim else "-"
        physics_s = statistics.median([m.physics_s for m in solved]) if solved and not args.no_sim else float("nan")
        print(f"| {label} | {_rate(m.closure for m in solved)} | {eps:.4f} | {held} | "
              f"{statistics.median([m.solve_s for m in ms]):.2f} | {physics_s:.2f} |")  # fmt: skip
    if any_held:
        print(f"| best of {args.best}: any of them holds | | | {_rate(any_held)} | | |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("tasks", nargs="*", help="task names, task files or folders (default: built-in tasks + examples/quality)")
    parser.add_argument("--best", type=int, default=5, help="N of the best of N (default 5)")
    parser.add_argument("--starts", type=int, default=100, help="random starts of the local solver for --best (default 100)")
    parser.add_argument("--torsion", type=float, default=0.0, help="soft-finger torsional friction of the quality measure [mm]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-sim", action="store_true", help="skip the physics test")
    args = parser.parse_args()
    started = time.perf_counter()
    run(_tasks(args.tasks), args)
    print(f"\n{time.perf_counter() - started:.0f} s in all; friction 0.6, {QualityOptions().cone_edges} cone edges, "
          f"torsion {args.torsion:g} mm; best of {args.best} from {args.starts} random starts (seed {args.seed}); "
          "physics: DexGraspBench protocol (prehension.sim.SimOptions defaults); 'rejected': more than 10 mm of "
          "hand-object penetration at the start")


if __name__ == "__main__":
    main()
