"""Hands on the command line: ``prehension show HAND`` and ``prehension export-hand HAND``.

A HAND is a built-in name (``schunk-sa``, alias ``sa``), a URDF (``.urdf``), an MJCF
(``.xml``, ``.mjcf``; needs the ``mjcf`` extra) or a hand YAML file.  Every command that
reads a hand prints the warnings of its import (missing meshes, unsupported joints...).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..errors import PrehensionError
from .codes import EXIT_OK

__all__ = ["add_parsers", "cmd_export_hand", "hand_named", "show_hand", "print_hand_warnings", "HAND_HELP"]

HAND_HELP = "built-in hand (schunk-sa, alias sa), hand file (.urdf; .xml/.mjcf for MJCF; .yaml)"
_EXPORTS = {".urdf": "urdf", ".xml": "mjcf", ".mjcf": "mjcf"}


def add_parsers(sub) -> None:
    """The ``export-hand`` sub-command."""
    p = sub.add_parser("export-hand", help="write a hand as URDF (.urdf) or MJCF (.xml)")
    p.add_argument("hand", help=HAND_HELP)
    p.add_argument("-o", "--output", type=Path, required=True, help="file to write: .urdf (URDF) or .xml/.mjcf (MJCF)")
    p.add_argument("--force", action="store_true", help="overwrite the output file if it exists")


def hand_named(spec: str):
    """The hand ``spec`` names, or None when it names a task (a built-in task, a task file)."""
    from ..hands.files import HAND_SUFFIXES
    from ..tasks.format.tasks import HAND_ALIASES, resolve_hand
    from ..tasks.format.schema import BUILTIN_HANDS

    path = Path(spec)
    suffix = path.suffix.lower()
    if HAND_ALIASES.get(spec, spec) in BUILTIN_HANDS or suffix in HAND_SUFFIXES:
        return resolve_hand(spec)
    if path.is_dir() and any(p.suffix.lower() in HAND_SUFFIXES for p in path.iterdir()):
        return resolve_hand(spec)  # a hand's folder: says so, naming the hand files in it
    if suffix in (".yaml", ".yml") and path.is_file() and not _is_task_file(path):
        return resolve_hand(spec)
    return None


def _is_task_file(path: Path) -> bool:
    from ..tasks.format.yaml_text import parse_yaml, read_text

    data = parse_yaml(read_text(path, str(path)), str(path))
    return isinstance(data, dict) and "prehension" in data


def print_hand_warnings(console: Console | None, hand) -> None:
    """Print the warnings of a hand's import on stderr (the other notes are for ``show``);
    nothing when ``console`` is quiet."""
    if console is not None and console.quiet:
        return
    err = Console(stderr=True, highlight=False)
    for note in hand.notes:
        if note.startswith("warning: "):
            err.print(f"[yellow]warning:[/] {escape(note[len('warning: '):])} (hand {hand.name!r})", soft_wrap=True)


# -- show -------------------------------------------------------------------------------------
def _deg(x: float) -> str:
    return f"{np.degrees(x):.4g}"


def _vec(v) -> str:
    v = np.asarray(v, dtype=float)
    return "[" + ", ".join(f"{x:.3g}" for x in np.where(np.abs(v) < 1e-9, 0.0, v) + 0.0) + "]"


def _links_text(links) -> str:
    return links[0] if len(links) == 1 else f"{links[0]} .. {links[-1]} ({len(links)})"


def _fingers_table(hand) -> Table:
    table = Table(title="Fingers and fingertips (caps in the distal link's frame)", title_justify="left")
    for col in ("finger", "links", "fingertip", "radius mm", "half-angle", "centre; axis", "fit"):
        table.add_column(col, overflow="fold")
    for f in hand.fingers:
        name = f.name + (" (opposes)" if f.name == hand.opposing_finger else "")
        reg = hand.regions.get(f"{f.name}_tip")
        if reg is None:
            table.add_row(name, _links_text(f.links), "-", "", "", "", "no fingertip found")
            continue
        cap, fit = reg.region, hand.tip_fits.get(f"{f.name}_tip")
        if not hasattr(cap, "radius"):
            table.add_row(name, _links_text(f.links), f"{f.name}_tip", "", "", cap.describe(), "given")
            continue
        table.add_row(
            name, _links_text(f.links), f"{f.name}_tip on {reg.link}", f"{cap.radius:.3g}", f"{_deg(cap.half_angle)} deg",
            f"{_vec(cap.center)}; {_vec(cap.axis)}", _fit_text(fit),
        )  # fmt: skip
    return table


def _fit_text(fit) -> str:
    if fit is None:
        return "given"
    if fit.n_points == 0:
        return fit.describe()
    over = f"; overridden: {', '.join(fit.overridden)}" if fit.overridden else ""
    return f"rms {fit.rms_mm:.2f}, max {fit.max_mm:.2f} mm ({fit.n_points} points, {fit.geometry}){over}"


def _joints_table(hand) -> Table:
    coupled = {c.dof: c for c in hand.couplings}
    named = any(j.dof_names != (j.name,) for j in hand.joints)  # show joint names only when they differ
    table = Table(title="Joint angles [deg]", title_justify="left")
    for col in ("angle",) + (("joint",) if named else ()) + ("moves link", "lower", "upper", "coupling"):
        table.add_column(col, overflow="fold")
    for joint in hand.joints:
        for dof, lo, hi in zip(joint.dof_names, joint.lower, joint.upper):
            c = coupled.get(dof)
            coupling = "-" if c is None else f"= {c.ratio:g} {c.source}" + (f" + {_deg(c.offset)}" if c.offset else "")
            table.add_row(dof, *((joint.name,) if named else ()), joint.child, _deg(lo), _deg(hi), coupling)
    return table


def _other_regions(hand) -> Table | None:
    tips = {f"{f.name}_tip" for f in hand.fingers}
    rest = [(n, r) for n, r in hand.regions.items() if n not in tips]
    if not rest:
        return None
    table = Table(title="Other contact regions", title_justify="left")
    for col in ("region", "link", "what"):
        table.add_column(col)
    for name, reg in rest:
        table.add_row(name, reg.link, reg.region.describe())
    return table


def _collision_table(hand) -> Table:
    """Per link: its capsules, and how they stand for its shapes (what they miss, how far
    they stick out; :attr:`~prehension.hands.model.Link.fit`)."""
    table = Table(title="Collision capsules (per link: what they miss of its shapes, how far they stick out)",
                  title_justify="left")  # fmt: skip
    for col in ("link", "capsules", "radii mm", "fitted to", "misses mm", "sticks out mm"):
        table.add_column(col, overflow="fold")
    for link in hand.links:
        radii = ", ".join(f"{c.radius:.3g}" for c in link.collision[:4]) + (" ..." if len(link.collision) > 4 else "")
        fit = link.fit
        rest = ("given as is", "-", "-") if fit is None else (fit.geometry, f"{fit.miss_mm:.2f}", f"{fit.stick_out_mm:.2f}")
        table.add_row(link.name, str(len(link.collision)), radii or "-", *rest)
    return table


def show_hand(hand, console: Console) -> int:
    """``prehension show HAND``: palm, fingers and fingertips, joints, notes (frames among them)."""
    where = f" from {hand.source.path}" if hand.source is not None else ""
    console.print(f"[bold]{escape(hand.name)}[/]{escape(where)}: palm {hand.palm!r}, {len(hand.links)} links, "
                  f"{hand.n_dof} joint angles, {len(hand.couplings)} couplings")  # fmt: skip
    console.print(_fingers_table(hand))
    console.print(_joints_table(hand))
    console.print(_collision_table(hand))
    others = _other_regions(hand)
    if others is not None:
        console.print(others)
    for note in hand.notes:
        style = "yellow" if note.startswith("warning: ") else "dim"
        console.print(f"[{style}]{escape(note)}[/]", soft_wrap=True)
    return EXIT_OK


# -- export -------------------------------------------------------------------------------------
def cmd_export_hand(args, console: Console) -> int:
    from ..atomic import write_text_atomic
    from ..hands.export import hand_to_mjcf, hand_to_urdf
    from ..tasks.format.tasks import resolve_hand

    from ..atomic import check_output_path
    from .outputs import task_inputs

    suffix = args.output.suffix.lower()
    if suffix not in _EXPORTS:
        raise PrehensionError(f"cannot tell the format of {args.output}: give a .urdf (URDF) or .xml/.mjcf (MJCF) file")
    check_output_path(args.output, "hand file", inputs=task_inputs(args.hand))
    if args.output.exists() and not args.force:
        raise PrehensionError(f"{args.output} already exists; pass --force to overwrite it")
    hand = resolve_hand(args.hand)
    print_hand_warnings(console, hand)
    text = hand_to_urdf(hand) if _EXPORTS[suffix] == "urdf" else hand_to_mjcf(hand)
    write_text_atomic(args.output, text)
    console.print(f"wrote {args.output} ({_EXPORTS[suffix].upper()}): hand {hand.name!r}, {len(hand.links)} links, "
                  f"{hand.n_dof} joint angles")  # fmt: skip
    return EXIT_OK
