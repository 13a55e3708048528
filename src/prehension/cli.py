"""The ``prehension`` command line.

Exit codes: 0 success; 2 bad input (an unknown task, a malformed task or world file, an
output file that already exists...): the message names the problem.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from . import __version__
from .errors import PrehensionError

__all__ = ["main", "build_parser", "EXIT_OK", "EXIT_BAD_INPUT"]

EXIT_OK = 0
EXIT_BAD_INPUT = 2


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="prehension",
        description="Grasp configurations of multi-fingered hands with specified contact regions.",
    )
    parser.add_argument("--version", action="version", version=f"prehension {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("tasks", help="list the built-in tasks")
    show = sub.add_parser("show", help="describe a task: hand, limits, contacts, problem size")
    show.add_argument("task", help="built-in task name, task file (.yaml) or CuikSuite file (.world)")
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
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    console = Console(highlight=False)
    commands = {"tasks": _cmd_tasks, "show": _cmd_show, "import-cuik": _cmd_import}
    if args.command is None:
        parser.print_help()
        return EXIT_OK
    try:
        return commands[args.command](args, console)
    except PrehensionError as exc:
        Console(stderr=True, highlight=False).print(f"[bold red]error:[/] {exc}", markup=True, soft_wrap=True)
        return EXIT_BAD_INPUT


# -- commands ---------------------------------------------------------------------------
def _cmd_tasks(args, console: Console) -> int:
    from .tasks.library import builtin_task_names, load_builtin_task

    table = Table(title="Built-in tasks", title_justify="left")
    table.add_column("task", no_wrap=True)
    for col in ("object", "fingers", "contacts", "what the grasp must do"):
        table.add_column(col, overflow="fold")
    for name in builtin_task_names():
        task = load_builtin_task(name)
        summary = task.description.split(". ")[0].rstrip(".") if task.description else ""
        table.add_row(name, task.object.name, ", ".join(task.fingers), str(len(task.contacts)), summary)
    console.print(table)
    return EXIT_OK


def _cmd_show(args, console: Console) -> int:
    from .tasks.library import resolve_task

    task = resolve_task(args.task)
    console.print(f"[bold]{task.name}[/]  hand {task.hand.name!r}, object {task.object.name!r}")
    if task.description:
        console.print(task.description)
    console.print(_links_table(task))
    console.print(_joints_table(task))
    console.print(_contacts_table(task))
    console.print(_size_table(task))
    return EXIT_OK


def _cmd_import(args, console: Console) -> int:
    from .tasks.cuik_import import import_world
    from .tasks.yaml_io import dump_task

    if args.output.exists() and not args.force:
        raise PrehensionError(f"{args.output} already exists; pass --force to overwrite it")
    couplings = tuple(_parse_coupling(c) for c in args.couple)
    task = import_world(
        args.world, name=args.name, angle2=args.angle2, couplings=couplings, couple_distal=args.couple_distal
    )
    dump_task(task, args.output)
    console.print(
        f"wrote {args.output}: task {task.name!r}, {len(task.contacts)} contacts, "
        f"fingers {', '.join(task.fingers)}, {len(task.hand.couplings)} couplings"
    )
    return EXIT_OK


def _parse_coupling(text: str) -> tuple[str, str]:
    angle, sep, source = text.partition("=")
    if not sep or not angle.strip() or not source.strip():
        raise PrehensionError(f"--couple {text!r}: write ANGLE=SOURCE, e.g. --couple p14=p13")
    return angle.strip(), source.strip()


# -- tables -----------------------------------------------------------------------------
def _deg(x: float) -> str:
    return f"{np.degrees(x):.4g}"


def _links_table(task) -> Table:
    hand = task.hand
    table = Table(title="Links", title_justify="left")
    for col in ("link", "finger", "parent joint", "collision capsules"):
        table.add_column(col)
    for link in hand.links:
        joint = hand.joint_of_link(link.name)
        table.add_row(
            link.name, hand.finger_of_link(link.name) or "-",
            "-" if joint is None else f"{joint.name} ({joint.kind})", str(len(link.collision)),
        )  # fmt: skip
    return table


def _joints_table(task) -> Table:
    hand = task.hand
    coupled = {c.dof: c for c in hand.couplings}
    active = task.active_mask
    idle = task.idle_vector
    table = Table(title="Joint angles [deg]", title_justify="left")
    for col in ("angle", "joint", "lower", "upper", "coupling", "in this task"):
        table.add_column(col)
    for i, (dof, lo, hi) in enumerate(zip(hand.dof_names, hand.lower, hand.upper)):
        joint = next(j for j in hand.joints if dof in j.dof_names)
        c = coupled.get(dof)
        coupling = "-" if c is None else f"= {c.ratio:g} x {c.source} + {_deg(c.offset)}"
        role = "moves" if active[i] else f"held at {_deg(idle[i])}"
        table.add_row(dof, joint.name, _deg(lo), _deg(hi), coupling, role)
    return table


def _contacts_table(task) -> Table:
    table = Table(title="Contacts", title_justify="left")
    for col in ("contact", "hand region", "on link", "object region"):
        table.add_column(col)
    for c in task.contacts:
        hr = task.hand_region(c)
        oreg = task.object_region(c)
        table.add_row(
            c.name, f"{c.hand_region}: {hr.region.describe()}", hr.link, f"{c.object_region}: {oreg.describe()}"
        )
    return table


def _size_table(task) -> Table:
    from .paper import TABLE2

    counts = task.counts()
    table = Table(
        title="Problem size",
        title_justify="left",
        caption="The paper counts its polynomial system (link rotations, normals, norms...): "
        "a larger but equivalent formulation of the same problem.",
        caption_justify="left",
    )
    table.add_column("quantity")
    table.add_column("this task")
    table.add_column("paper (Table 2)")
    paper = TABLE2.get(task.name)
    rows = [
        ("moving joint angles", counts["moving_angles"], None),
        ("independent joint angles", counts["independent_angles"], None),
        ("region parameters", counts["region_parameters"], None),
        ("variables (angles + 6 pose + region parameters)", counts["variables"], paper and paper.n_v),
        ("equations (5 per contact)", counts["equations"], paper and paper.n_e),
        ("expected solution dimension", counts["dimension"], paper and paper.d),
    ]
    for label, ours, theirs in rows:
        table.add_row(label, str(ours), "" if theirs is None else str(theirs))
    return table


if __name__ == "__main__":
    sys.exit(main())
