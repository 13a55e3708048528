"""Where a hand came from, and how its fingertips were found: values recorded on a Hand.

* :class:`HandSource`: the hand file a :class:`~prehension.hands.model.Hand` was read
  from (format, path, SHA-256 of its bytes) and the options of the reading (palm root,
  fingertip overrides), so that a task file can name the file instead of holding the
  whole hand, and a reader can tell whether the file has changed since.
* :class:`TipFit`: the report of one fingertip fit (which geometry, how many points, how
  well a sphere fits them), so that a user can judge a fingertip found automatically.
* :class:`ShapeFit`: how a link's collision capsules stand for its shapes (what they miss,
  how far they stick out), so that a reader knows which geometry judged a collision.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping

from ..frozen import FrozenMap

__all__ = ["HandSource", "TipFit", "ShapeFit", "file_sha256"]

HAND_FORMATS = ("urdf", "mjcf")


def file_sha256(path) -> str:
    """Hex SHA-256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@dataclass(frozen=True, eq=False)
class HandSource:
    """The hand file a hand was read from, and the options it was read with.

    Attributes:
        format: ``"urdf"`` or ``"mjcf"``.
        path: absolute path of the file.
        sha256: hex SHA-256 of the file's bytes when it was read.
        options: the reading options as written in a task file (``root``,
            ``fingertips``...): plain data, degrees for angles.
    """

    format: Literal["urdf", "mjcf"]
    path: str
    sha256: str
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "options", FrozenMap(dict(self.options)))

    def changed(self) -> bool:
        """True when the file is missing or its bytes differ from those read."""
        try:
            return file_sha256(self.path) != self.sha256
        except OSError:
            return True


@dataclass(frozen=True, eq=False)
class TipFit:
    """How the sphere cap of one fingertip was found.

    Attributes:
        finger: the finger.
        link: the link that carries the cap (the finger's distal link).
        geometry: what the sphere was fitted to (``"collision mesh"``, ``"visual mesh"``,
            ``"collision shapes"``...) or ``"override"`` when the user gave every value.
        n_points: surface points of the pad used in the fit.
        rms_mm: root-mean-square distance of those points from the sphere [mm].
        max_mm: largest distance of those points from the sphere [mm].
        flexion: how the pad side was chosen (e.g. ``"joint 'j3' flexes towards +"``).
        overridden: the values the user overrode (``radius``, ``half_angle_deg``...).
    """

    finger: str
    link: str
    geometry: str
    n_points: int
    rms_mm: float
    max_mm: float
    flexion: str = ""
    overridden: tuple[str, ...] = ()

    def describe(self) -> str:
        over = f"; overridden: {', '.join(self.overridden)}" if self.overridden else ""
        if self.n_points == 0:
            return f"{self.geometry}{over}"
        return (
            f"fitted to {self.n_points} points of the {self.geometry}: rms {self.rms_mm:.2f} mm, "
            f"max {self.max_mm:.2f} mm{over}"
        )


@dataclass(frozen=True)
class ShapeFit:
    """How a link's collision capsules stand for the link's own shapes (link frame, mm).

    Attributes:
        geometry: what the capsules were fitted to (``"collision mesh"``, ``"collision
            shapes"``, ``"published mesh"``...).
        miss_mm: largest distance of the link's surface outside every capsule (0: the
            capsules enclose the link).
        stick_out_mm: largest distance of the capsules' outer surface from the link.
    """

    geometry: str
    miss_mm: float
    stick_out_mm: float

    def describe(self) -> str:
        return f"{self.geometry}: misses {self.miss_mm:.2f} mm, sticks out {self.stick_out_mm:.2f} mm"
