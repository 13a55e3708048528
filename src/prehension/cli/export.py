"""``prehension export``: a result's grasps in the field's formats, or its posed scene.

Grasp records (:mod:`prehension.interop`): ``dexgraspbench`` (one ``.npy`` dict per grasp:
``-o FILE.npy`` for one, ``-o FOLDER`` for ``0.npy, 1.npy, ...``, named by solution number), ``dexgraspnet`` (one
``.npy``, a list of dicts), ``json-m`` (JSON in metres), ``moveit`` (``moveit_msgs/Grasp``
messages as YAML or JSON, :mod:`prehension.interop.moveit`).  Scenes
(:mod:`prehension.interop.scene`): ``glb``, ``obj``, ``ply``, one solution posed, each link
drawn as its hand file's meshes where it has them (``--draw capsules``: as its capsules).
"""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import PrehensionError, not_a_file
from .codes import EXIT_OK

__all__ = ["add_parser", "cmd_export", "RECORD_FORMATS", "FORMATS"]

RECORD_FORMATS = ("dexgraspbench", "dexgraspnet", "json-m", "moveit")
FORMATS = RECORD_FORMATS + ("glb", "obj", "ply")
_SUFFIXES = {"dexgraspnet": (".npy",), "json-m": (".json",), "moveit": (".yaml", ".yml", ".json"), "glb": (".glb",), "obj": (".obj",), "ply": (".ply",)}


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write a result's grasps for other tools (DexGraspBench, DexGraspNet, JSON in metres, MoveIt) "
                                      "or its posed hand and object as a scene (GLB, OBJ, PLY)")  # fmt: skip
    p.add_argument("result", type=Path, help="result file (.json) of 'prehension solve'")
    p.add_argument("--format", required=True, choices=FORMATS, metavar="FORMAT", help=f"one of {', '.join(FORMATS)}")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="file to write (dexgraspbench: FILE.npy for one grasp, or a folder for 0.npy, 1.npy, ...)")  # fmt: skip
    p.add_argument("--solution", type=int, metavar="K", help="only the K-th solution (default: every one; a scene: 0)")
    p.add_argument("--units", choices=("m", "mm"), help="scene lengths (default m; grasp records are always in metres)")
    p.add_argument("--stage", choices=("grasp", "pregrasp", "squeeze"),
                   help="scene: the hand at its grasp (default), pre-grasp or squeeze angles")  # fmt: skip
    p.add_argument("--draw", choices=("meshes", "capsules"),
                   help="scene: each link as its hand file's meshes where it has them (default), or every link as "
                        "the capsules prehension checks")  # fmt: skip
    p.add_argument("--frame", choices=("object", "palm"),
                   help="moveit: grasp_pose is the palm's pose in the object frame (default, what MoveIt's pick "
                        "expects) or the object's pose in the palm frame")  # fmt: skip
    p.add_argument("--force", action="store_true", help="overwrite output files that exist")


def _outputs(args, n: int) -> list[Path]:
    """The files the export will write, checked before any is (never the input, never a
    file that exists unless ``--force``)."""
    from ..atomic import check_output_path

    from ..interop.dexgraspbench import grasp_files

    out = args.output
    if args.format == "dexgraspbench" and out.suffix.lower() != ".npy":
        if out.exists() and not out.is_dir():
            raise PrehensionError(f"{out} exists and is not a folder; dexgraspbench writes FILE.npy (one grasp) or a folder")
        paths = grasp_files(out, n, args.solution or 0)
        if not out.exists():
            return paths  # the folder is made when the grasps are written
    else:
        paths = [out]
    for path in paths:
        check_output_path(path, "output", inputs=[args.result], suffixes=_SUFFIXES.get(args.format, (".npy",)))
        if path.exists() and not args.force:
            raise PrehensionError(f"{path} already exists; pass --force to overwrite it")
    return paths


