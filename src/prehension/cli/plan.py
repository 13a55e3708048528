"""``prehension plan MESH --hand HAND --fingers K``: grasps planned on a bare mesh (docs/planning.md).

Candidate sets of ``K`` contact regions are proposed on the mesh and, best first, the
assignment of the hand's fingertips to each set is searched
(:func:`prehension.planning.plan_grasps`), until ``--grasps`` distinct grasps are found.
The output (``-o FILE.jsonl``, default ``<mesh>.plan.jsonl``) is a batch journal with one
record per candidate set tried (:mod:`prehension.assignment.records`): a set's grasp is a
``solved`` record (its best assignment's verified result), a set with none records why
(an assignment left undecided, or proven impossible); ``prehension check`` re-verifies
every record, and running the same command again goes on where it stopped.  With
``--tasks-dir DIR`` every grasp's task (the regions, the assignment, the mesh) is also
written as a task file that ``prehension solve`` solves again, to edit and re-solve.

Exit codes: 0 at least one grasp; 4 none (or interrupted before any); 2 bad input.
"""

from __future__ import annotations

import hashlib
import logging
import re
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..errors import PrehensionError
from . import args as types
from .codes import EXIT_GAVE_UP, EXIT_OK
from .hands import HAND_HELP

__all__ = ["add_parser", "cmd_plan"]

_LOG = logging.getLogger("prehension.planning")
_SET = re.compile(r"->set(\d+)_1(,|$)")


