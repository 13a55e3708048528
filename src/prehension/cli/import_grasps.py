"""``prehension import-grasps``: other tools' grasp files as result records that
``prehension check`` re-verifies (:mod:`prehension.interop.imported`)."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import PrehensionError
from .codes import EXIT_OK

__all__ = ["add_parser", "cmd_import_grasps"]

_TASK_SUFFIXES = (".yaml", ".yml", ".world")
_GRASP_SUFFIXES = (".npy", ".json")  # what a folder given for FILE is searched for


IMPORT_FORMATS = ("auto", "dexgraspbench", "dexgraspnet", "json-m")  # prehension.interop.readers (not imported at start-up)


def add_parser(sub) -> None:
    p = sub.add_parser("import-grasps", help="judge grasps made by other tools (DexGraspBench, DexGraspNet, json-m): "
                                             "write result records that 'prehension check' re-verifies")  # fmt: skip
    p.add_argument("files", nargs="+", type=Path, metavar="FILE|FOLDER",
                   help="grasp files (.npy, .json), or folders: every .npy and .json file in each, in natural order")  # fmt: skip
    p.add_argument("--hand", help="the hand the grasps are for (built-in name or hand file); default: the task's")
    p.add_argument("--object", required=True, metavar="MESH|TASK",
                   help="a task (built-in name or task file: its contacts judge the grasps) or a mesh file (contacts "
                        "measured where the hand touches it)")  # fmt: skip
    p.add_argument("--mesh-scale", type=float, metavar="MM_PER_UNIT",
                   help="mm per unit of the mesh file (default: the record's object scale, e.g. obj_scale x 1000)")
    p.add_argument("--format", choices=IMPORT_FORMATS, default="auto", help="the files' format (default: from each file)")
    p.add_argument("-o", "--output", type=Path, required=True, help="records to write (.jsonl)")
    p.add_argument("--force", action="store_true", help="overwrite the output file if it exists")


def _is_task(spec: str) -> bool:
    from ..tasks.library import builtin_task_names

    return spec in builtin_task_names() or Path(spec).suffix.lower() in _TASK_SUFFIXES


def cmd_import_grasps(args, console: Console) -> int:
    import json

    from ..atomic import check_output_path, write_text_atomic

    files = grasp_files(args.files)
    check_output_path(args.output, "output", inputs=[*files, args.object], suffixes=(".jsonl",))
    if args.output.exists() and not args.force:
        raise PrehensionError(f"{args.output} already exists; pass --force to overwrite it")
    task, hand = _task_and_hand(args)
    lines, counts = [], {}
    for path in files:
        for line in _judged(args, path, task, hand):
            lines.append(json.dumps(line))
            counts[line["status"]] = counts.get(line["status"], 0) + 1
    write_text_atomic(args.output, "\n".join(lines) + "\n")
    summary = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    console.print(f"wrote {args.output}: {len(lines)} grasp(s) judged ({summary}); re-verify with: prehension check {args.output}")
    return EXIT_OK


def grasp_files(paths) -> list[Path]:
    """The files to read: each file as given, each folder's ``.npy`` and ``.json`` files (not
    its subfolders), in natural order (``2.npy`` before ``10.npy``, as DexGraspBench
    numbers them).  A folder without such files is an error naming it."""
    import re

    def natural(p: Path):
        return [(0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", p.name) if t]

    out = []
    for path in paths:
        if not path.is_dir():
            out.append(path)
            continue
        found = sorted((p for p in path.iterdir() if p.is_file() and p.suffix.lower() in _GRASP_SUFFIXES), key=natural)
        if not found:
            raise PrehensionError(f"folder {path} holds no grasp file ({', '.join(_GRASP_SUFFIXES)}); give the files or a folder that holds them")
        out += found
    return out


def _task_and_hand(args):
    from .hands import hand_named

    if _is_task(args.object):
        from ..tasks.library import resolve_task

        task = resolve_task(args.object)
        if args.hand is not None and hand_named(args.hand).name != task.hand.name:
            raise PrehensionError(f"--hand {args.hand!r} is not the hand of task {task.name!r} ({task.hand.name!r}); "
                                  "leave --hand out to use the task's")  # fmt: skip
        return task, task.hand
    if args.hand is None:
        raise PrehensionError("--hand is needed with a mesh for --object (which hand are the grasps for?)")
    if not Path(args.object).is_file():
        raise PrehensionError(f"--object {args.object!r} is neither a task (built-in name, .yaml, .world) nor a mesh file")
    return None, hand_named(args.hand)


def _judged(args, path: Path, task, hand):
    from ..interop.imported import imported_record, measured_task
    from ..interop.readers import read_records

    fmt, records = read_records(path, hand, args.format)
    for k, record in enumerate(records):
        index = f"{path.name}#{k}" if len(records) > 1 else path.name
        if task is not None:
            yield imported_record(task, record, index, format_name=fmt)
            continue
        import numpy as np

        scale = args.mesh_scale if args.mesh_scale is not None else record.object_scale_mm
        q = np.array([record.joint_angles[d] for d in hand.dof_names])
        judged_task, measured = measured_task(hand, str(Path(args.object).resolve()), scale, q, record.T_palm_object,
                                              Path(args.object).stem)  # fmt: skip
        yield imported_record(judged_task, record, index, measured=measured, format_name=fmt)
