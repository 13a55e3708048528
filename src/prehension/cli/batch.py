"""``prehension batch``: solve every task of a ``.jsonl`` file or a folder on a Dask cluster.

Exit codes: 0 every task of the input has a done record (solved, infeasible or gave up;
with ``--hold`` a solved task whose candidates all drop is done too: its record says
``"held": false``);
2 bad input (a malformed line, named by file and line, or tasks recorded ``invalid``);
1 some task ended in ``error`` (a crash; its record says which); 4 stopped before every
task was done -- by Ctrl-C (as ``prehension solve`` when interrupted) or ``--max-tasks`` --
what finished is saved: run the same command again to go on.
"""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, ProgressColumn, TextColumn, TimeElapsedColumn
from rich.progress import TimeRemainingColumn
from rich.text import Text

from . import args as types
from .best import add_batch_arguments, batch_extras
from .codes import EXIT_BAD_INPUT, EXIT_GAVE_UP, EXIT_OK

__all__ = ["add_parser", "cmd_batch"]

EXIT_ERRORS = 1
EXIT_INTERRUPTED = EXIT_GAVE_UP  # as `prehension solve` stopped by Ctrl-C


def add_parser(sub) -> None:
    """The ``batch`` sub-command."""
    p = sub.add_parser("batch", help="solve many tasks on a Dask cluster, resumable (docs/batch.md)")
    p.add_argument("input", type=Path, help="tasks: a .jsonl file (one task per line) or a folder of task files")
    p.add_argument("-o", "--output", type=Path, required=True, help="results (.jsonl): appended as tasks finish; "
                   "tasks already in it are skipped")  # fmt: skip
    p.add_argument("--method", choices=("auto", "local", "complete"), default="auto",
                   help="auto (default): the local solver, then the complete one if it fails")  # fmt: skip
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDR", help="a running Dask scheduler, e.g. tcp://host:8786")
    where.add_argument("--workers", type=types.positive_int, help="size of the local cluster (processes; default: the cores)")
    p.add_argument("--seed", type=types.seed, default=0, help="base seed; each task's seed is derived from it and its id")
    p.add_argument("--time-limit", type=types.seconds, default=types.DEFAULT_TIME_LIMIT_S, metavar="SECONDS",
                   help=f"give up on a task after this long (default {types.DEFAULT_TIME_LIMIT_S:g} s; 0: no limit)")  # fmt: skip
    p.add_argument("--chunk-size", type=types.positive_int, default=None,
                   help="tasks per Dask task (default: local up to 64, four chunks per worker at least; 1 otherwise)")
    p.add_argument("--self-contained", action="store_true",
                   help="every record embeds its task (default: each distinct task stored once, records refer to it)")
    p.add_argument("--retry-gave-up", action="store_true", help="solve again the tasks recorded as gave_up (or approximate)")
    p.add_argument("--max-tasks", type=types.positive_int, default=None, help="stop after this many tasks (re-run to go on)")
    p.add_argument("--sequence", type=Path, action="append", default=[], metavar="FILE",
                   help="local solver: initial poses from 'prehension offline' (.json), used by the tasks of its "
                        "hand; repeat for several hands")  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary, only errors")
    add_batch_arguments(p)


class _RateColumn(ProgressColumn):
    """Tasks per second, averaged by rich over the last 30 s."""

    def render(self, task) -> Text:
        return Text(f"{task.speed:.1f} tasks/s" if task.speed else "- tasks/s", style="progress.data.speed")


def _bar(console: Console) -> Progress:
    return Progress(
        TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), _RateColumn(),
        TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), console=console,
    )  # fmt: skip


def cmd_batch(args, console: Console) -> int:
    from ..batch import BatchOptions, read_inputs, run_batch
    from ..batch.run import check_output
    from ..parallel import check_where, cluster

    options = BatchOptions(
        method=args.method, seed=args.seed, time_limit_s=types.time_limit(args.time_limit), chunk_size=args.chunk_size,
        retry_gave_up=args.retry_gave_up, max_tasks=args.max_tasks, self_contained=args.self_contained,
        sequences=_sequences(args.sequence), **batch_extras(args),
    )  # fmt: skip
    check_where(args.scheduler, args.workers)
    check_output(args.input, args.output)
    entries = read_inputs(args.input)  # bad input fails here, before a cluster starts
    with _bar(console) as bar, cluster(args.scheduler, args.workers) as client:
        bar_id = bar.add_task("starting the cluster", total=None)

        def progress(p) -> None:
            text = ", ".join(f"{n} {s}" for s, n in sorted(p.counts.items())) or "starting"
            bar.update(bar_id, total=p.total, completed=p.done, description=f"batch ({text})")

        summary = run_batch(entries, args.output, client, options, progress)
    _report(console, summary)
    if args.hold:
        _report_hold(console, args.output)
    return _exit_code(summary)


def _sequences(paths) -> tuple:
    """The ``--sequence`` files, read and checked, as JSON mappings (they travel to the workers)."""
    from ..solvers.local.sequence import InitialPoseSequence

    return tuple(InitialPoseSequence.load(p).to_dict() for p in paths)


def _report(console: Console, summary) -> None:
    for note in summary.notes:
        console.print(f"[yellow]journal:[/] {note}")
    labels = {"solved": "solved", "infeasible": "proven infeasible", "gave_up": "gave up", "invalid": "invalid", "error": "error"}
    parts = [f"{summary.counts[s]} {label}" for s, label in labels.items() if summary.counts.get(s)]
    console.print(
        f"{summary.tasks} tasks: {', '.join(parts) or 'none solved in this run'}; {summary.skipped} already done, "
        f"{summary.remaining} left; {summary.seconds:.1f} s -> {summary.output}"
    )
    if summary.interrupted:
        console.print("[bold yellow]interrupted[/]: what finished is saved; run the same command again to go on")
    if summary.counts.get("invalid") or summary.counts.get("error"):
        console.print("tasks recorded invalid or error (their message says why) are solved again by the next run")


def _report_hold(console: Console, output) -> None:
    """``--hold``: how many tasks of the output hold in the physics test (their records' ``held``)."""
    from ..batch import read_records

    held = [r.get("held") for r in read_records(output) if r.get("status") == "solved"]
    judged = [h for h in held if h is not None]
    unjudged = f"; {len(held) - len(judged)} not judged (their message says why)" if len(judged) < len(held) else ""
    console.print(f"hold: {sum(judged)} of {len(judged)} solved tasks hold in the physics test{unjudged}")


def _exit_code(summary) -> int:
    if summary.interrupted:
        return EXIT_INTERRUPTED
    if summary.counts.get("invalid"):
        return EXIT_BAD_INPUT
    if summary.counts.get("error"):
        return EXIT_ERRORS
    if summary.remaining:
        return EXIT_INTERRUPTED
    return EXIT_OK
