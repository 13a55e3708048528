"""``prehension view`` (a self-contained HTML viewer) and ``prehension render`` (a PNG)."""

from __future__ import annotations

import re
from pathlib import Path

from rich.console import Console

from ..errors import PrehensionError
from ..atomic import check_output_path
from .args import finite
from .codes import EXIT_OK
from .outputs import task_inputs

INPUT_HELP = ("result file (.json) written by 'prehension solve', a task (built-in name, .yaml or .world file), "
              "or a hand alone (built-in hand, .urdf, .xml/.mjcf)")


def add_parsers(sub) -> None:
    """Add the ``view`` and ``render`` sub-commands to ``sub`` (argparse sub-parsers)."""
    view = sub.add_parser("view", help="write an interactive 3-D view of a grasp or a task (one offline HTML file)")
    _common(view, ".html")
    render = sub.add_parser("render", help="draw a grasp or a task as a picture (PNG, JPEG, PDF or SVG by the file name; needs matplotlib)")
    _common(render, ".png")
    render.add_argument("--elev", type=finite, default=None, metavar="DEG", help="view elevation [deg] (default 18)")
    render.add_argument("--azim", type=finite, default=None, metavar="DEG", help="view azimuth [deg] (default 35)")
    render.add_argument("--size", default="900x700", metavar="WxH", help="picture size in pixels (default 900x700)")
    render.add_argument(
        "--layers", metavar="A,B", help="layers to draw (default: hand,object,hand_regions,pads,object_regions,contacts; also frames, "
        "capsules (a hand drawn as its meshes), and hand_pregrasp, hand_squeeze of a result's stages)"
    )


def _common(p, suffix: str) -> None:
    p.add_argument("input", help=INPUT_HELP)
    p.add_argument("-o", "--output", type=Path, help=f"file to write (default: the input's name with {suffix})")
    p.add_argument("--solution", type=int, default=None, metavar="K",
                   help="result files: which solution to show, from 0 (default 0)")  # fmt: skip
    p.add_argument("--stage", choices=("pregrasp", "grasp", "squeeze"), default=None,
                   help="result files: which stage of the grasp to show -- the pre-grasp (fingers backed off), the "
                        "grasp, or the squeeze targets of the physics test (default: grasp; the page can switch)")  # fmt: skip
    p.add_argument("--draw", choices=("meshes", "capsules"), default="meshes",
                   help="how the hand's links are drawn: 'meshes' (default) -- the hand file's mesh files where it has "
                        "them (a URDF or MJCF hand), with the collision capsules the checks judge in a layer of their own; "
                        "'capsules' -- every link as its capsules")  # fmt: skip


def _load_scene(args):
    """The scene of a result or a task, or of a hand alone (a built-in hand or a hand file)."""
    from ..viewer import build_hand_scene, build_scene, load_grasp
    from .hands import hand_named

    from ..viewer.stages import with_stage

    hand = hand_named(args.input) if args.solution is None else None
    if hand is not None:
        scene = build_hand_scene(hand, draw=args.draw)
    else:
        loaded = load_grasp(args.input, args.solution)
        scene = build_scene(loaded.task, loaded.pose, status=loaded.status, draw=args.draw)
    return scene if args.stage is None else with_stage(scene, args.stage)


def _output(args, suffixes: tuple[str, ...]) -> Path:
    """The output file, checked before any work (not a folder, not the input, writable)."""
    if args.output is not None:
        path = args.output
    else:
        stem = Path(args.input).stem if Path(args.input).suffix else str(args.input)
        path = Path((stem.lstrip(".") or "grasp") + suffixes[0])
    return check_output_path(path, "output", inputs=task_inputs(args.input), suffixes=suffixes)


def cmd_view(args, console: Console) -> int:
    from ..viewer import write_html

    out = _output(args, (".html", ".htm"))
    scene = _load_scene(args)
    path = write_html(scene, out)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB): {scene.title}")
    return EXIT_OK


def cmd_render(args, console: Console) -> int:
    from ..viewer.render import IMAGE_FORMATS, render_image, require_matplotlib

    require_matplotlib()  # before any work: say what to install (main() prints the message as text)
    size = _size(args.size)
    layers = tuple(k.strip() for k in args.layers.split(",") if k.strip()) if args.layers else None
    out = _output(args, tuple(IMAGE_FORMATS))
    scene = _load_scene(args)
    path = render_image(scene, out, elev_deg=args.elev, azim_deg=args.azim, size_px=size, layers=layers)
    console.print(f"wrote {path} ({size[0]}x{size[1]} px): {scene.title}")
    return EXIT_OK


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match or not all(50 <= int(g) <= 8000 for g in match.groups()):
        raise PrehensionError(f"--size must be WIDTHxHEIGHT in pixels, each 50 to 8000 (e.g. 900x700), got {text!r}")
    return int(match.group(1)), int(match.group(2))
