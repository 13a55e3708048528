"""Hands named by file in a task file: ``hand: {file: PATH}`` (a hand YAML file),
``hand: {urdf: PATH}``, ``hand: {mjcf: PATH}``; read and written.

Reading (a hand YAML file holds one inline hand mapping, :mod:`.hands`)::

    hand:
      urdf: hands/allegro_hand_right.urdf   # or mjcf: hands/shadow_hand.xml; relative to the task file
      root: palm                            # optional: the palm link (default: where the fingers branch)
      name: allegro                         # optional: the hand's name (default: the file's model name)
      fingertips:                           # optional: per finger, values replacing the fitted cap's
        index: {radius: 13, half_angle_deg: 45}
        thumb: {link: link_15.0, center: [0, 0, 40], radius: 12, axis: [1, 0, 0], half_angle_deg: 60}

Writing (:func:`reference_entries`): a hand read from a file is written as the same
reference (path relative to the task file's folder) plus ``hand_limits_deg`` /
``hand_couplings: false`` / ``hand_regions`` for what the task changed, as for a
built-in hand; when the file no longer gives the same hand (edited, moved), the hand is
written inline instead.  Result files always hold the hand inline, with a ``source``
entry (the file's absolute path, SHA-256 and options), so that they can be re-checked
alone: see ``docs/hands.md``.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Annotated

from pydantic import Field, model_validator

from ...errors import InvalidHand, InvalidTask, not_a_file
from ...hands.files import load_hand_file
from ...hands.fingertips import TipOverride
from ...hands.model import Hand
from ...hands.provenance import HandSource, file_sha256
from .errors import check_mapping, fail, located, validate
from .hands import hand_from_data, hand_to_dict
from .schema import Name, PosNum, Vec3, _Spec
from .yaml_text import parse_yaml, read_text

__all__ = ["HandFileSpec", "TipSpec", "hand_file", "hand_from_file_entry", "is_hand_reference",
           "hand_from_reference", "reference_entries", "source_hand", "hand_meshes"]  # fmt: skip

FILE_KEYS = ("urdf", "mjcf")


class TipSpec(_Spec):
    link: Name | None = None
    center: Vec3 | None = None
    radius: PosNum | None = None
    axis: Vec3 | None = None
    half_angle_deg: Annotated[float, Field(strict=True, ge=0, le=180)] | None = None


class HandFileSpec(_Spec):
    urdf: Name | None = None
    mjcf: Name | None = None
    root: Name | None = None
    name: Name | None = None
    fingertips: dict[Name, TipSpec] = {}
    length_unit: PosNum | None = None

    @model_validator(mode="after")
    def _one_file(self):
        if (self.urdf is None) == (self.mjcf is None):
            raise ValueError("give exactly one of urdf, mjcf (the hand file, relative to the task file)")
        return self


def hand_file(path: Path, where: str) -> Hand:
    """The hand of a YAML hand file (one inline hand mapping), its source recorded."""
    text = read_text(path, where)
    data = parse_yaml(text, where)
    check_mapping(data, where, "a hand file holds one inline hand mapping (name, links, joints, ...)")
    hand = hand_from_data(data, where, "")
    if hand.source is not None:  # an inline hand that says where it came from
        return hand
    resolved = path.resolve()
    return replace(hand, source=HandSource("yaml", str(resolved), file_sha256(resolved)))


def hand_from_file_entry(value: dict, base: Path, source: str) -> Hand:
    """The hand of a ``hand: {file: hand.yaml}`` entry (path relative to ``base``)."""
    if set(value) != {"file"} or not isinstance(value["file"], str) or not value["file"]:
        raise fail(source, "hand", "a hand file reference is {file: path/to/hand.yaml} with no other key")
    path = base / value["file"]
    return hand_file(path, f"{source}: hand.file: {path}")


def is_hand_reference(value) -> bool:
    """Whether a ``hand:`` value names a URDF or MJCF file."""
    return isinstance(value, dict) and any(k in value for k in FILE_KEYS)


def _overrides(spec: HandFileSpec) -> dict[str, TipOverride]:
    out = {}
    for finger, t in spec.fingertips.items():
        out[finger] = TipOverride(
            t.link, None if t.center is None else tuple(t.center), t.radius,
            None if t.axis is None else tuple(t.axis), t.half_angle_deg,
        )  # fmt: skip
    return out


def hand_from_reference(value: dict, base: Path, source: str, loc: str = "hand") -> Hand:
    """The hand of a ``{urdf: ...}`` / ``{mjcf: ...}`` mapping (paths relative to ``base``)."""
    spec = validate(HandFileSpec, value, source, (loc,))
    fmt = "urdf" if spec.urdf is not None else "mjcf"
    path = base / (spec.urdf or spec.mjcf)
    if not path.is_file():
        raise fail(source, f"{loc}.{fmt}", not_a_file("hand file", path.resolve()))
    with located(source, loc):
        return load_hand_file(
            path, format=fmt, root=spec.root, name=spec.name, fingertips=_overrides(spec),
            length_unit=spec.length_unit or 1000.0,
        )  # fmt: skip


# -- writing -------------------------------------------------------------------------------
def _relative(path: str, base_dir) -> str:
    if base_dir is None:
        return Path(path).as_posix()
    try:
        return Path(os.path.relpath(path, Path(base_dir).resolve())).as_posix()
    except ValueError:  # another drive (Windows): keep it absolute
        return path


def reference_value(source: HandSource, base_dir) -> dict | str:
    """The ``hand:`` value that names ``source`` (``{file: ...}`` for a hand YAML file)."""
    key = "file" if source.format == "yaml" else source.format
    return {key: _relative(source.path, base_dir), **dict(source.options)}


def source_hand(source: HandSource) -> Hand | None:
    """The hand ``source`` gives today (None when the file is gone or no longer a hand)."""
    try:
        if source.format == "yaml":
            return hand_file(Path(source.path), f"hand file {source.path}")
        value = {source.format: source.path, **dict(source.options)}
        return hand_from_reference(value, Path("/"), f"hand file {source.path}")
    except (InvalidHand, InvalidTask):
        return None


def reference_entries(hand: Hand, full: dict, base_dir, compare) -> dict | None:
    """``hand: {urdf: ...}`` plus the task's differences from the file's hand, or None when
    the file no longer gives that hand.  ``compare(value, full, base_full)`` is the writer's
    difference function (the one built-in hands use)."""
    base = source_hand(hand.source)
    if base is None:
        return None
    return compare(reference_value(hand.source, base_dir), full, hand_to_dict(base))


def hand_meshes(hand: Hand) -> tuple[dict, str]:
    """``({link name: its LinkMesh files}, a note)``: the mesh files that draw ``hand``'s
    links (for pictures and scenes only): the hand's own link meshes, else those of the
    hand file it was read from (:attr:`Hand.source`, a result's inline hand) while that
    file is unchanged; the note says why there are none when the file is missing or changed."""
    own = {link.name: link.meshes for link in hand.links if link.meshes}
    if own or hand.source is None or hand.source.format not in ("urdf", "mjcf"):
        return own, ""
    if hand.source.changed():
        return {}, f"hand file {hand.source.path} is missing or changed since the result was written"
    base = source_hand(hand.source)
    if base is None:
        return {}, f"hand file {hand.source.path} no longer gives a hand"
    return {link.name: link.meshes for link in base.links if link.meshes and link.name in hand.link_names}, ""
