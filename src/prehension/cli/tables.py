"""Describing tasks in the terminal: ``prehension tasks`` and ``prehension show``."""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table

from .codes import EXIT_OK

def cmd_tasks(args, console: Console) -> int:
    from ..tasks.library import builtin_task_names, load_builtin_task

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


def cmd_show(args, console: Console) -> int:
    from ..tasks.library import resolve_task
    from .hands import hand_named, print_hand_warnings, show_hand

    hand = hand_named(args.task)
    if hand is not None:
        return show_hand(hand, console)
    task = resolve_task(args.task)
    print_hand_warnings(console, task.hand)
    console.print(f"[bold]{task.name}[/]  hand {task.hand.name!r}, object {task.object.name!r}")
    if task.description:
        console.print(task.description)
    console.print(_links_table(task))
    console.print(_joints_table(task))
    console.print(_contacts_table(task))
    console.print(_size_table(task))
    return EXIT_OK


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
    from ..paper import TABLE2

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


