"""Task mappings, read and written; and a hand named on the command line.

A task mapping holds its hand (:mod:`.task_hands`), its object (:mod:`.objects`), contacts,
fingers and idle angles (schema in the docstring of :mod:`prehension.tasks.yaml_io`).
:func:`resolve_hand` turns what a user names on the command line (a built-in name, a
URDF / MJCF / hand YAML / task file) into a hand; it lives here because a task file is
one of the things it reads.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from ...errors import InvalidHand, not_a_file
from ...hands.files import HAND_SUFFIXES, load_hand_file
from ...hands.model import Hand
from ...objects.model import GraspObject
from ..model import Contact, Task
from ..open_task import OpenContact, OpenTask, fingers_of_regions
from .errors import check_mapping, fail, join_path, located, validate
from .hand_files import hand_file
from .objects import object_from_spec, object_to_dict
from .schema import ANY_HAND, BUILTIN_HANDS, FORMAT_TAG, HAND_ALIASES, TaskSpec
from .task_hands import hand_entries, task_hand
from .values import written_deg
from .yaml_text import parse_yaml, read_text

__all__ = ["task_from_dict", "open_task_from_dict", "is_open_task_dict", "task_to_dict", "resolve_hand", "HAND_ALIASES"]


# -- reading ----------------------------------------------------------------------------
def _check_names(spec: TaskSpec, hand: Hand, obj: GraspObject, source: str) -> None:
    """Name the field of an unknown finger, region or angle before Task checks the rest."""
    for i, f in enumerate(spec.fingers or ()):
        with located(source, join_path("fingers", i)):
            hand.finger(f)
    for i, c in enumerate(spec.contacts):
        names = [(join_path("contacts", i, "hand"), c.hand)] if isinstance(c.hand, str) else [
            (join_path("contacts", i, "hand", k), name) for k, name in enumerate(c.hand)]  # fmt: skip
        for loc, name in names:
            if name != ANY_HAND:
                with located(source, loc):
                    hand.region(name)
        with located(source, join_path("contacts", i, "object")):
            obj.region(c.object)
    for dof, value in spec.idle_angles_deg.items():
        with located(source, join_path("idle_angles_deg", dof)):
            k = hand.dof_index(dof)
        lo, hi = math.degrees(hand.lower[k]), math.degrees(hand.upper[k])
        if not lo - 1e-9 <= value <= hi + 1e-9:
            limits = f"[{lo:.6g}, {hi:.6g}] deg"
            raise fail(source, join_path("idle_angles_deg", dof), f"{value} deg is outside the limits {limits}")


def _check_tag(data: dict, source: str) -> None:
    if "prehension" not in data:
        raise fail(source, "prehension", f"missing format tag; a task file starts with 'prehension: {FORMAT_TAG}'")
    if data["prehension"] != FORMAT_TAG:
        raise fail(
            source, "prehension", f"unsupported format tag {data['prehension']!r}; the supported tag is {FORMAT_TAG!r}"
        )


def _read(data: dict, base_dir: Path | None, source: str) -> tuple[TaskSpec, Hand, GraspObject]:
    """The checked spec of a task mapping, its hand and its object (names checked)."""
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    check_mapping(data, source, f"a task file is a mapping that starts with 'prehension: {FORMAT_TAG}'")
    _check_tag(data, source)
    spec = validate(TaskSpec, data, source)
    hand = task_hand(spec, base, source)
    obj = object_from_spec(spec.object, base, source)
    _check_names(spec, hand, obj, source)
    return spec, hand, obj


def is_open_task_dict(data) -> bool:
    """Whether the mapping of a task file leaves the hand side of a contact open
    (``hand: any`` or a list of candidates): an *open task* (:func:`open_task_from_dict`)."""
    contacts = data.get("contacts") if isinstance(data, dict) else None
    return isinstance(contacts, list) and any(
        isinstance(c, dict) and (c.get("hand") == ANY_HAND or isinstance(c.get("hand"), list)) for c in contacts
    )


def task_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "<dict>") -> Task:
    """A :class:`Task` from the mapping of a task file.

    Args:
        data: the parsed task file (schema in the docstring of :mod:`prehension.tasks.yaml_io`).
        base_dir: folder that relative ``hand: {file: ...}`` and ``mesh_file`` paths are
            taken from (default: the current directory).
        source: name that starts every error message (normally the file path).

    Raises:
        InvalidTask: naming ``source``, the field path and what would be valid; an open
            task (a contact with ``hand: any`` or candidates) is refused with a pointer
            to :func:`open_task_from_dict` and the assignment search.
    """
    spec, hand, obj = _read(data, base_dir, source)
    for i, c in enumerate(spec.contacts):
        if c.is_open:
            raise fail(source, join_path("contacts", i, "hand"), (
                f"{'any' if c.hand == ANY_HAND else 'a list of candidates'} leaves the hand region open: this is an "
                "open task, whose assignment is searched; solve it with 'prehension solve FILE', or read it with "
                "prehension.tasks.yaml_io.load_open_task (docs/assignment.md)"))  # fmt: skip
    contacts = [Contact(c.hand, c.object, c.name) for c in spec.contacts]
    fingers = spec.fingers if spec.fingers is not None else fingers_of_regions(hand, [c.hand for c in spec.contacts])
    idle = {k: math.radians(v) for k, v in spec.idle_angles_deg.items()}
    with located(source, ""):
        return Task(spec.name, hand, obj, tuple(contacts), tuple(fingers), spec.description, idle)


def open_task_from_dict(data: dict, *, base_dir: Path | None = None, source: str = "<dict>") -> OpenTask:
    """An :class:`~prehension.tasks.open_task.OpenTask` from the mapping of a task file,
    open or not (a contact's ``hand:`` may be ``any`` or a list of candidate regions, and
    ``fingers`` may be omitted).  Arguments and errors as :func:`task_from_dict`."""
    spec, hand, obj = _read(data, base_dir, source)
    contacts = []
    for c in spec.contacts:
        if not c.is_open:
            contacts.append(Contact(c.hand, c.object, c.name))
        else:
            contacts.append(OpenContact(c.object, None if c.hand == ANY_HAND else tuple(c.hand), c.name))
    fingers = tuple(spec.fingers) if spec.fingers is not None else None
    idle = {k: math.radians(v) for k, v in spec.idle_angles_deg.items()}
    with located(source, ""):
        return OpenTask(spec.name, hand, obj, tuple(contacts), fingers, spec.description, idle)


# -- writing ----------------------------------------------------------------------------
def _contact_to_dict(c: Contact | OpenContact) -> dict:
    if isinstance(c, OpenContact):
        out = {"name": c.name} if c.name else {}
        return {**out, "hand": ANY_HAND if c.hand_candidates is None else list(c.hand_candidates), "object": c.object_region}
    out = {"name": c.name} if c.name != f"{c.hand_region}->{c.object_region}" else {}
    return {**out, "hand": c.hand_region, "object": c.object_region}


def task_to_dict(task: Task | OpenTask, *, base_dir: Path | str | None = None, hand_inline: bool = False) -> dict:
    """The task-file mapping of ``task`` (a :class:`Task`, or an open task: its open
    contacts written as ``hand: any`` or their candidates, ``fingers`` left out when it
    leaves them open): plain lists, floats, ints, bools and strings.

    ``base_dir``: write ``mesh_file`` and hand file references relative to this folder
    (default: as stored, absolute).  ``hand_inline``: write the whole hand even when it
    comes from a hand file (result files do, so that they can be re-checked alone).
    """
    out: dict = {"prehension": FORMAT_TAG, "name": task.name}
    if task.description:
        out["description"] = task.description
    out.update(hand_entries(task.hand, base_dir, hand_inline))
    out["object"] = object_to_dict(task.object, base_dir)
    out["contacts"] = [_contact_to_dict(c) for c in task.contacts]
    if task.fingers is not None:
        out["fingers"] = list(task.fingers)
    if task.idle_angles:
        out["idle_angles_deg"] = {dof: written_deg(v) for dof, v in task.idle_angles.items()}
    return out


# -- the command line ------------------------------------------------------------------------
def _yaml_hand(path: Path) -> Hand:
    source = str(path)
    data = parse_yaml(read_text(path, source), source)
    if isinstance(data, dict) and "prehension" in data:  # a task file (open or not): its hand
        return open_task_from_dict(data, base_dir=path.parent, source=source).hand
    return hand_file(path, source)


def resolve_hand(spec: str | os.PathLike) -> Hand:
    """A hand from a built-in name (or alias), a URDF (``.urdf``), an MJCF (``.xml``,
    ``.mjcf``), a hand YAML file or a task file (its hand).

    Raises:
        InvalidHand: naming what was given and what would be valid.
    """
    text = str(spec)
    name = HAND_ALIASES.get(text, text)
    if name in BUILTIN_HANDS:
        return BUILTIN_HANDS[name]()
    path = Path(text)
    suffix = path.suffix.lower()
    if suffix in HAND_SUFFIXES or suffix in (".yaml", ".yml"):
        if not path.is_file():
            raise InvalidHand(not_a_file("hand file", path))
        return load_hand_file(path) if suffix in HAND_SUFFIXES else _yaml_hand(path)
    aliases = ", ".join(f"{a} ({n})" for a, n in HAND_ALIASES.items())
    if path.is_dir():
        found = sorted(p.name for p in path.iterdir() if p.suffix.lower() in HAND_SUFFIXES)[:5]
        raise InvalidHand(f"{text} is a folder; give the hand file inside it" + (f" (it holds {', '.join(found)})" if found else ""))
    raise InvalidHand(
        f"{text!r} is neither a built-in hand ({', '.join(BUILTIN_HANDS)}; aliases: {aliases}) nor a hand file "
        "(.urdf, .xml/.mjcf for MJCF, .yaml for a hand or task file)"
    )