def cmd_export(args, console: Console) -> int:
    from ..results import read_result

    if not args.result.is_file():
        raise PrehensionError(not_a_file("result file", args.result))
    if args.format in RECORD_FORMATS:
        unused = [o for o, v in (("--units", args.units), ("--stage", args.stage), ("--draw", args.draw)) if v is not None]
        if unused:
            raise PrehensionError(f"{', '.join(unused)}: for scenes (glb, obj, ply) only; a {args.format} record is in "
                                  "metres and carries every stage the solution has")  # fmt: skip
        if args.frame is not None and args.format != "moveit":
            raise PrehensionError(f"--frame: for --format moveit only (a {args.format} record holds the palm's pose in the object frame)")
        return _export_records(args, *read_result(args.result), console)
    if args.frame is not None:
        raise PrehensionError("--frame: for --format moveit only (a scene is in the object frame)")
    return _export_scene(args, *read_result(args.result), console)


def _export_records(args, task, data, console: Console) -> int:
    from ..interop.dexgraspbench import write_dexgraspbench
    from ..interop.dexgraspnet import write_dexgraspnet
    from ..interop.json_m import write_json_m
    from ..interop.records import records_from_result

    records = records_from_result(task, data, args.solution, str(args.result))
    _outputs(args, len(records))
    if args.format == "dexgraspbench":  # a folder's files are named by solution number
        write_dexgraspbench(records, task.hand, args.output, args.solution or 0)
    elif args.format == "moveit":
        _write_moveit(args, task, data, records)
    else:
        {"dexgraspnet": write_dexgraspnet, "json-m": write_json_m}[args.format](records, task.hand, args.output)
    stages = [s for s in ("pregrasp", "squeeze") if all(getattr(r, s) is not None for r in records)]
    extra = f" with {' and '.join(stages)}" if stages else " (the result stores no pre-grasp or squeeze)"
    extra = " (the grasp only: the format has no pre-grasp or squeeze)" if args.format == "dexgraspnet" else extra
    console.print(f"wrote {args.output}: {len(records)} grasp(s) of hand {task.hand.name!r} as {args.format}{extra}")
    return EXIT_OK


def _write_moveit(args, task, data, records) -> None:
    from ..atomic import write_text_atomic
    from ..interop.moveit import moveit_grasps, moveit_text

    entries = data["solutions"] if args.solution is None else [data["solutions"][args.solution]]
    grasps = moveit_grasps(task, records, entries, args.solution or 0, args.frame or "object")
    write_text_atomic(args.output, moveit_text(grasps, args.output))


def _export_scene(args, task, data, console: Console) -> int:
    import numpy as np

    from ..atomic import write_bytes_atomic
    from ..interop.records import records_from_result
    from ..interop.scene import grasp_scene, hand_meshes, scene_bytes

    k = 0 if args.solution is None else args.solution
    stage, units = args.stage or "grasp", args.units or "m"
    record = records_from_result(task, data, k, str(args.result))[0]
    angles = {"grasp": record.joint_angles, "pregrasp": record.pregrasp, "squeeze": record.squeeze}[stage]
    if angles is None:
        raise PrehensionError(f"{args.result}: solution {k} stores no {stage}; export --stage grasp")
    _outputs(args, 1)
    q = np.array([angles[d] for d in task.hand.dof_names])
    meshes, why = hand_meshes(task.hand) if args.draw != "capsules" else ({}, "")
    scene = grasp_scene(task, q, record.T_palm_object, units, meshes)
    write_bytes_atomic(args.output, scene_bytes(scene, args.format))
    console.print(f"wrote {args.output}: solution {k} ({stage}), {len(task.hand.links)} links and the object, "
                  f"object frame, {units}; {_drawn_text(scene.metadata['drawn'], why)}")  # fmt: skip
    return EXIT_OK


def _drawn_text(drawn: dict, why: str) -> str:
    """How the links were drawn, for the user: meshes, capsules, and why not meshes."""
    meshed = [n for n, d in drawn.items() if d == "mesh"]
    if not meshed:
        return "links drawn as capsules" + (f" ({why})" if why else "")
    failed = [n for n, d in drawn.items() if d == "capsules"]
    text = f"{len(meshed)} link(s) drawn as their meshes"
    return text + (f", {len(failed)} as capsules (no readable mesh): {', '.join(failed)}" if failed else "")
