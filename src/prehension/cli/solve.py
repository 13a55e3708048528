"""``prehension solve``: the main job.

Every output (result file, ``--html``, ``--checkpoint``) is checked before any work starts
(:func:`prehension.atomic.check_output_path`): not a folder, not an input, in a folder that
exists and can be written.  Every run is bounded (``--time-limit``, 300 s by default; 0 for
none) and visible (:mod:`.progress`).
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..atomic import check_output_path
from ..errors import PrehensionError, not_a_file
from ..results import Status, result_to_dict, write_result
from . import args as types
from .assign import DEFAULT_OPEN_TIME_LIMIT_S, SolveDefaultLimit, add_assignment_arguments, cmd_solve_open, refuse_open_only
from .best import (
    HOLD_CANDIDATES, add_best_arguments, add_hold_closure_argument, add_quality_arguments, add_require_argument, best_options,
    best_table, hold_closure_time, quality_lines, quality_options,
)  # fmt: skip
from .codes import EXIT_APPROXIMATE, EXIT_DROPPED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK
from .hands import print_hand_warnings
from .outputs import files_of_task, keep_previous, task_inputs
from .progress import LiveProgress

__all__ = ["add_parser", "cmd_solve", "EXIT_OF_STATUS"]

EXIT_OF_STATUS = {
    Status.SOLVED: EXIT_OK, Status.INFEASIBLE: EXIT_INFEASIBLE, Status.GAVE_UP: EXIT_GAVE_UP,
    Status.APPROXIMATE: EXIT_APPROXIMATE,
}  # fmt: skip
TASK_HELP = "built-in task name, task file (.yaml) or CuikSuite file (.world)"


def add_parser(sub) -> None:
    p = sub.add_parser("solve", help="find a grasp configuration (or prove there is none)")
    p.add_argument("task", help=TASK_HELP + "; a task file whose contacts leave the hand open (hand: any) runs the "
                   "assignment search")
    p.add_argument("--method", choices=("auto", "local", "complete"), default="auto",
                   help="auto (default): the local solver, then the complete one if it finds no strict solution")  # fmt: skip
    p.add_argument("-o", "--output", type=Path, help="result file (default: TASK.result.json; an older one is kept as a backup)")
    p.add_argument("--all", action="store_true",
                   help="complete solver: describe the solution set down to --sigma (breadth first); stops "
                        "after 100 boxes unless --max-boxes is given (or at --time-limit), returning a cover: "
                        "solution boxes, verified solutions and the boxes still open")  # fmt: skip
    p.add_argument("--sigma", type=types.finite, default=None,
                   help="complete solver: solution-box size (fraction of the initial box; default 0.1)")  # fmt: skip
    p.add_argument("--workers", type=types.positive_int, default=1,
                   help="complete solver: boxes processed in parallel on a local Dask cluster of N processes")  # fmt: skip
    p.add_argument("--scheduler", metavar="ADDR", help="complete solver: process boxes on a running Dask cluster (tcp://host:8786)")
    p.add_argument("--time-limit", type=types.seconds, default=SolveDefaultLimit(types.DEFAULT_TIME_LIMIT_S), metavar="SECONDS",
                   help=f"give up after this long (default {types.DEFAULT_TIME_LIMIT_S:g} s; an open task's assignment "
                        f"search {DEFAULT_OPEN_TIME_LIMIT_S:g} s; 0: no limit)")  # fmt: skip
    p.add_argument("--max-boxes", type=types.positive_int, default=None, help="complete solver: give up after this many boxes")
    p.add_argument("--checkpoint", type=Path, help="complete solver: save the open boxes here when stopped (Ctrl-C too)")
    p.add_argument("--resume", action="store_true", help="complete solver: continue from --checkpoint (same task and options only)")
    p.add_argument("--seed", type=types.seed, default=0, help="random seed of the local solver (an integer >= 0)")
    p.add_argument("--sequence", type=Path, metavar="FILE", help="local solver: initial poses from 'prehension offline' (.json)")
    p.add_argument("--approximate", action="store_true",
                   help="accept an answer within the paper's d_min tolerances (1.5 mm) when no strict solution is found: "
                        "status 'approximate', exit code 6, never 'solved'")  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress or tables, only errors")
    p.add_argument("--json", action="store_true", help="print the result summary as JSON on stdout")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the 3-D view of the grasp (as 'prehension view')")
    add_quality_arguments(p)
    add_require_argument(p)
    add_best_arguments(p)
    p.add_argument("--hold", action="store_true",
                   help="physics in the loop: run the ranked candidates of --best N (--best 5 unless given) through "
                        "the physics test (prehension simulate) and answer with the first that holds; exit 7 when none "
                        'does (needs: pip install "prehension[sim]"; docs/quality.md)')  # fmt: skip
    add_hold_closure_argument(p)
    add_assignment_arguments(p)
    types.add_option_rule(p, _method_options)


_COMPLETE_ONLY = ("all", "sigma", "max_boxes", "checkpoint", "resume", "workers", "scheduler")


def _method_options(args) -> str | None:
    """An option of one solver given with ``--method`` the other: refused, not ignored."""
    if args.method == "local":
        given = [k for k in _COMPLETE_ONLY if getattr(args, k) not in (None, False) and not (k == "workers" and args.workers == 1)]
        if given:
            flag = "--" + given[0].replace("_", "-")
            return f"{flag} is an option of the complete solver; --method local does not use it: drop it or use --method auto or complete"
    if args.method == "complete" and args.sequence is not None:
        return "--sequence gives the local solver's initial poses; --method complete does not use it: drop it or use --method auto or local"
    return None


def _default_output(task_name: str) -> Path:
    """``NAME.result.json`` in the current folder, with the name made a safe, visible file name."""
    stem = re.sub(r"[^A-Za-z0-9._+-]+", "_", task_name).lstrip("._") or "task"
    return Path(f"{stem}.result.json")


def _check_outputs(args, task) -> Path:
    """Every output checked before the solve: returns the result file's path."""
    inputs = task_inputs(args.task) + files_of_task(task)
    path = check_output_path(args.output or _default_output(task.name), "result file", inputs=inputs)
    named = [(path, "result file")]
    if args.html is not None:
        named.append((check_output_path(args.html, "--html", inputs=inputs), "--html"))
    if args.checkpoint is not None:
        named.append((check_output_path(args.checkpoint, "--checkpoint", inputs=inputs), "--checkpoint"))
    for i, (a, what_a) in enumerate(named):
        for b, what_b in named[i + 1 :]:
            if a.resolve() == b.resolve():
                raise PrehensionError(f"{what_a} and {what_b} are the same file {a}: give each its own file")
    return path


