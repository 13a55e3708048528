"""One problem at a time: where a warm ``solve_local`` call spends its CPU (issue 11).

    python benchmarks/single_call.py                 # 100 four-fingertip SA-hand tasks
    python benchmarks/single_call.py --tasks 300 --builtin
    python benchmarks/single_call.py --cli 10        # + the command line, 10 fresh processes

Rows, each the median CPU time (``time.process_time``) over the tasks, in one warm
process (BLAS pinned to one thread): a whole ``solve_local`` call; the kernel on one
initial pose (``run_kernel``); ``make_solution`` of the answer (the one residual
function, idle fingers settled); inside it ``evaluate`` with the pose given, and
``forward_kinematics`` of one configuration.  With ``--builtin`` also ``make_solution`` on
the nine built-in tasks' answers, with the object checked and ignored.  CPU times are
less at the mercy of other processes than wall times, not immune: read them beside the
load average printed at the start.

With ``--cli N``: ``prehension solve teapot-lid-lifting`` (the README's first command)
run N times as a fresh process, its median wall and CPU time (start-up included; numba's
cache and the geometry cache warm: the first run warms them and is not counted); then the
median split of the same work in N fresh processes: ``import prehension.cli``, loading
the task, ``solve`` and writing the result file; and the libraries' floor: a fresh process
that only imports what the command cannot do without (numpy, numba, scipy.spatial for
the grasp quality's Qhull, highspy, pydantic, yaml, rich) and, when the command's kernels
come from numba's JIT cache rather than the ahead-of-time extension
(``prehension.kernels.aot``), runs numba's one-time target set-up (which such a process pays
before its first cached function loads, and which imports scipy.linalg for numba's BLAS
check).  Python writes and reuses its bytecode
(``PYTHONDONTWRITEBYTECODE`` is removed from the children's environment, as on a user's
machine).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402
from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402


def _cpu_median(calls, repeats: int = 1) -> float:
    """Median CPU seconds of each zero-argument callable (each run ``repeats`` times)."""
    times = []
    for call in calls:
        t0 = time.process_time()
        for _ in range(repeats):
            call()
        times.append((time.process_time() - t0) / repeats)
    return float(np.median(times))


def point_rows(n: int) -> list[tuple[str, float]]:
    from prehension.hands.kinematics import forward_kinematics
    from prehension.hands.sa_hand import schunk_sa_hand
    from prehension.results import make_solution
    from prehension.solvers.local import LocalOptions, random_point_problems, solve_local
    from prehension.solvers.local.problems import group_from_tasks
    from prehension.solvers.local.sequence import default_sequence
    from prehension.solvers.local._starts import place_poses as _place_poses
    from prehension.solvers.local.solver import run_kernel
    from prehension.verification.residuals import evaluate

    problems = random_point_problems(n, schunk_sa_hand(), seed=0)
    tasks = [problems.task(i) for i in range(n)]
    solve_local(tasks[0])  # warm: compiled code loaded, tables built
    whole = _cpu_median([lambda t=t: solve_local(t) for t in tasks])
    answers = [(t, r.solutions[0].configuration()) for t in tasks for r in [solve_local(t)] if r.solutions]
    options, sequence = LocalOptions(), default_sequence(problems.hand)
    kernel = []
    for t in tasks:
        group = group_from_tasks([t], options.joint_scale_mm)
        x0 = _place_poses(group, sequence.names, sequence.poses(sequence.lambdas[0:1]))
        kernel.append(lambda g=group, x=x0: run_kernel(g, np.zeros(1, dtype=np.int64), x, options))
    poses = {id(c): forward_kinematics(t.hand, c.joint_angles) for t, c in answers}
    return [
        (f"solve_local, one call ({len(tasks)} tasks)", whole),
        ("  kernel, one initial pose (run_kernel)", _cpu_median(kernel, 3)),
        (f"  make_solution of the answer ({len(answers)} answers)", _cpu_median([lambda t=t, c=c: make_solution(t, c) for t, c in answers], 3)),
        ("    evaluate, pose given", _cpu_median([lambda t=t, c=c: evaluate(t, c, pose=poses[id(c)]) for t, c in answers], 3)),
        ("    forward_kinematics, one configuration", _cpu_median([lambda t=t, c=c: forward_kinematics(t.hand, c.joint_angles) for t, c in answers], 10)),
    ]  # fmt: skip


def builtin_rows() -> list[tuple[str, float]]:
    from prehension.results import make_solution
    from prehension.solvers.local import solve_local
    from prehension.tasks.library import builtin_task_names, load_builtin_task

    answers = []
    for name in builtin_task_names():
        task = load_builtin_task(name)
        result = solve_local(task)
        if result.solutions:
            answers.append((task, result.solutions[0].configuration()))
    rows = []
    for collide in (True, False):
        calls = []
        for task, config in answers:
            variant = replace(task, object=replace(task.object, collisions=collide))
            make_solution(variant, config)
            calls.append(lambda v=variant, c=config: make_solution(v, c))
        label = "checked" if collide else "ignored"
        rows.append((f"make_solution, {len(answers)} built-in answers, object {label}", _cpu_median(calls, 5)))
    return rows


CLI_TASK = "teapot-lid-lifting"
_SPLIT = r"""
import json, sys, time
t = [time.perf_counter()]
import prehension.cli
t.append(time.perf_counter())
from prehension.tasks.library import resolve_task
task = resolve_task(sys.argv[1])
t.append(time.perf_counter())
from prehension.solve import solve
result = solve(task, "auto")
t.append(time.perf_counter())
from prehension.results import write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
write_result(result, sys.argv[2], quality_entries(result), approach_entries_of(result))
t.append(time.perf_counter())
print(json.dumps([b - a for a, b in zip(t, t[1:])] + [result.status]))
"""


# What ``prehension solve`` cannot do without, before any of its own work (see the docstring).
_FLOOR_IMPORTS = """
import numpy, numba, scipy.spatial, highspy, pydantic.main, yaml, rich.console, rich.table, rich.progress
"""
# Only a process that compiles or loads numba's cache pays the target set-up; the
# ahead-of-time extension (when installed and current) serves the command without it.
_FLOOR_TARGET = """
from numba.core.registry import cpu_target
cpu_target.target_context.refresh()
"""


def _floor_script() -> tuple[str, str]:
    """The floor's script and its row label: numba's target set-up only if the JIT serves."""
    from prehension.kernels.aot import aot_available

    if aot_available():
        return _FLOOR_IMPORTS, "imports; AOT, no target set-up"
    return _FLOOR_IMPORTS + _FLOOR_TARGET, "imports, numba's target set-up"


def _child_env() -> dict:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _timed_child(argv: list[str]) -> tuple[float, float, str]:
    """``(wall s, CPU s of the child, stdout)`` of one fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=_child_env(), check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.stdout


