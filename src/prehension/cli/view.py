"""``prehension view`` (a self-contained HTML viewer) and ``prehension render`` (a PNG)."""

from __future__ import annotations

import re
from pathlib import Path

from rich.console import Console

from ..errors import PrehensionError
from .codes import EXIT_BAD_INPUT, EXIT_OK

INPUT_HELP = "result file (.json) written by 'prehension solve', or a task: built-in name, .yaml or .world file"


def add_parsers(sub) -> None:
    """Add the ``view`` and ``render`` sub-commands to ``sub`` (argparse sub-parsers)."""
    view = sub.add_parser("view", help="write an interactive 3-D view of a grasp or a task (one offline HTML file)")
    _common(view, ".html")
    render = sub.add_parser("render", help="draw a grasp or a task as a picture (PNG; needs matplotlib)")
    _common(render, ".png")
    render.add_argument("--elev", type=float, default=None, metavar="DEG", help="view elevation [deg] (default 18)")
    render.add_argument("--azim", type=float, default=None, metavar="DEG", help="view azimuth [deg] (default 35)")
    render.add_argument("--size", default="900x700", metavar="WxH", help="picture size in pixels (default 900x700)")
    render.add_argument(
        "--layers", metavar="A,B", help="layers to draw (default: hand,object,hand_regions,object_regions,contacts; also frames)"
    )


def _common(p, suffix: str) -> None:
    p.add_argument("input", help=INPUT_HELP)
    p.add_argument("-o", "--output", type=Path, help=f"file to write (default: the input's name with {suffix})")
    p.add_argument("--solution", type=int, default=None, metavar="K",
                   help="result files: which solution to show, from 0 (default 0)")  # fmt: skip


def _load_scene(args):
    from ..viewer import build_scene, load_grasp

    loaded = load_grasp(args.input, args.solution)
    return build_scene(loaded.task, loaded.pose, status=loaded.status)


def _output(args, scene, suffix: str) -> Path:
    if args.output is not None:
        return args.output
    stem = Path(args.input).stem if Path(args.input).suffix else scene.task_name
    return Path(stem + suffix)


def cmd_view(args, console: Console) -> int:
    from ..viewer import write_html

    scene = _load_scene(args)
    path = write_html(scene, _output(args, scene, ".html"))
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB): {scene.title}")
    return EXIT_OK


def cmd_render(args, console: Console) -> int:
    from ..viewer.render import render_png, require_matplotlib

    try:
        require_matplotlib()  # before any work: say what to install
    except PrehensionError as exc:  # printed here: main() would read "[plot]" as rich markup
        Console(stderr=True, highlight=False).print(f"error: {exc}", markup=False, soft_wrap=True)
        return EXIT_BAD_INPUT
    size = _size(args.size)
    layers = tuple(k.strip() for k in args.layers.split(",") if k.strip()) if args.layers else None
    scene = _load_scene(args)
    path = render_png(scene, _output(args, scene, ".png"), elev_deg=args.elev, azim_deg=args.azim,
                      size_px=size, layers=layers)  # fmt: skip
    console.print(f"wrote {path} ({size[0]}x{size[1]} px): {scene.title}")
    return EXIT_OK


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match or not all(50 <= int(g) <= 8000 for g in match.groups()):
        raise PrehensionError(f"--size must be WIDTHxHEIGHT in pixels, each 50 to 8000 (e.g. 900x700), got {text!r}")
    return int(match.group(1)), int(match.group(2))
