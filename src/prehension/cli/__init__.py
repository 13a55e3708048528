"""The ``prehension`` command line.

Exit codes (``prehension.cli.codes``): 0 done / solved, 2 bad input (the message names
the problem), 3 proven infeasible, 4 gave up, 5 a checked result does not hold,
6 only an approximate answer (``solve --approximate``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console
from rich.markup import escape

from .. import __version__
from ..errors import PrehensionError
from . import batch, hands, offline, view
from .codes import EXIT_APPROXIMATE, EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK

__all__ = [
    "main", "build_parser", "EXIT_OK", "EXIT_BAD_INPUT", "EXIT_INFEASIBLE", "EXIT_GAVE_UP", "EXIT_CHECK_FAILED",
    "EXIT_APPROXIMATE",
]  # fmt: skip

TASK_HELP = "built-in task name, task file (.yaml) or CuikSuite file (.world)"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="prehension",
        description="Grasp configurations of multi-fingered hands with specified contact regions.",
    )
    parser.add_argument("--version", action="version", version=f"prehension {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("tasks", help="list the built-in tasks")
    show = sub.add_parser("show", help="describe a task (hand, limits, contacts, problem size) or a hand (fingers, fingertips)")
    show.add_argument("task", help=f"{TASK_HELP}; or a {hands.HAND_HELP}")
    _add_solve(sub)
    check = sub.add_parser("check", help="re-verify a result file against its task")
    check.add_argument("result", type=Path, help="result file (.json) of 'prehension solve', or the output (.jsonl) of 'prehension batch'")
    _add_import(sub)
    offline.add_parser(sub)
    batch.add_parser(sub)
    view.add_parsers(sub)
    hands.add_parsers(sub)
    return parser


def _add_solve(sub) -> None:
    p = sub.add_parser("solve", help="find a grasp configuration (or prove there is none)")
    p.add_argument("task", help=TASK_HELP)
    p.add_argument("--method", choices=("auto", "local", "complete"), default="auto",
                   help="auto (default): the local solver, then the complete one if it fails")  # fmt: skip
    p.add_argument("-o", "--output", type=Path, help="result file (default: TASK.result.json; an older one is kept as a backup)")
    p.add_argument("--all", action="store_true", help="complete solver: search the whole solution set (breadth first)")
    p.add_argument("--sigma", type=float, default=0.1, help="complete solver: solution-box size (fraction of the initial box)")
    p.add_argument("--workers", type=int, default=1,
                   help="complete solver: boxes processed in parallel on a local Dask cluster of N processes")  # fmt: skip
    p.add_argument("--scheduler", metavar="ADDR", help="complete solver: process boxes on a running Dask cluster (tcp://host:8786)")
    p.add_argument("--time-limit", type=float, default=None, metavar="SECONDS", help="give up after this long")
    p.add_argument("--max-boxes", type=int, default=None, help="complete solver: give up after this many boxes")
    p.add_argument("--checkpoint", type=Path, help="complete solver: save the open boxes here when stopped (Ctrl-C too)")
    p.add_argument("--resume", action="store_true", help="complete solver: continue from --checkpoint")
    p.add_argument("--seed", type=int, default=0, help="random seed (local solver)")
    p.add_argument("--sequence", type=Path, metavar="FILE", help="local solver: initial poses from 'prehension offline' (.json)")
    p.add_argument("--approximate", action="store_true",
                   help="accept an answer within the paper's d_min tolerances (1.5 mm) when no strict solution is found: "
                        "status 'approximate', exit code 6, never 'solved'")  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress or tables, only errors")
    p.add_argument("--json", action="store_true", help="print the result summary as JSON on stdout")
    p.add_argument("--html", type=Path, metavar="FILE", help="also write the 3-D view of the grasp (as 'prehension view')")


def _add_import(sub) -> None:
    imp = sub.add_parser("import-cuik", help="convert a CuikSuite .world grasp problem into a task file")
    imp.add_argument("world", type=Path, help="the .world file")
    imp.add_argument("-o", "--output", type=Path, required=True, help="task file to write (.yaml)")
    imp.add_argument("--name", help="task name (default: the world file's folder name)")
    imp.add_argument(
        "--angle2", choices=("2011", "current"), default="2011",
        help="sign of universal-joint angle 2: as in the 2011 CuikSuite release (default) or the current one",
    )  # fmt: skip
    imp.add_argument("--couple-distal", action="store_true", help="couple the last two revolute joints of each finger")
    imp.add_argument(
        "--couple", action="append", default=[], metavar="ANGLE=SOURCE", help="couple two joint angles (equal angles)"
    )
    imp.add_argument("--force", action="store_true", help="overwrite the output file if it exists")


def main(argv: list[str] | None = None) -> int:
    from .batch import cmd_batch
    from .check import cmd_check
    from .convert import cmd_import
    from .hands import cmd_export_hand
    from .solve import cmd_solve
    from .tables import cmd_show, cmd_tasks
    from .view import cmd_render, cmd_view

    parser = build_parser()
    args = parser.parse_args(argv)
    console = Console(highlight=False, quiet=bool(getattr(args, "quiet", False)))
    commands = {
        "tasks": cmd_tasks, "show": cmd_show, "import-cuik": cmd_import, "solve": cmd_solve,
        "check": cmd_check, "offline": _cmd_offline, "batch": cmd_batch,
        "view": cmd_view, "render": cmd_render, "export-hand": cmd_export_hand,
    }  # fmt: skip
    if args.command is None:
        parser.print_help()
        return EXIT_OK
    try:
        return commands[args.command](args, console)
    except PrehensionError as exc:
        Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {escape(str(exc))}", markup=True, soft_wrap=True)
        return EXIT_BAD_INPUT


def _cmd_offline(args, console: Console) -> int:
    from .offline import cmd_offline

    return cmd_offline(args, console)
