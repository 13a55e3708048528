"""Open tasks and their assignments: which hand region makes which contact.

An :class:`OpenTask` is a :class:`~prehension.tasks.model.Task` whose contacts may leave
their hand side open (:class:`OpenContact`: a list of candidate hand regions, or ``None``
for *any* region of the hand) and whose ``fingers`` may be omitted.  An
:class:`Assignment` closes it: one hand region per contact, in contact order;
:func:`concrete_task` turns the pair into an ordinary task.

:func:`enumerate_assignments` lists the assignments a search must decide:

* **injective**: two contacts never share a hand region;
* **symmetric duplicates pruned**: contacts that are interchangeable -- open contacts with
  the same object region and the same candidate hand regions -- differ only in their
  order, which changes nothing of the grasp (the residual function and both solvers
  treat contacts as a set).  Of the assignments that differ by permuting the hand
  regions of interchangeable contacts only one is kept: the one whose hand regions of
  each interchangeable group appear in the group's candidate order.  The hand's own
  (near-)mirror symmetries are *not* pruned: no real hand is exactly symmetric, so
  swapping, say, index and ring is a different problem.

These values sit with the task model (below the task-file format, which reads and writes
open tasks); :mod:`prehension.assignment` re-exports them with the search.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Mapping

from ..errors import InvalidTask, PrehensionError
from ..frozen import FrozenMap
from ..hands.model import Hand
from ..objects.model import GraspObject
from .model import Contact, Task

__all__ = ["OpenContact", "OpenTask", "Assignment", "enumerate_assignments", "concrete_task", "fingers_of_regions"]


@dataclass(frozen=True)
class OpenContact:
    """Some hand region, one of ``hand_candidates`` (``None``: any region of the hand that
    may take part), must touch object region ``object_region``."""

    object_region: str
    hand_candidates: tuple[str, ...] | None = None
    name: str = ""

    def __post_init__(self):
        if self.hand_candidates is not None:
            cands = tuple(self.hand_candidates)
            object.__setattr__(self, "hand_candidates", cands)
            if not cands:
                raise InvalidTask(f"open contact on {self.object_region!r}: give at least one candidate hand region, or 'any'")
            if len(set(cands)) != len(cands):
                raise InvalidTask(f"open contact on {self.object_region!r}: candidate hand regions repeat: {list(cands)}")

    @property
    def hand_text(self) -> str:
        """How the task file writes the hand side: ``any`` or the candidates."""
        return "any" if self.hand_candidates is None else ", ".join(self.hand_candidates)


@dataclass(frozen=True, eq=False)
class OpenTask:
    """A task whose hand side of some contacts is open (see the module docstring).

    Attributes:
        name, hand, object, description, idle_angles: as in :class:`~prehension.tasks.model.Task`.
        contacts: :class:`~prehension.tasks.model.Contact` (hand region fixed) or
            :class:`OpenContact` values, in order.
        fingers: the fingers that may take part; ``None``: every finger of the hand may,
            and a concrete task takes part with the fingers of the links its assignment
            uses (:func:`concrete_task`).
    """

    name: str
    hand: Hand
    object: GraspObject
    contacts: tuple[Contact | OpenContact, ...]
    fingers: tuple[str, ...] | None = None
    description: str = ""
    idle_angles: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "contacts", tuple(self.contacts))
        if self.fingers is not None:
            object.__setattr__(self, "fingers", tuple(self.fingers))
        object.__setattr__(self, "idle_angles", FrozenMap(dict(self.idle_angles)))
        try:
            self._validate()
        except InvalidTask:
            raise
        except PrehensionError as exc:
            raise InvalidTask(f"task {self.name!r}: {exc}") from None

    def _validate(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InvalidTask(f"a task needs a non-empty name, got {self.name!r}")
        if not self.contacts:
            raise InvalidTask(f"task {self.name!r} has no contacts; give at least one hand/object region pair")
        for f in self.fingers or ():
            self.hand.finger(f)
        for c in self.contacts:
            if not isinstance(c, (Contact, OpenContact)):
                raise InvalidTask(f"task {self.name!r}: a contact is a Contact or an OpenContact, got {type(c).__name__}")
            self.object.region(c.object_region)
        for i in range(len(self.contacts)):
            self.candidates(i)  # unknown names, regions of idle fingers, no region at all
        names = [c.name for c in self.contacts if c.name]
        if len(set(names)) != len(names):
            raise InvalidTask(f"task {self.name!r}: contact names must be unique, got {names}")
        _check_enough(self)

    @property
    def usable_regions(self) -> tuple[str, ...]:
        """The hand regions a contact may use: every region of the hand, or, when
        ``fingers`` is given, those on the palm or on a finger that takes part."""
        hand = self.hand
        if self.fingers is None:
            return tuple(hand.regions)
        return tuple(n for n, r in hand.regions.items() if hand.finger_of_link(r.link) in (None, *self.fingers))

    def candidates(self, i: int) -> tuple[str, ...]:
        """The hand regions contact ``i`` may use, in order (checked: known, usable)."""
        c = self.contacts[i]
        usable = self.usable_regions
        label = c.name or f"contact {i} (object region {c.object_region!r})"
        if isinstance(c, Contact):
            cands: tuple[str, ...] = (c.hand_region,)
        elif c.hand_candidates is None:
            if not self.hand.regions:
                raise InvalidTask(f"task {self.name!r}: {label} says 'hand: any', but hand {self.hand.name!r} has no "
                                  "contact regions; define some (hand_regions: in the task file, docs/task-format.md)")  # fmt: skip
            if not usable:
                raise InvalidTask(f"task {self.name!r}: {label} says 'hand: any', but no hand region lies on the palm "
                                  f"or on the fingers taking part ({', '.join(self.fingers or ())})")  # fmt: skip
            return usable
        else:
            cands = c.hand_candidates
        for name in cands:
            self.hand.region(name)  # unknown: names the valid ones
            if name not in usable:
                finger = self.hand.finger_of_link(self.hand.region(name).link)
                raise InvalidTask(f"task {self.name!r}: {label}: hand region {name!r} lies on finger {finger!r}, which "
                                  f"does not take part; fingers taking part: {list(self.fingers or ())}")  # fmt: skip
        return cands


def _check_enough(task: OpenTask) -> None:
    """Refuse a task whose contacts cannot all get distinct hand regions."""
    pool = set().union(*(task.candidates(i) for i in range(len(task.contacts))))
    if len(task.contacts) > len(pool):
        raise InvalidTask(
            f"task {task.name!r} has {len(task.contacts)} contacts but only {len(pool)} candidate hand region(s) "
            f"({', '.join(sorted(pool))}); every contact needs its own hand region: drop contacts or add regions"
        )


@dataclass(frozen=True)
class Assignment:
    """One hand region per contact of an open task, in contact order."""

    hand_regions: tuple[str, ...]
    object_regions: tuple[str, ...]

    def __post_init__(self):
        object.__setattr__(self, "hand_regions", tuple(self.hand_regions))
        object.__setattr__(self, "object_regions", tuple(self.object_regions))
        if len(self.hand_regions) != len(self.object_regions):
            raise PrehensionError("an assignment gives one hand region per contact")

    @property
    def label(self) -> str:
        """``"thumb_tip->A, index_tip->B"``: also the assignment's id in a ``.jsonl`` output."""
        return ", ".join(f"{h}->{o}" for h, o in zip(self.hand_regions, self.object_regions))

    def pairs(self) -> tuple[tuple[str, str], ...]:
        return tuple(zip(self.hand_regions, self.object_regions))


