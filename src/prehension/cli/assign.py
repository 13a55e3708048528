"""``prehension solve OPEN_TASK.yaml``: the assignment search of an open task (docs/assignment.md).

A task file whose contacts leave the hand region open (``hand: any`` or a list of
candidates) has one answer per assignment, so its output is a ``.jsonl`` journal, one
batch record per assignment (:mod:`prehension.assignment.records`), appended as
assignments are decided: a run stopped by Ctrl-C (or a crash) goes on where it stopped
when run again; ``prehension check`` re-verifies every record.  A single result file
(``-o x.json``) is refused: it would hold one assignment's answer only.

Exit codes: 0 at least one feasible assignment; 3 every assignment proven impossible;
4 none feasible and some undecided (or the run was interrupted); 2 bad input.
"""

from __future__ import annotations

import re
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..errors import PrehensionError
from . import args as types
from .codes import EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK

__all__ = ["cmd_solve_open", "add_assignment_arguments", "refuse_open_only"]

DEFAULT_ASSIGNMENT_TIME_S = 2.0
DEFAULT_OPEN_TIME_LIMIT_S = 60.0  # an open task's whole search, unless --time-limit says otherwise (0: none)


class SolveDefaultLimit(float):
    """``solve --time-limit`` when not given (300 s for one task): an open task's search
    takes :data:`DEFAULT_OPEN_TIME_LIMIT_S` instead; a given value, 300 too, is kept."""
SHOWN = 20  # rows of the feasible table (the journal has them all)
# solve's options that a closed task's single solve uses and the assignment search does not
_NOT_FOR_OPEN = {"all": "--all", "sigma": "--sigma", "max_boxes": "--max-boxes", "checkpoint": "--checkpoint",
                 "resume": "--resume", "sequence": "--sequence", "approximate": "--approximate", "html": "--html",
                 "best": "--best", "require": "--require", "json": "--json"}  # fmt: skip


def add_assignment_arguments(p) -> None:
    """The options of ``solve`` on an open task."""
    g = p.add_argument_group("open tasks: the assignment search (hand: any, or candidates; docs/assignment.md)")
    g.add_argument("--assignment-time", type=types.seconds, default=None, metavar="SECONDS",
                   help="complete solver's time on each assignment the local solver did not solve (default 2; 0: none, "
                        "those stay undecided)")  # fmt: skip
    g.add_argument("--initial-poses", type=types.positive_int, default=None, metavar="N",
                   help="local solver's initial poses per assignment (default 64, as solve; the paper's 12 decides "
                        "a search several times faster, missing a few grasps a long search would find)")  # fmt: skip
    g.add_argument("--retry-undecided", action="store_true",
                   help="decide again the assignments the output records as undecided (gave_up), going on after the "
                        "initial poses the earlier run tried (docs/assignment.md)")


def refuse_open_only(args) -> None:
    """On a task that is not open: the assignment options are refused, not ignored."""
    for key, flag in (("assignment_time", "--assignment-time"), ("retry_undecided", "--retry-undecided"),
                      ("initial_poses", "--initial-poses")):
        if getattr(args, key, None) not in (None, False):
            raise PrehensionError(f"{flag} is an option of the assignment search; {args.task} is not an open task "
                                  "(no contact says 'hand: any' or lists candidates): drop it")  # fmt: skip


def _refuse_closed_only(args) -> None:
    given = [flag for key, flag in _NOT_FOR_OPEN.items() if getattr(args, key, None) not in (None, False)]
    if given:
        raise PrehensionError(f"{given[0]} is an option of solving one task; an open task runs the assignment search, "
                              "which does not use it (docs/assignment.md)")  # fmt: skip
    if args.method == "complete":
        raise PrehensionError("--method complete: the assignment search runs the local solver on every assignment first, "
                              "then the complete solver (--assignment-time) on the rest; use --method auto (default) or local")  # fmt: skip


