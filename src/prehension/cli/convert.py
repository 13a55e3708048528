"""``prehension import-cuik``: CuikSuite world files to task files."""

from __future__ import annotations

from rich.console import Console

from ..atomic import check_output_path
from ..errors import PrehensionError
from .codes import EXIT_OK


def cmd_import(args, console: Console) -> int:
    from ..tasks.cuik_import import import_world
    from ..tasks.yaml_io import dump_task

    check_output_path(args.output, "task file", inputs=[args.world], suffixes=(".yaml", ".yml"))
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
