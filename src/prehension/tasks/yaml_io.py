"""Task files: the YAML format of a grasp task, read into and written from the model classes.

A task file is one YAML mapping.  Lengths are millimetres; angles are **degrees** in the
file (every key that holds an angle ends in ``_deg``) and radians in the model classes.
Every mapping is checked with a strict schema (pydantic v2, ``extra="forbid"``): a
misspelt key is an error that lists the keys allowed there, and every error is an
:class:`~prehension.errors.InvalidTask` whose message starts with the file name and the
path of the offending field, e.g. ``bad.yaml: contacts.0.hand: field required``.

Schema (format ``task/1``)::

    prehension: task/1              # required format tag
    name: teapot-lid-lifting        # required, non-empty
    description: "..."              # optional free text
    hand: schunk-sa                 # a built-in hand name (BUILTIN_HANDS), or an inline hand
                                    # mapping (below), or {file: hand.yaml}: a YAML file that
                                    # holds an inline hand mapping (path relative to this file),
                                    # or {urdf: hand.urdf} / {mjcf: hand.xml} with optional root,
                                    # name, fingertips (tasks/format/hand_files.py, docs/hands.md)
    hand_limits_deg:                # optional: replace limits, {angle: [lower, upper]}
      index_mcp_abd: [-22.5, 22.5]
    hand_couplings: true            # optional (default true); false drops every coupling
    hand_regions:                   # optional: new or replacing contact regions on hand links
      index_tip: {link: index_distal, sphere_cap: {center: [20, 0, 0], radius: 13,
                                                   axis: [0.14, 0, 0.99], half_angle_deg: 60}}
    object:
      name: teapot
      regions:                      # at least one; each region gives exactly one of:
        knob: {bezier: [[[x, y, z], [x, y, z]], [[x, y, z], [x, y, z]]]}
                                    #   control_points[i][j], i along u, j along v; any
                                    #   (M+1) x (N+1) grid; outward normal = p_u x p_v
        rim: {point: [x, y, z], normal: [nx, ny, nz]}
        bump: {sphere_cap: {center: [x, y, z], radius: r, axis: [ax, ay, az], half_angle_deg: a}}
      mesh: teapot.obj              # optional solid: a mesh file (OBJ, STL, PLY, OFF, GLB),
      units: mm                     #   relative to this file, with units (mm, cm, m, in) or
                                    #   scale (mm per file unit); or instead of mesh:
      shape: [{box: {...}}, ...]    #   closed primitives (as in display) united into the solid
      collisions: true              # optional (default true): check the hand against the solid
      surface_tolerance_mm: 0.5     # optional: how far regions may lie from the solid's surface
                                    # (every region is checked on it, normals outward: docs/objects.md)
      display:                      # optional, only for looking at grasps
        primitives:                 # each item has exactly one key:
          - {box: {center: [0, 0, 0], size: [10, 20, 30]}}
          - {sphere: {center: [0, 0, 0], radius: 5}}
          - {ellipsoid: {center: [0, 0, 0], radii: [5, 6, 7], resolution: 24}}
          - {cylinder: {start: [0, 0, 0], end: [0, 0, 50], radius: 5, end_radius: 3, resolution: 32}}
          - {torus: {center: [0, 0, 0], axis: [0, 0, 1], major: 30, minor: 4, resolution: 32}}
        mesh_file: teapot.off       # optional OFF mesh, relative to this file's folder
    contacts:                       # at least one
      - {hand: index_tip, object: knob}   # optional name: (default "index_tip->knob")
      - {hand: any, object: rim}    # an OPEN contact: any hand region, or a list of
      - {hand: [thumb_tip, palm], object: bump}  # candidates (docs/assignment.md)
    fingers: [index, thumb]         # optional: the fingers that take part (omitted: the
                                    # fingers of the links the contacts use)
    idle_angles_deg: {ring_mcp_flex: 10}  # optional: angles of idle dofs

Inline hand mapping (also the content of a ``{file: ...}`` hand file)::

    name: my-hand
    links:                          # the first link is the palm
      - name: palm
        collision: [{a: [x, y, z], b: [x, y, z], radius: 10}, {center: [x, y, z], radius: 5}]
    joints:                         # from the palm outwards
      - name: index_mcp
        type: universal             # or revolute
        parent: palm
        child: index_proximal
        origin_in_parent: [x, y, z]
        origin_in_child: [0, 0, 0]  # optional, default zeros
        axis_in_parent: [1, 0, 0]
        axis_in_child: [0, -1, 0]   # universal joints only
        rotation_zero: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]  # rows; optional, default identity
        angles:                     # 1 (revolute) or 2 (universal)
          - {name: index_mcp_abd, lower_deg: -15, upper_deg: 15}
          - {name: index_mcp_flex, lower_deg: -4, upper_deg: 75}
    couplings: [{angle: index_dip, source: index_pip, ratio: 1.0, offset_deg: 0.0}]
    fingers: [{name: index, links: [index_proximal, index_middle, index_distal]}]
    regions: {index_tip: {link: index_distal, sphere_cap: {...}}}
    collision_exclusions: [[link_a, link_b]]
    frames: {tip_frame: {link: index_distal, origin: [x, y, z], rotation: [[...], [...], [...]]}}
    opposing_finger: thumb          # optional (default: the finger named thumb)
    source: {format: urdf, path: /abs/hand.urdf, sha256: ..., options: {}}  # optional, informational

Writing (:func:`task_to_dict`): a hand whose name is a built-in one and that differs from
that built-in only in limits, regions, or by having no couplings is written as the
name plus ``hand_limits_deg`` / ``hand_couplings: false`` / ``hand_regions`` for just the
differences; a hand read from a file is written the same way as its file reference (while
the file still gives that hand); any other hand is written inline, and result files
always hold the hand inline with its ``source``.  Angles are written in degrees rounded to
12 decimals, and unit vectors as the nearest value that the model's own normalisation
leaves unchanged, so that reading a written task and writing it again gives the same
dict.

A task with an open contact is an *open task*: :func:`load_task` refuses it (naming the
contact and pointing to the assignment search), :func:`load_open_task` reads any task file
as an :class:`~prehension.tasks.open_task.OpenTask` (whose contacts may all be fixed), and
:func:`dump_task` writes either.  ``any`` is reserved: a hand region named ``any`` cannot
be named by a contact.

Reading refuses duplicate keys in a mapping (plain ``yaml.safe_load`` silently keeps the
last one).  See ``docs/task-format.md`` for a complete example.

The format is implemented by kind in :mod:`prehension.tasks.format` (``regions``,
``hands``, ``hand_files``, ``task_hands``, ``objects``, ``tasks``: each reads and writes
its kind, on top of ``schema``, ``values``, ``yaml_text`` and ``errors``); this module is
the public entry point: it reads and writes YAML text and files, and re-exports the rest.
"""