def _output(args, task) -> Path:
    from ..atomic import check_output_path
    from .outputs import files_of_task, task_inputs

    if args.output is not None and args.output.suffix.lower() != ".jsonl":
        raise PrehensionError(f"{args.output}: an open task has one answer per assignment; write them to a .jsonl file "
                              "(-o NAME.jsonl; re-run to resume, check it with prehension check)")  # fmt: skip
    stem = re.sub(r"[^A-Za-z0-9._+-]+", "_", task.name).lstrip("._") or "task"
    path = args.output or Path(f"{stem}.assignments.jsonl")
    inputs = task_inputs(args.task) + files_of_task(task)
    return check_output_path(path, "assignment output (-o)", inputs=inputs)


def _search_options(args, executor):
    from ..assignment import AssignmentOptions
    from ..solvers.local import LocalOptions
    from .best import quality_options

    hold = None
    if args.hold:
        from ..sim import SimOptions, require_mujoco

        require_mujoco()
        hold = SimOptions()
    given = DEFAULT_ASSIGNMENT_TIME_S if args.assignment_time is None else args.assignment_time
    complete = 0.0 if args.method == "local" else (types.time_limit(given, "--assignment-time") or 0.0)
    local = LocalOptions() if args.initial_poses is None else LocalOptions(i_max=args.initial_poses)
    return AssignmentOptions(seed=args.seed, local_options=local, complete_time_s=complete, quality=quality_options(args),
                             hold=hold, executor=executor, time_limit_s=types.time_limit(_time_limit(args)))  # fmt: skip


def _time_limit(args) -> float:
    """``--time-limit``, else the open task's default (:data:`DEFAULT_OPEN_TIME_LIMIT_S`)."""
    return DEFAULT_OPEN_TIME_LIMIT_S if isinstance(args.time_limit, SolveDefaultLimit) else args.time_limit


def cmd_solve_open(args, console: Console) -> int:
    """Search the assignments of the open task ``args.task``; one record each in the output."""
    from ..assignment import enumerate_assignments
    from ..parallel import check_where, executor_for
    from ..tasks.yaml_io import load_open_task

    _refuse_closed_only(args)
    task = load_open_task(args.task)
    path = _output(args, task)
    where = (args.scheduler, args.workers if args.workers > 1 else None)
    check_where(*where)
    _search_options(args, None)  # every option checked before a cluster starts
    total = len(enumerate_assignments(task))
    quiet = args.quiet
    if not quiet:
        console.print(f"task {escape(task.name)!r}: {total} assignment(s) of {len(task.contacts)} contact(s) -> {path}")
    with executor_for(*where) as executor:
        run = _run(args, task, path, _search_options(args, executor), console)
    return _finish(console, args, task, path, run)


def _run(args, task, path: Path, options, console: Console):
    """The search, its verdicts appended to the journal as they come; ``(report, notes, interrupted)``."""
    from ..assignment import search_assignments
    from ..assignment.records import verdict_line
    from ..assignment.resume import earlier_runs
    from ..batch.journal import Appender, open_journal, read_records
    from .progress import LiveProgress

    earlier = earlier_runs(read_records(path)) if args.retry_undecided and path.is_file() else {}
    with open_journal(path, args.retry_undecided) as (journal, state):
        appender = Appender(journal)

        def write(item) -> None:
            line, loaded = verdict_line(item, str(args.task), options.seed, options.local_options.i_max)
            appender.put(journal.lines_needed(loaded) + [line.line])

        report, interrupted = None, False
        with LiveProgress(console, enabled=not args.quiet, time_limit_s=options.time_limit_s) as update:
            progress = None if update is None else (lambda p: update({"stage": "assignments", "decided": f"{p.decided} / {p.total}",
                                                                      **p.counts}))  # fmt: skip
            try:
                report = search_assignments(task, options, progress=progress, skip=state.done, on_decided=write,
                                            earlier=earlier)  # fmt: skip
            except KeyboardInterrupt:
                interrupted = True
            finally:
                appender.close()
    return report, state.notes, interrupted