def _options(args):
    """The complete solver's options, as a zero-argument callable that makes them.

    Importing the complete solver costs ~50 ms (its LP and relaxation modules), which
    ``--method auto`` needs only when the local solver finds nothing: :func:`~prehension.solve.solve`
    calls this only then.  The one value the command line can make invalid, ``--sigma``,
    is checked here, before any work, with the options' own words.
    """
    sigma = 0.1 if args.sigma is None else args.sigma
    if not 0.0 < sigma < 1.0:
        raise PrehensionError(f"sigma must lie in (0, 1) (a fraction of the initial box), got {sigma}")

    def make():
        from ..solvers.complete.search import BranchAndPruneOptions

        return BranchAndPruneOptions(
            sigma=sigma, order="breadth" if args.all else "depth", all_solutions=args.all,
            max_boxes=args.max_boxes, time_limit_s=types.time_limit(args.time_limit),
        )  # fmt: skip

    return make


def _sequence(args):
    """The ``--sequence FILE`` of ``prehension offline``, or None."""
    if getattr(args, "sequence", None) is None:
        return None
    from ..solvers.local.sequence import InitialPoseSequence

    return InitialPoseSequence.load(args.sequence)


def _local_options(args):
    from ..solvers.local import LocalOptions

    return LocalOptions(approximate=args.approximate)