from __future__ import annotations

from pathlib import Path

from ..atomic import write_text_atomic
from ..errors import PrehensionError
from .format.hands import hand_from_dict, hand_to_dict
from .format.regions import region_from_dict, region_to_dict
from .format.schema import BUILTIN_HANDS, FORMAT_TAG
from .format.tasks import is_open_task_dict, open_task_from_dict, task_from_dict, task_to_dict
from .format.yaml_text import dump_yaml, parse_yaml, read_text
from .model import Task
from .open_task import OpenTask

__all__ = [
    "FORMAT_TAG",
    "BUILTIN_HANDS",
    "task_from_dict",
    "task_to_dict",
    "open_task_from_dict",
    "is_open_task_dict",
    "load_task",
    "loads_task",
    "load_open_task",
    "loads_open_task",
    "is_open_task_file",
    "dump_task",
    "dumps_task",
    "hand_from_dict",
    "hand_to_dict",
    "region_from_dict",
    "region_to_dict",
]


def loads_task(text: str, source: str = "<string>", *, base_dir: Path | None = None) -> Task:
    """A :class:`Task` from the YAML text of a task file."""
    return task_from_dict(parse_yaml(text, source), base_dir=base_dir, source=source)


def load_task(path) -> Task:
    """Read a task file; relative paths inside it are taken from its folder."""
    path = Path(path)
    source = str(path)
    return loads_task(read_text(path, source), source, base_dir=path.parent)


def loads_open_task(text: str, source: str = "<string>", *, base_dir: Path | None = None) -> OpenTask:
    """An :class:`~prehension.tasks.open_task.OpenTask` from the YAML text of a task file (open or not)."""
    return open_task_from_dict(parse_yaml(text, source), base_dir=base_dir, source=source)


def load_open_task(path) -> OpenTask:
    """Read a task file, open or not, as an :class:`~prehension.tasks.open_task.OpenTask`."""
    path = Path(path)
    source = str(path)
    return loads_open_task(read_text(path, source), source, base_dir=path.parent)


def is_open_task_file(path) -> bool:
    """Whether the YAML task file ``path`` has an open contact (``hand: any`` or candidates).
    Only the YAML is read; a file that cannot be read is not open (its loader says why)."""
    path = Path(path)
    if path.suffix.lower() not in (".yaml", ".yml") or not path.is_file():
        return False
    try:
        return is_open_task_dict(parse_yaml(read_text(path, str(path)), str(path)))
    except PrehensionError:  # the loader that runs next names the problem
        return False


def dumps_task(task: Task | OpenTask, *, base_dir: Path | str | None = None) -> str:
    """The YAML text of a task file (keys in schema order, short lists in flow style)."""
    return dump_yaml(task_to_dict(task, base_dir=base_dir))


def dump_task(task: Task | OpenTask, path) -> None:
    """Write ``task`` to ``path`` atomically (a reader sees the old file or the new one)."""
    path = Path(path)
    text = dumps_task(task, base_dir=path.resolve().parent)
    write_text_atomic(path, text)