def cli_rows(n: int) -> list[tuple[str, float]]:
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.json")
        command = [sys.executable, "-m", "prehension.cli", "solve", CLI_TASK, "-o", out]
        _timed_child(command)  # warm: bytecode, numba's cache, the geometry cache
        runs = [_timed_child(command)[:2] for _ in range(n)]
        splits = [json.loads(_timed_child([sys.executable, "-c", _SPLIT, CLI_TASK, out])[2])[:4] for _ in range(n)]
        floor_script, floor_label = _floor_script()
        floor = [_timed_child([sys.executable, "-c", floor_script])[:2] for _ in range(n)]
    wall, cpu = np.median(runs, axis=0)
    parts = np.median(splits, axis=0)
    floor_wall, floor_cpu = np.median(floor, axis=0)
    return [
        (f"prehension solve {CLI_TASK}, fresh process: wall ({n} runs)", float(wall)),
        ("  the same: CPU of the process", float(cpu)),
        ("  split (wall, fresh processes): import prehension.cli", float(parts[0])),
        ("    load the task (YAML, hand, object, region checks)", float(parts[1])),
        ("    solve (auto: the local solver)", float(parts[2])),
        ("    write the result file (grasp quality included)", float(parts[3])),
        (f"  the libraries' floor ({floor_label}): wall", float(floor_wall)),
        ("    the same: CPU of the process", float(floor_cpu)),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tasks", type=int, default=100, help="random four-fingertip SA-hand tasks (default 100)")
    parser.add_argument("--builtin", action="store_true", help="also make_solution on the nine built-in answers")
    parser.add_argument("--cli", type=int, default=0, metavar="N", help=f"also `prehension solve {CLI_TASK}` in N fresh processes")
    args = parser.parse_args()
    console = Console()
    console.print(f"load average at the start {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores)")
    rows = point_rows(args.tasks) + (builtin_rows() if args.builtin else []) + (cli_rows(args.cli) if args.cli else [])
    table = Table(title="One problem at a time, warm process: CPU medians")
    table.add_column("what")
    table.add_column("ms", justify="right")
    for label, seconds in rows:
        table.add_row(label, f"{1e3 * seconds:.3f}")
    console.print(table)


if __name__ == "__main__":
    main()
