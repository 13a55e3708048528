"""``prehension region``: fit a contact region to a mesh and print the task-file snippet."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from ..errors import PrehensionError
from . import args as types
from .codes import EXIT_OK


def add_parser(sub) -> None:
    """Add the ``region`` sub-command to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser(
        "region", help="fit a contact region (Bézier patch or point) to a mesh and print it for a task file"
    )
    p.add_argument("mesh", type=Path, help="mesh file (OBJ, STL, PLY, OFF, GLB)")
    p.add_argument("--at", required=True, metavar="X,Y,Z",
                   help="a point on (or near) the surface, mm in the object frame (after --scale); negative values "
                        "work as they are: --at -30,0,0.  A point farther from the surface than --radius is "
                        "refused with its distance, the nearest surface point and the mesh's bounding box (mm)")  # fmt: skip
    p.add_argument("--radius", type=types.positive, metavar="MM",
                   help="fit the surface within this distance of the point [mm] (> 0; not with --point)")  # fmt: skip
    p.add_argument("--degree", type=int, default=2, help="patch degree in u and v, 1..6 (default 2)")
    p.add_argument("--point", action="store_true", help="a point-with-normal region at the surface point instead of a patch")
    units = p.add_mutually_exclusive_group()
    units.add_argument("--scale", type=float, help="mm per mesh-file unit (e.g. 1000 for a file in metres)")
    units.add_argument("--units", choices=("mm", "cm", "m", "in"), help="the mesh file's units")
    p.add_argument("--name", default="region", help="the region's name in the snippet (default 'region')")


def _point(text: str):
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(abs(v) <= 1e9 for v in values):  # also refuses nan and inf
        raise PrehensionError(f"--at takes three numbers X,Y,Z [mm] (finite, at most 1e9 in size), e.g. --at 0,12.5,30; got {text!r}")
    return values


def _rounded(value, decimals: int = 4):
    """Numbers rounded to 0.1 micrometre (lengths) for a readable snippet."""
    if isinstance(value, dict):
        return {k: (v if k == "normal" else _rounded(v, decimals)) for k, v in value.items()}
    if isinstance(value, list):
        return [_rounded(v, decimals) for v in value]
    return round(value, decimals) + 0.0 if isinstance(value, float) else value


def cmd_region(args, console: Console) -> int:
    from ..objects.mesh_io import load_mesh, scale_of
    from ..objects.pick import region_from_mesh
    from ..tasks.format.regions import region_to_dict
    from ..tasks.format.yaml_text import dump_yaml

    at = _point(args.at)
    if args.radius is None and not args.point:
        raise PrehensionError("give --radius MM (the piece of surface to fit) or --point (a point with its normal)")
    scale = scale_of(args.scale, args.units)
    mesh = load_mesh(args.mesh, scale)
    picked = region_from_mesh(mesh, at=at, radius=args.radius or 1.0, degree=args.degree, point=args.point)
    p, n = (", ".join(f"{x:.4g}" for x in v) for v in (picked.point, picked.normal))
    units = f"units {args.units}" if args.units else f"scale {scale:g} mm per unit"
    lines = [f"# {args.mesh.name} ({units}): surface point ({p}) mm, outward normal ({n})"]
    if not args.point:
        lines.append(
            f"# degree-{args.degree} patch fitted to {picked.n_faces} faces within {args.radius:g} mm; "
            f"largest deviation from the mesh {picked.max_deviation_mm:.3g} mm; normal outward everywhere, at most "
            f"{picked.max_angle_deg:.0f} deg from the closest face's"
        )
        if picked.max_deviation_mm > 0.5 and args.radius > picked.turns_away_mm:
            lines.append(
                f"# (above the default 0.5 mm: the surface turns more than 84 degrees from the point's normal "
                f"{picked.turns_away_mm:.4g} mm away, which one patch cannot follow: pick a --radius under that)"
            )
        elif picked.max_deviation_mm > 0.5:
            lines.append(
                f"# (above the default 0.5 mm: set the object's surface_tolerance_mm >= {picked.max_deviation_mm:.2g}, "
                "or fit less curved surface: a smaller --radius or a higher --degree)"
            )
    text = "\n".join(lines) + "\n" + dump_yaml({args.name: _rounded(region_to_dict(picked.region))})
    console.print(text, markup=False, highlight=False, soft_wrap=True, end="")
    return EXIT_OK
