"""The hand of a task, read and written: ``hand:`` plus ``hand_limits_deg``,
``hand_couplings`` and ``hand_regions``.

``hand:`` is a built-in hand name (or alias), an inline hand mapping (:mod:`.hands`), or a
file reference (:mod:`.hand_files`); the other three keys change that hand for this task.
Writing goes the other way: a hand that differs from a built-in one (or from the hand its
file gives today) only in limits, regions or by having no couplings is written as the name
(or reference) plus just those differences; any other hand is written inline.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

from ...hands.model import Hand
from .errors import fail, join_path, kind_of, located
from .hand_files import hand_from_file_entry, hand_from_reference, is_hand_reference, reference_entries
from .hands import hand_from_data, hand_regions, hand_to_dict
from .schema import BUILTIN_HANDS, HAND_ALIASES, TaskSpec

__all__ = ["task_hand", "hand_entries", "builtin_names"]

_BUILTIN_TOL = 1e-9  # a hand "is" the built-in one when its numbers agree to this [mm, unitless]


# -- reading ----------------------------------------------------------------------------
def builtin_names() -> str:
    """The built-in hand names, comma separated (for messages)."""
    return ", ".join(BUILTIN_HANDS) or "(none)"


_HAND_FORMS = "a built-in hand name ({}), an inline hand mapping, {{file: hand.yaml}}, {{urdf: hand.urdf}} or {{mjcf: hand.xml}}"


@functools.lru_cache(maxsize=None)
def _builtin_hand(name: str) -> Hand:
    """A built-in hand, built once per process (a hand is immutable: tasks share it, and so
    do the tables solvers build for it)."""
    return BUILTIN_HANDS[name]()


def _base_hand(value, base: Path, source: str) -> Hand:
    if isinstance(value, str):
        if HAND_ALIASES.get(value, value) not in BUILTIN_HANDS:
            raise fail(
                source, "hand", f"unknown built-in hand {value!r}; built-in hands are: {builtin_names()} "
                "(or give an inline hand mapping, {file: hand.yaml}, {urdf: hand.urdf} or {mjcf: hand.xml})",
            )  # fmt: skip
        return _builtin_hand(HAND_ALIASES.get(value, value))
    if isinstance(value, dict) and "file" in value:
        return hand_from_file_entry(value, base, source)
    if is_hand_reference(value):
        return hand_from_reference(value, base, source)
    if isinstance(value, dict):
        return hand_from_data(value, source, "hand")
    raise fail(source, "hand", f"give {_HAND_FORMS.format(builtin_names())}; got {kind_of(value)}")


def _with_limits(hand: Hand, limits: dict[str, list[float]], source: str) -> Hand:
    for name in limits:
        if name not in hand.dof_names:
            raise fail(
                source, join_path("hand_limits_deg", name),
                f"unknown joint angle {name!r}; angles of {hand.name!r} are: {', '.join(hand.dof_names)}",
            )  # fmt: skip
        if limits[name][0] > limits[name][1]:
            lo, hi = limits[name]
            raise fail(source, join_path("hand_limits_deg", name), f"lower limit {lo} exceeds upper limit {hi}")
    with located(source, "hand_limits_deg"):
        return hand.with_limits({k: (math.radians(lo), math.radians(hi)) for k, (lo, hi) in limits.items()})


def task_hand(spec: TaskSpec, base: Path, source: str) -> Hand:
    """The hand of a checked task mapping, with the task's limits, couplings and regions."""
    hand = _base_hand(spec.hand, base, source)
    if spec.hand_limits_deg:
        hand = _with_limits(hand, spec.hand_limits_deg, source)
    if not spec.hand_couplings:
        hand = hand.without_couplings()
    if spec.hand_regions:
        extra = hand_regions(spec.hand_regions, hand.link_names, source, "hand_regions", hand.missing_link_message)
        with located(source, "hand_regions"):
            hand = hand.with_regions(extra)
    return hand


# -- writing ----------------------------------------------------------------------------
def _close(a, b, tol: float = _BUILTIN_TOL) -> bool:
    """Structural equality of plain dicts/lists, floats compared to ``tol``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], tol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) <= tol
    return type(a) is type(b) and a == b


def _core(hand_dict: dict) -> dict:
    """A hand mapping without what a task may change: regions, couplings, limits."""
    core = {k: v for k, v in hand_dict.items() if k not in ("regions", "couplings")}
    core["joints"] = [
        {**j, "angles": [a["name"] for a in j["angles"]]} for j in hand_dict["joints"]
    ]
    return core


def _limits(hand_dict: dict) -> dict[str, list[float]]:
    return {a["name"]: [a["lower_deg"], a["upper_deg"]] for j in hand_dict["joints"] for a in j["angles"]}


def _builtin_entries(name, full: dict, builtin: dict) -> dict | None:
    """``hand: <name>`` (or a file reference) plus the differences from the built-in (or
    the file's) hand, or None if not expressible."""
    if not _close(_core(full), _core(builtin)):
        return None
    out: dict = {"hand": name}
    base_limits = _limits(builtin)
    limits = {d: lim for d, lim in _limits(full).items() if lim != base_limits[d]}
    if limits:
        out["hand_limits_deg"] = limits
    couplings, base_couplings = full.get("couplings", []), builtin.get("couplings", [])
    if not _close(couplings, base_couplings):
        if couplings:
            return None
        out["hand_couplings"] = False
    regions, base_regions = full.get("regions", {}), builtin.get("regions", {})
    if not set(base_regions) <= set(regions):
        return None  # a task can add or replace built-in regions, not remove them
    changed = {k: r for k, r in regions.items() if k not in base_regions or not _close(r, base_regions[k])}
    if changed:
        out["hand_regions"] = changed
    return out


@functools.lru_cache(maxsize=None)
def _builtin_hand_dict(name: str) -> dict:
    """:func:`hand_to_dict` of a built-in hand (computed once; do not modify)."""
    return hand_to_dict(BUILTIN_HANDS[name]())


def hand_entries(hand: Hand, base_dir=None, inline: bool = False) -> dict:
    """The ``hand:`` entries of a task: a built-in name or a file reference with the
    task's differences, else (or when ``inline``) the whole hand."""
    full = hand_to_dict(hand)
    if inline:
        return {"hand": full}
    if hand.source is not None:
        entries = reference_entries(hand, full, base_dir, _builtin_entries)
        if entries is not None:
            return entries
    elif hand.name in BUILTIN_HANDS:
        entries = _builtin_entries(hand.name, full, _builtin_hand_dict(hand.name))
        if entries is not None:
            return entries
    return {"hand": full}