def add_parser(sub) -> None:
    """Add the ``plan`` sub-command to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("plan", help="plan grasps on a bare mesh: contact regions proposed, fingertips assigned and solved")
    p.add_argument("mesh", help="mesh file (OBJ, STL, PLY, OFF, GLB), or a built-in object: teapot, scalpel, guitar (mm)")
    p.add_argument("--hand", required=True, help=HAND_HELP)
    p.add_argument("--fingers", type=types.positive_int, default=3, help="contacts per grasp, 2.. the hand's fingertips (default 3)")
    p.add_argument("--palm", action="store_true", help="the palm's regions may take a contact too")
    p.add_argument("--any-finger", action="store_true",
                   help="every fingertip may take every contact (default: the thumb opposes the other fingertips)")
    units = p.add_mutually_exclusive_group()
    units.add_argument("--scale", type=float, help="mm per mesh-file unit (e.g. 1000 for a file in metres)")
    units.add_argument("--units", choices=("mm", "cm", "m", "in"), help="the mesh file's units")
    p.add_argument("--grasps", type=types.positive_int, default=10, help="stop after this many distinct grasps (default 10)")
    p.add_argument("--samples", type=types.positive_int, default=600, help="surface points sampled (default 600)")
    p.add_argument("--seed", type=types.seed, default=0, help="seed of the proposal and of the solvers (default 0)")
    p.add_argument("-o", "--output", type=Path, help="the grasps, one record per candidate set tried (.jsonl; "
                   "default <mesh>.plan.jsonl); run again to go on; check it with prehension check")  # fmt: skip
    p.add_argument("--tasks-dir", type=Path, metavar="DIR", help="write each grasp's task file here (to edit and re-solve)")
    p.add_argument("--assignment-time", type=types.seconds, default=0.0, metavar="SECONDS",
                   help="complete solver's time on each assignment the local solver did not solve (default 0: none)")
    p.add_argument("--time-limit", type=types.seconds, default=None, metavar="SECONDS",
                   help="start no new candidate set after this many seconds (default: none)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDR", help="a running Dask scheduler, e.g. tcp://host:8786")
    where.add_argument("--workers", type=types.positive_int, help="size of the local Dask cluster (processes)")
    p.add_argument("--quiet", action="store_true", help="no progress or table, only errors")


def _solid(args):
    """The object's solid and name: a built-in object's mesh (mm), or the mesh file at its units."""
    from ..objects.mesh_io import check_mesh_suffix, scale_of
    from ..objects.solid import MeshFileSolid
    from ..tasks.library import builtin_mesh_dir

    builtin = builtin_mesh_dir() / f"{args.mesh}.ply"
    path = Path(args.mesh)
    if not path.suffix and builtin.is_file():
        if args.scale is not None or args.units is not None:
            raise PrehensionError(f"{args.mesh} is a built-in object, in mm: drop --units/--scale")
        return MeshFileSolid(str(builtin), 1.0, "mm"), args.mesh
    if not path.suffix and not path.exists():
        names = ", ".join(sorted(p.stem for p in builtin_mesh_dir().glob("*.ply")))
        raise PrehensionError(f"{args.mesh}: no such mesh file, nor a built-in object (built-in objects: {names})")
    check_mesh_suffix(path)
    scale = scale_of(args.scale, args.units)
    return MeshFileSolid(str(path.resolve()), scale, args.units), path.stem


def _options(args, executor):
    from ..assignment import AssignmentOptions
    from ..planning import PlanOptions, ProposalOptions
    from ..solvers.local import LocalOptions

    search = AssignmentOptions(seed=args.seed, local_options=LocalOptions(i_max=16), complete_time_s=args.assignment_time,
                               executor=executor)  # fmt: skip
    return PlanOptions(fingers=args.fingers, palm=args.palm, oppose=not args.any_finger, grasps=args.grasps,
                       proposal=ProposalOptions(samples=args.samples, seed=args.seed), search=search,
                       time_limit_s=types.time_limit(args.time_limit))  # fmt: skip


def _plan_key(solid, hand, options) -> str:
    """What the set indices of a run depend on (mesh bytes and scale, hand, options), digested:
    a journal holds the sets of one key only, so a resumed run never mixes two proposals."""
    h = hashlib.sha256(solid.content() or b"")
    h.update(repr((hand.name, sorted(hand.regions), options.fingers, options.palm, options.oppose, options.proposal)).encode())
    return h.hexdigest()[:8]


def _resumed(path: Path, prefix: str) -> dict[int, bool]:
    """Sets an earlier run recorded in ``path``: ``{set index: gave a grasp}``; refuses a
    journal of another plan (other mesh, hand or options)."""
    from ..batch.journal import read_records

    if not path.exists():
        return {}
    done: dict[int, bool] = {}
    for record in read_records(path):
        name, m = str(record.get("task", "")), _SET.search(str(record.get("id", "")))
        if not name.startswith(prefix) or m is None:
            raise PrehensionError(f"{path} holds records of another plan (task {name!r}; this plan's tasks are {prefix}*): "
                                  "write to another file (-o), or plan with the settings it was made with")  # fmt: skip
        done[int(m.group(1))] = done.get(int(m.group(1)), False) or record.get("status") == "solved"
    return done


def cmd_plan(args, console: Console) -> int:
    """Plan grasps on ``args.mesh``; one record per candidate set tried in the output."""
    from ..atomic import check_output_path
    from ..parallel import check_where, executor_for
    from ..tasks.format.tasks import resolve_hand
    from .hands import print_hand_warnings

    solid, name = _solid(args)
    hand = resolve_hand(args.hand)
    print_hand_warnings(None if args.quiet else console, hand)
    options = _options(args, None)
    key = f"{name}-plan{_plan_key(solid, hand, options)}"
    path = check_output_path(args.output or Path(f"{name}.plan.jsonl"), "plan output (-o)", inputs=[Path(solid.path)],
                             suffixes=(".jsonl",))  # fmt: skip
    skip = _resumed(path, key + "-")
    check_where(args.scheduler, args.workers)
    with executor_for(args.scheduler, args.workers) as executor:
        run = _run(args, solid, hand, key, path, _options(args, executor), skip, console)
    return _finish(args, console, path, run)


def _writer(journal, appender, source: str, seed: int, tasks_dir: Path | None):
    """``on_set``: each set's verdict appended to the journal (its task and file lines once),
    a grasp's task file written to ``tasks_dir``."""
    from ..assignment.records import verdict_line

    def write(verdict) -> None:
        _LOG.info("set %d: %s (%d assignments)", verdict.set_index, "grasp" if verdict.grasp else "no grasp", verdict.assignments)
        if verdict.verdict is None:  # its regions could not be grown: nothing to record
            return
        line, loaded = verdict_line(verdict.verdict, source, seed)
        appender.put(journal.lines_needed(loaded) + [line.line])
        if verdict.grasp is not None and tasks_dir is not None:
            _write_task(verdict.grasp.outcome.task, tasks_dir)

    return write