def _groups(task: OpenTask) -> list[list[int]]:
    """Interchangeable open contacts (same object region and candidates), in contact order."""
    groups: dict = {}
    for i, c in enumerate(task.contacts):
        key = ("open", c.object_region, task.candidates(i)) if isinstance(c, OpenContact) else ("fixed", i)
        groups.setdefault(key, []).append(i)
    return list(groups.values())


def enumerate_assignments(task: OpenTask) -> list[Assignment]:
    """Every injective assignment of ``task``, symmetric duplicates pruned (module
    docstring), in the lexicographic order of the candidates of each contact."""
    options = [task.candidates(i) for i in range(len(task.contacts))]
    rank = [{name: k for k, name in enumerate(cands)} for cands in options]
    groups = [g for g in _groups(task) if len(g) > 1]
    objects = tuple(c.object_region for c in task.contacts)
    out = []
    for choice in itertools.product(*options):
        if len(set(choice)) != len(choice):
            continue
        if any(any(rank[a][choice[a]] > rank[b][choice[b]] for a, b in zip(g, g[1:])) for g in groups):
            continue
        out.append(Assignment(choice, objects))
    return out


def concrete_task(task: OpenTask, assignment: Assignment) -> Task:
    """The :class:`~prehension.tasks.model.Task` of ``assignment``: contact ``i`` made by
    hand region ``assignment.hand_regions[i]``; ``fingers`` those of the open task, or
    (when it leaves them open) the fingers of the links the assignment uses, in the hand's
    order.  Raises :class:`InvalidTask` when the assignment does not fit the task."""
    if assignment.object_regions != tuple(c.object_region for c in task.contacts):
        raise InvalidTask(f"assignment {assignment.label!r} does not fit task {task.name!r}: its object regions differ")
    for i, h in enumerate(assignment.hand_regions):
        if h not in task.candidates(i):
            raise InvalidTask(f"assignment {assignment.label!r}: hand region {h!r} is not a candidate of contact {i}")
    if len(set(assignment.hand_regions)) != len(assignment.hand_regions):
        raise InvalidTask(f"assignment {assignment.label!r} uses a hand region twice")
    contacts = tuple(Contact(h, c.object_region, c.name) for h, c in zip(assignment.hand_regions, task.contacts))
    fingers = task.fingers if task.fingers is not None else fingers_of_regions(task.hand, assignment.hand_regions)
    return Task(task.name, task.hand, task.object, contacts, fingers, task.description, dict(task.idle_angles))


def fingers_of_regions(hand: Hand, regions) -> tuple[str, ...]:
    """The fingers whose links hold the hand regions ``regions``, in the hand's order
    (what a task takes part with when it leaves ``fingers`` open)."""
    used = {hand.finger_of_link(hand.region(r).link) for r in regions}
    return tuple(f.name for f in hand.fingers if f.name in used)
