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

from ..deadline import TimeLimitReached
from ..errors import PrehensionError
from . import batch, check, export, hands, import_grasps, offline, plan, region, simulate, solve, view
from .terminate import Terminated, termination_as_interrupt
from .codes import EXIT_APPROXIMATE, EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK

__all__ = [
    "main", "build_parser", "EXIT_OK", "EXIT_BAD_INPUT", "EXIT_INFEASIBLE", "EXIT_GAVE_UP", "EXIT_CHECK_FAILED",
    "EXIT_APPROXIMATE",
]  # fmt: skip

TASK_HELP = solve.TASK_HELP


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="prehension",
        description="Grasp configurations of multi-fingered hands with specified contact regions.",
    )
    parser.add_argument("--version", action=_Version, help="show the program's version number and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("tasks", help="list the built-in tasks")
    show = sub.add_parser("show", help="describe a task (hand, limits, contacts, problem size) or a hand (fingers, fingertips)")
    show.add_argument("task", help=f"{TASK_HELP}; or a {hands.HAND_HELP}")
    solve.add_parser(sub)
    check.add_parser(sub)
    _add_import(sub)
    offline.add_parser(sub)
    batch.add_parser(sub)
    view.add_parsers(sub)
    hands.add_parsers(sub)
    region.add_parser(sub)
    plan.add_parser(sub)
    simulate.add_parser(sub)
    export.add_parser(sub)
    import_grasps.add_parser(sub)
    return parser


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


class _Version(argparse.Action):
    """``--version``: prints ``prehension X.Y.Z`` and exits; the version is read only when
    asked for (reading the package metadata would cost every command ~10 ms)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from .. import __version__

        print(f"prehension {__version__}")  # on stdout, as argparse's own "version" action
        parser.exit()


def main(argv: list[str] | None = None) -> int:
    from .batch import cmd_batch
    from .check import cmd_check
    from .region import cmd_region
    from .convert import cmd_import
    from .hands import cmd_export_hand
    from .solve import cmd_solve
    from .tables import cmd_show, cmd_tasks
    from .view import cmd_render, cmd_view

    import sys

    from .args import check_option_rules, join_negative_values

    parser = build_parser()
    args = parser.parse_args(join_negative_values(list(sys.argv[1:] if argv is None else argv)))
    check_option_rules(args)
    console = Console(highlight=False, quiet=bool(getattr(args, "quiet", False)))
    commands = {
        "tasks": cmd_tasks, "show": cmd_show, "import-cuik": cmd_import, "solve": cmd_solve,
        "check": cmd_check, "offline": _cmd_offline, "batch": cmd_batch,
        "view": cmd_view, "render": cmd_render, "export-hand": cmd_export_hand, "region": cmd_region,
        "simulate": simulate.cmd_simulate, "export": export.cmd_export, "import-grasps": import_grasps.cmd_import_grasps,
        "plan": plan.cmd_plan,
    }  # fmt: skip
    if args.command is None:
        parser.print_help()
        return EXIT_OK
    try:
        with termination_as_interrupt():  # SIGTERM and SIGHUP save what Ctrl-C saves
            return commands[args.command](args, console)
    except PrehensionError as exc:
        Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {escape(str(exc))}", markup=True, soft_wrap=True)
        return EXIT_BAD_INPUT
    except TimeLimitReached as exc:  # a command that can save part of its work says so itself
        Console(stderr=True, highlight=False).print(f"gave up: {exc}; nothing was written", markup=False, soft_wrap=True)
        return EXIT_GAVE_UP
    except KeyboardInterrupt as exc:  # what a command saves on Ctrl-C it has saved; say so in one line
        what = str(exc) if isinstance(exc, Terminated) else "Ctrl-C"
        Console(stderr=True, highlight=False).print(f"interrupted ({what}); nothing more was written", soft_wrap=True)
        return EXIT_GAVE_UP
    except MemoryError:
        Console(stderr=True, highlight=False).print(
            "error: out of memory; try fewer workers, a smaller batch or --chunk-size, or a machine with more memory",
            soft_wrap=True,
        )  # fmt: skip
        return EXIT_GAVE_UP


def _cmd_offline(args, console: Console) -> int:
    from .offline import cmd_offline

    return cmd_offline(args, console)