def _write_task(task, tasks_dir: Path) -> None:
    from ..tasks.yaml_io import dump_task

    tasks_dir.mkdir(parents=True, exist_ok=True)
    dump_task(task, tasks_dir / f"{task.name}.yaml")


def _run(args, solid, hand, key: str, path: Path, options, skip: dict, console: Console):
    """The plan, its sets appended to the journal as they are decided: ``(report, interrupted)``."""
    from ..batch.journal import Appender, open_journal
    from ..planning import plan_grasps
    from .progress import LiveProgress

    with open_journal(path) as (journal, _state):
        appender = Appender(journal)
        write = _writer(journal, appender, str(args.mesh), options.search.seed, args.tasks_dir)
        report, interrupted = None, False
        with LiveProgress(console, enabled=not args.quiet, time_limit_s=options.time_limit_s) as update:
            def progress(p) -> None:
                _LOG.info("plan: %d of %d sets tried, %d grasps, %d assignments decided", p.sets_tried, p.sets, p.grasps, p.assignments)
                if update is not None:
                    update({"stage": "plan", "sets": f"{p.sets_tried} / {p.sets}", "grasps": p.grasps, "assignments": p.assignments})

            try:
                report = plan_grasps(solid, hand, options, name=key, skip=skip, progress=progress, on_set=write)
            except KeyboardInterrupt:
                interrupted = True
            finally:
                appender.close()
    return report, interrupted


def _epsilon(record) -> float:
    sols = (record.get("result") or {}).get("solutions") or []
    values = [(s.get("quality") or {}).get("epsilon") for s in sols]
    return max((float(v) for v in values if isinstance(v, (int, float))), default=-1.0)


def _finish(args, console: Console, path: Path, run) -> int:
    """The grasps of the journal (this run's and earlier ones), best first; the exit code."""
    from ..batch.journal import read_records

    report, interrupted = run
    records = list(read_records(path))
    grasps = sorted((r for r in records if r.get("status") == "solved"), key=_epsilon, reverse=True)
    if not args.quiet:
        table = Table(title=f"Grasps planned on {escape(str(args.mesh))}, best first ({len(grasps)})", title_justify="left")
        for col in ("#", "task", "assignment (hand region -> object region)", "epsilon"):
            table.add_column(col, justify="right" if col in ("#", "epsilon") else "left")
        for k, r in enumerate(grasps):
            table.add_row(str(k + 1), escape(str(r.get("task"))), escape(str(r.get("id"))), f"{_epsilon(r):.4g}")
        console.print(table)
        if report is not None:
            pts = report.points
            console.print(f"{len(pts.points)} surface points, {pts.pairs} antipodal pairs within reach, {pts.scored} sets scored, "
                          f"{report.sets} distinct candidate sets; this run tried {report.tried} ({report.assignments} "
                          f"assignments) and found {len(report.grasps)} grasps in {report.seconds:.1f} s -> {path}")  # fmt: skip
        if interrupted:
            console.print("[bold yellow]interrupted[/]: what was decided is saved; run the same command again to go on")
        if args.tasks_dir is not None:
            console.print(f"task files of the grasps: {args.tasks_dir}/ (edit and re-solve with prehension solve)")
        console.print(f"check it: prehension check {path}")
    return EXIT_OK if grasps else EXIT_GAVE_UP