def cmd_solve(args, console: Console) -> int:
    from ..parallel import check_where, executor_for
    from ..tasks.library import resolve_task
    from ..tasks.yaml_io import is_open_task_file

    if is_open_task_file(args.task):  # hand: any, or candidates: the assignment search
        if args.hold_closure_time is not None:
            raise PrehensionError("--hold-closure-time is not used by an open task's assignment search (its --hold "
                                  "judges every solution of each feasible assignment): drop it")  # fmt: skip
        return cmd_solve_open(args, console)
    refuse_open_only(args)
    args.time_limit = float(args.time_limit)  # a plain number (not the open task's default marker)
    task = resolve_task(args.task)
    print_hand_warnings(console, task.hand)
    path, options, best = _checked(args, task)
    where = (args.scheduler, args.workers if args.workers > 1 else None)
    check_where(*where)
    if args.method == "local":  # the cluster only serves the complete solver's boxes
        where = (None, None)
    _say_if_compiling(args)
    with executor_for(*where) as executor:
        with LiveProgress(console, enabled=not (args.quiet or args.json), time_limit_s=types.time_limit(args.time_limit)) as update:
            workers = executor.max_workers if executor is not None else 1
            result = _solve(task, replace(options, executor=executor, workers=workers, progress=update), best)
    hold = _hold(console, args, result) if args.hold and result.solutions else None
    return _save(console, args, result if hold is None else hold.result, hold, options.quality, path, best is not None)


def _save(console: Console, args, result, hold, quality, path: Path, best: bool) -> int:
    """Write the result file (its quality, pre-grasp and squeeze measured here), report,
    write ``--html``; the exit code."""
    from ..pregrasp import approach_entries_of
    from ..quality import quality_entries

    qualities = quality_entries(result, quality)  # measured once: the file and the --json summary
    backup = keep_previous(path)
    write_result(result, path, qualities, approach_entries_of(result), physics=None if hold is None else hold.physics)
    _report(console, args, result, qualities, path, backup)
    if result.solutions and not (args.quiet or args.json):
        console.print(best_table(result) if best else "\n".join(quality_lines(result, quality)))
    if args.html is not None:
        _write_view(console, args, result)
    elif not (args.quiet or args.json):
        console.print(f"see it: prehension view {path} -o grasp.html")
    if hold is not None and not hold.held:
        return EXIT_DROPPED
    return EXIT_OF_STATUS[result.status]


def _checked(args, task):
    """Every argument and output checked before any work: ``(result file, solve options
    without their executor and progress, best options or None)``."""
    sequence, complete = _sequence(args), _options(args)
    if args.resume and args.checkpoint is None:
        raise PrehensionError("--resume needs --checkpoint FILE (the file the interrupted run saved)")
    if args.resume and not args.checkpoint.is_file():
        raise PrehensionError(f"cannot resume: {not_a_file('checkpoint file', args.checkpoint)}")
    path = _check_outputs(args, task)
    implied = args.hold and args.best is None
    if args.hold:
        from ..sim import require_mujoco

        require_mujoco()  # before any work: say what to install
        if implied:
            args.best = HOLD_CANDIDATES
    try:
        quality, best = quality_options(args), best_options(args, types.time_limit(args.time_limit))
    except PrehensionError as exc:
        raise PrehensionError(f"--hold runs the candidates of --best {HOLD_CANDIDATES}: {exc}" if implied else str(exc)) from None
    hold_closure_time(args)
    if args.require and args.method == "local":
        raise PrehensionError(f"--require {args.require} needs the complete solver (--method complete, or auto): "
                              "the local solver cannot prove that no such grasp exists")  # fmt: skip
    return path, _solve_options(args, quality, sequence, complete), best


def _say_if_compiling(args) -> None:
    """The local solver's kernels compile on first use (minutes): say so on stderr."""
    if args.method in ("local", "auto"):
        from ..solvers.local import COMPILING_MESSAGE, compile_pending

        if compile_pending():
            print(COMPILING_MESSAGE, file=sys.stderr, flush=True)


