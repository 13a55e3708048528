"""Hands read from URDF and MJCF files, with their source recorded and reused.

:func:`load_hand_file` reads a hand file (format from the suffix, or given) and records on
the hand where it came from (:class:`~prehension.hands.provenance.HandSource`: the
absolute path, the SHA-256 of the file's bytes and the options), so that a task file can
name the file instead of holding the hand.  A file read again with the same bytes and
options gives the same (immutable) hand from a cache.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Mapping

from ..errors import InvalidHand
from .fingertips import TipOverride
from .model import Hand
from .provenance import HAND_FORMATS, HandSource, file_sha256

__all__ = ["load_hand_file", "hand_format", "HAND_SUFFIXES", "tip_override_options"]

HAND_SUFFIXES = {".urdf": "urdf", ".xml": "mjcf", ".mjcf": "mjcf"}
_CACHE: dict = {}
_CACHE_SIZE = 32


def hand_format(path, format: str | None = None) -> str:
    """``"urdf"`` or ``"mjcf"``: ``format`` if given, else from the file's suffix."""
    if format is not None:
        if format not in HAND_FORMATS:
            raise InvalidHand(f"unknown hand file format {format!r}; formats are: {', '.join(HAND_FORMATS)}")
        return format
    suffix = Path(path).suffix.lower()
    if suffix not in HAND_SUFFIXES:
        known = ", ".join(f"{s} ({f})" for s, f in HAND_SUFFIXES.items())
        raise InvalidHand(f"{path}: cannot tell the hand file format from the suffix {suffix!r}; known: {known}")
    return HAND_SUFFIXES[suffix]


def tip_override_options(fingertips: Mapping[str, TipOverride]) -> dict:
    """Fingertip overrides as plain data, in the task file's words (degrees)."""
    out = {}
    for finger, o in fingertips.items():
        entry = {k: getattr(o, k) for k in o.given}
        for k in ("center", "axis"):
            if k in entry:
                entry[k] = [float(x) for x in entry[k]]
        out[finger] = entry
    return out


def _options(root, name, fingertips) -> dict:
    out: dict = {}
    if root is not None:
        out["root"] = root
    if name is not None:
        out["name"] = name
    if fingertips:
        out["fingertips"] = tip_override_options(fingertips)
    return out


def _read(path: Path, fmt: str, **kwargs) -> Hand:
    if fmt == "urdf":
        from .urdf import hand_from_urdf

        return hand_from_urdf(path, **kwargs)
    from .mjcf import hand_from_mjcf

    return hand_from_mjcf(path, **kwargs)


def _key(path: Path, sha: str, fmt: str, root, name, fingertips, length_unit) -> tuple:
    tips = tuple(sorted((f, repr(o)) for f, o in fingertips.items()))
    return (str(path), sha, fmt, root, name, tips, length_unit)


def load_hand_file(
    path, *, format: str | None = None, root: str | None = None, name: str | None = None,
    fingertips: Mapping[str, TipOverride] | None = None, length_unit: float = 1000.0,
) -> Hand:  # fmt: skip
    """The hand of a URDF or MJCF file, with :attr:`Hand.source` set.

    Args:
        path: the hand file.
        format: ``"urdf"`` or ``"mjcf"`` (default: from the suffix: ``.urdf``; ``.xml``, ``.mjcf``).
        root: the link that becomes the palm (default: where the fingers branch).
        name: hand name (default: the file's model name).
        fingertips: per finger, values that replace the fitted fingertip's.
        length_unit: millimetres per file length unit (1000: metres).

    Raises:
        InvalidHand: the file cannot be read or is not a hand (the message names it).
    """
    path = Path(path).resolve()
    fmt = hand_format(path, format)
    if not (isinstance(length_unit, (int, float)) and math.isfinite(length_unit) and length_unit > 0):
        raise InvalidHand(f"length_unit must be a positive number of mm per file unit, got {length_unit!r}")
    try:
        sha = file_sha256(path)
    except OSError as exc:
        raise InvalidHand(f"{path}: cannot read the hand file ({exc.strerror or exc})") from None
    fingertips = dict(fingertips or {})
    key = _key(path, sha, fmt, root, name, fingertips, float(length_unit))
    if key not in _CACHE:
        hand = _read(path, fmt, name=name, root=root, fingertips=fingertips, length_unit=length_unit)
        source = HandSource(fmt, str(path), sha, _options(root, name, fingertips))
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = replace(hand, source=source)
    return _CACHE[key]
