"""``prehension solve``: the main job."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..errors import PrehensionError
from ..results import Status, result_to_dict, write_result
from .codes import EXIT_APPROXIMATE, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK

EXIT_OF_STATUS = {
    Status.SOLVED: EXIT_OK, Status.INFEASIBLE: EXIT_INFEASIBLE, Status.GAVE_UP: EXIT_GAVE_UP,
    Status.APPROXIMATE: EXIT_APPROXIMATE,
}  # fmt: skip


def _output_path(args, task_name: str) -> Path:
    return args.output if args.output is not None else Path(f"{task_name}.result.json")


def _keep_previous(path: Path) -> Path | None:
    """Move an existing file aside as ``path.~N~`` so nothing a user saved is lost."""
    if not path.exists():
        return None
    n = 1
    while Path(f"{path}.~{n}~").exists():
        n += 1
    backup = Path(f"{path}.~{n}~")
    os.replace(path, backup)
    return backup


def _options(args):
    from ..solvers.complete.search import BranchAndPruneOptions

    if args.workers < 1:
        raise PrehensionError(f"--workers must be at least 1, got {args.workers}")
    return BranchAndPruneOptions(
        sigma=args.sigma, order="breadth" if args.all else "depth", all_solutions=args.all,
        max_boxes=args.max_boxes, time_limit_s=args.time_limit,
    )  # fmt: skip


def _local_options(args):
    from ..solvers.local import LocalOptions

    return LocalOptions(approximate=args.approximate)


def cmd_solve(args, console: Console) -> int:
    from ..parallel import check_where, executor_for
    from ..solve import solve
    from ..tasks.library import resolve_task

    task = resolve_task(args.task)
    options = _options(args)
    if args.resume and args.checkpoint is None:
        raise PrehensionError("--resume needs --checkpoint FILE (the file the interrupted run saved)")
    where = (args.scheduler, args.workers if args.workers > 1 else None)
    check_where(*where)
    if args.method == "local":  # the cluster only serves the complete solver's boxes
        where = (None, None)
    if args.method in ("local", "auto"):
        from ..solvers.local import COMPILING_MESSAGE, compile_pending

        if compile_pending():
            print(COMPILING_MESSAGE, file=sys.stderr, flush=True)
    with executor_for(*where) as executor:
        with _progress(console, args) as update:
            result = solve(
                task, args.method, complete_options=options, seed=args.seed, executor=executor,
                local_options=_local_options(args),
                workers=executor.max_workers if executor is not None else 1, checkpoint=args.checkpoint,
                resume=args.resume, progress=update,
            )  # fmt: skip
    path = _output_path(args, task.name)
    backup = _keep_previous(path)
    write_result(result, path)
    _report(console, args, result, path, backup)
    if args.html is not None:
        _write_view(console, args, result)
    elif not (args.quiet or args.json):
        console.print(f"see it: prehension view {path} -o grasp.html")
    return EXIT_OF_STATUS[result.status]


def _write_view(console: Console, args, result) -> None:
    """The 3-D view of the first solution (or of the task, when there is none)."""
    from ..viewer import build_scene, write_html

    grasp = result.solutions[0] if result.solutions else None
    scene = build_scene(result.task, grasp, status=None if grasp is not None else str(result.status))
    html = write_html(scene, args.html)
    if not args.json:
        console.print(f"3-D view written to {html} (open it in a browser; it works offline)")


class _progress:
    """A live line: boxes done / open, depth, LPs (silent with --quiet or --json)."""

    def __init__(self, console: Console, args):
        self.enabled = not (args.quiet or args.json)
        self.bar = Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console, transient=True)

    def __enter__(self):
        if not self.enabled:
            return None
        self.bar.__enter__()
        self.id = self.bar.add_task("solving", total=None)
        return self.update

    def update(self, info: dict) -> None:
        text = "  ".join(f"{k} {v}" for k, v in info.items())
        self.bar.update(self.id, description=f"complete solver: {text}")

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.__exit__(*exc)
        return False


def _report(console: Console, args, result, path: Path, backup: Path | None) -> None:
    if args.json:
        summary = {k: v for k, v in result_to_dict(result).items() if k not in ("task", "solutions")}
        summary["result_file"] = str(path)
        if result.solutions:
            summary["joint_angles_deg"] = {k: float(np.degrees(v)) for k, v in result.solutions[0].joint_angles.items()}
        print(json.dumps(summary, indent=1))
        return
    style = {"solved": "bold green", "infeasible": "bold yellow", "gave_up": "bold red", "approximate": "bold magenta"}[result.status]
    console.print(f"[{style}]{result.status}[/] ({result.method}, {result.seconds:.2f} s): {result.message}")
    if result.solutions:
        console.print(_solution_table(result.solutions[0]))
    console.print(f"result written to {path}" + (f" (previous one kept as {backup})" if backup else ""))


def _solution_table(solution) -> Table:
    table = Table(title="Solution", title_justify="left")
    table.add_column("joint angle")
    table.add_column("deg", justify="right")
    for name, value in solution.joint_angles.items():
        table.add_row(name, f"{np.degrees(value):.3f}")
    worst = solution.report
    table.caption = (
        f"contacts within {worst.worst('contact_distance'):.1e} mm and {worst.worst('contact_normal'):.1e} deg; "
        f"limits and couplings exact; no self-collision"
    )
    return table