def _solve_options(args, quality, sequence, complete):
    """The :class:`~prehension.solve.SolveOptions` of the command line (the executor and
    the progress display are added when they exist)."""
    from ..solve import SolveOptions

    return SolveOptions(
        method=args.method, seed=args.seed, time_limit_s=types.time_limit(args.time_limit), require=args.require,
        quality=quality, sequence=sequence, local_options=_local_options(args), complete_options=complete,
        checkpoint=args.checkpoint, resume=args.resume,
    )  # fmt: skip


def _solve(task, options, best):
    """``solve`` (:func:`prehension.solve.solve`), or ``solve --best N`` (:func:`prehension.best.solve_best`)."""
    if best is None:
        from ..solve import solve

        return solve(task, options)
    from ..best import solve_best

    return solve_best(task, best, options)


def _hold(console: Console, args, result):
    """``--hold``: the first candidate that holds in the physics test (:func:`prehension.hold.hold_first`)."""
    from ..hold import hold_first

    say = None if (args.quiet or args.json) else (lambda line: console.print(line, style="dim"))
    hold = hold_first(result, seed=args.seed, progress=say, closure_time_s=args.hold_closure_time)
    if not (args.quiet or args.json):
        for t in hold.result.stats["hold"]["tried"]:
            style = "green" if t["success"] else "red"
            console.print(f"candidate {t['candidate'] + 1}: [{style}]{escape(t['why'])}[/]")
        if hold.proven_none:
            by = ("without the hand: no choice of points in the object regions is" if hold.closure.get("method") == "regions"
                  else "by the complete solver")  # fmt: skip
            console.print(f"[bold yellow]no grasp in these regions is force closure[/] (proven {by}, with the physics "
                          "test's friction and torsion; prehension check re-proves it)")  # fmt: skip
        if not hold.held:
            console.print("[bold red]no candidate holds in the physics test[/]: the solutions are every candidate "
                          "tried, the one that held the most pushes first (exit code 7)")  # fmt: skip
    return hold


def _write_view(console: Console, args, result) -> None:
    """The 3-D view of the first solution (or of the task, when there is none)."""
    from ..viewer import build_scene, write_html

    grasp = result.solutions[0] if result.solutions else None
    scene = build_scene(result.task, grasp, status=None if result.success else str(result.status))
    html = write_html(scene, args.html)
    if not args.json:
        console.print(f"3-D view written to {html} (open it in a browser; it works offline)")


def _report(console: Console, args, result, qualities, path: Path, backup: Path | None) -> None:
    if args.json:
        data = result_to_dict(result, qualities, embed_task=False)
        summary = {k: v for k, v in data.items() if k != "solutions"}  # no task, no mesh
        summary["result_file"] = str(path)
        if result.solutions:
            summary["joint_angles_deg"] = {k: float(np.degrees(v)) for k, v in result.solutions[0].joint_angles.items()}
        print(json.dumps(summary, indent=1, allow_nan=False))
        return
    style = {"solved": "bold green", "infeasible": "bold yellow", "gave_up": "bold red", "approximate": "bold magenta"}[result.status]
    console.print(f"[{style}]{result.status}[/] ({result.method}, {result.seconds:.2f} s): {escape(result.message)}")
    if result.solutions:
        console.print(_solution_table(result.solutions[0], result.status))
    console.print(f"result written to {path}" + (f" (previous one kept as {backup})" if backup else ""))


def _solution_table(solution, status: str) -> Table:
    table = Table(title="Solution" if status == Status.SOLVED else "Approximate answer (not a solution)", title_justify="left")
    table.add_column("joint angle")
    table.add_column("deg", justify="right")
    for name, value in solution.joint_angles.items():
        table.add_row(name, f"{np.degrees(value):.3f}")
    report = solution.report
    into = [c for c in report.checks if c.kind == "object_collision"]
    object_note = (f"; no link or pad more than {into[0].tolerance:g} mm into the object (deepest link "
                   f"{report.worst('object_collision'):.2g} mm, pad {report.worst('pad_collision'):.2g} mm)") if into else ""  # fmt: skip
    table.caption = (
        f"contacts within {report.worst('contact_distance'):.1e} mm and {report.worst('contact_normal'):.1e} deg; "
        f"limits and couplings exact; no self-collision{object_note}"
    )
    return table