def _finish(console: Console, args, task, path: Path, run) -> int:
    """Report from the journal (this run's verdicts and earlier ones alike); the exit code."""
    from ..assignment import enumerate_assignments
    from ..batch.journal import read_records

    report, notes, interrupted = run
    labels = [a.label for a in enumerate_assignments(task)]
    records = {r["id"]: r for r in read_records(path) if r.get("id") in set(labels)}
    verdicts = {label: _verdict(records.get(label)) for label in labels}
    feasible = sorted((r for r in records.values() if r.get("status") == "solved"), key=_rank_key, reverse=True)
    if not args.quiet:
        for note in notes:
            console.print(f"[yellow]journal:[/] {note}")
        console.print(_table(task, feasible))
        _summary(console, verdicts, records, report, path, interrupted)
    if feasible:
        return EXIT_OK
    if not interrupted and all(v == "infeasible" for v in verdicts.values()):
        return EXIT_INFEASIBLE
    return EXIT_GAVE_UP


def _verdict(record) -> str:
    if record is None:
        return "not decided"
    return {"solved": "feasible", "infeasible": "infeasible"}.get(record.get("status"), "undecided")


def _best_quality(record) -> dict:
    sols = (record.get("result") or {}).get("solutions") or []
    entries = [s.get("quality") or {} for s in sols]
    return max(entries, key=lambda q: (bool(q.get("force_closure")), _number(q.get("epsilon"))), default={})


def _number(value) -> float:
    return float(value) if isinstance(value, (int, float)) else -1.0


def _rank_key(record) -> tuple:
    q = _best_quality(record)
    held = any(p.get("held") for p in record.get("physics") or [] if isinstance(p, dict))
    return (held, bool(q.get("force_closure")), _number(q.get("epsilon")))


def _table(task, feasible) -> Table:
    """One row per feasible assignment, best first: the hand region of each contact (a
    column per contact, headed by its object region), the quality of its best grasp."""
    table = Table(title=f"Feasible assignments, best first ({len(feasible)})", title_justify="left")
    table.add_column("#", justify="right")
    for c in task.contacts:
        table.add_column(escape(c.object_region))
    for col in ("method", "force closure", "epsilon", "contact [mm]"):
        table.add_column(col, justify="left" if col in ("method", "force closure") else "right")
    for k, r in enumerate(feasible[:SHOWN]):
        q = _best_quality(r)
        hands = (r.get("assignment") or {}).get("hand_regions") or ["?"] * len(task.contacts)
        worst = max((s.get("worst", {}).get("contact_distance", 0.0) for s in r["result"].get("solutions", [])), default=0.0)
        table.add_row(str(k + 1), *map(escape, hands), str(r.get("method")), "yes" if q.get("force_closure") else "no",
                      f"{_number(q.get('epsilon')):.4g}", f"{worst:.1e}")  # fmt: skip
    if len(feasible) > SHOWN:
        table.caption = f"... and {len(feasible) - SHOWN} more in the output"
    return table


def _summary(console: Console, verdicts: dict, records: dict, report, path: Path, interrupted: bool) -> None:
    counts = {v: sum(1 for x in verdicts.values() if x == v) for v in ("feasible", "infeasible", "undecided", "not decided")}
    by_span = sum(1 for r in records.values() if r.get("method") == "span")
    seconds = f"; {report.seconds:.1f} s" if report is not None else ""
    skipped = f", {report.skipped} decided by an earlier run" if report is not None and report.skipped else ""
    console.print(f"{len(verdicts)} assignments: {counts['feasible']} feasible, {counts['infeasible']} proven impossible "
                  f"({by_span} by the hand's span), {counts['undecided']} undecided{skipped}{seconds} -> {path}")  # fmt: skip
    for label, v in verdicts.items():
        if v == "undecided":
            console.print(f"  undecided: {escape(label)}: {escape(str(records[label].get('message')))}", style="dim")
    if interrupted or counts["not decided"]:
        console.print("[bold yellow]interrupted[/]: what was decided is saved; run the same command again to go on")
    console.print(f"check it: prehension check {path}")
