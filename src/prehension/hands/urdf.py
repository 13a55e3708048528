"""Read a :class:`~prehension.hands.model.Hand` from a URDF file.

This module reads the XML into the neutral :class:`~prehension.hands.description.RawHand`;
:mod:`prehension.hands.assemble` makes the hand (fixed joints merged into named frames,
palm and fingers found, fingertips fitted: see there).

Conventions
-----------
* **Units.** URDF lengths are metres, the hand model's millimetres: every length (joint
  and shape origins, shape sizes, mesh vertices) is multiplied by ``length_unit`` (1000).
  Angles stay radians.
* **Origins.** ``<origin xyz="x y z" rpy="r p y"/>`` is the transform
  ``[R(rpy), xyz]`` with ``R(rpy) = Rz(y) Ry(p) Rx(r)`` (roll, pitch, yaw about fixed axes).
* **Revolute and continuous joints.** A URDF joint's origin places the child (joint) frame
  in the parent frame at zero angle and its ``<axis>`` (default ``1 0 0``) is stated in that
  child frame: ``T_parent_child(q) = T_origin Rot(axis, q)``; its dof is named after the
  joint; limits come from ``<limit lower upper>``, ``[-pi, pi]`` for a continuous joint.
* **Fixed joints** are merged (their child becomes a named frame); **other joint types**
  (prismatic, planar, floating) are held at zero with a warning, or cut off with the arm
  above the palm.
* **Couplings.** ``<mimic joint="J" multiplier="m" offset="o"/>`` on joint K gives
  ``q_K = m q_J + o`` (defaults 1, 0).
* **Shapes.** ``<collision>`` and ``<visual>`` geometries (sphere, cylinder along z, box,
  mesh) with their ``<origin>`` and mesh ``scale``.  Mesh files are read through trimesh
  (:func:`~prehension.hands.shapes.read_mesh_vertices`: OBJ, STL, PLY, OFF, GLB, GLTF; DAE
  with pycollada), a GLB/GLTF scene flattened with its node transforms applied, then
  scaled by ``scale`` and ``length_unit``.  Mesh paths are
  relative to the URDF's folder (``package://pkg/`` is stripped; ``pkg/...`` is also
  searched in the folders above); for URDF text given as a string, relative to the
  working directory.  A missing, unreadable or unsupported mesh is skipped with a warning
  that names the file (and, for a format not read, the formats that are).  Each mesh is
  also kept as a reference that draws its link in scenes
  (:class:`~prehension.hands.model.LinkMesh`: absolute path, origin, scale x length unit).
"""

from __future__ import annotations

import functools
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InvalidHand
from ..geometry.rotations import rotation_about
from ..objects.mesh_io import check_mesh_suffix
from .assemble import ImportOptions, assemble
from .description import RawCoupling, RawHand, RawJoint, RawShape
from .fingertips import TipOverride
from .model import Hand, LinkMesh
from .shapes import mesh_capsule, read_mesh_vertices

__all__ = ["hand_from_urdf", "load_urdf_hand", "read_urdf", "read_mesh_vertices", "mesh_capsule"]

_MOVABLE = ("revolute", "continuous")


# -- public API ---------------------------------------------------------------------------
def hand_from_urdf(
    path_or_text, *, name: str | None = None, root: str | None = None, length_unit: float = 1000.0,
    fingertips: dict[str, TipOverride] | None = None,
) -> Hand:  # fmt: skip
    """The hand described by a URDF file (a path) or URDF text (a string starting with ``<``).

    Args:
        path_or_text: path of a ``.urdf`` file, or the URDF XML itself.
        name: hand name (default: the ``<robot name>``, else the file stem).
        root: the link that becomes the palm (default: the link where the fingers branch,
            see :mod:`prehension.hands.assemble`); everything not below it is ignored.
        length_unit: millimetres per URDF length unit (1000: URDF is in metres).
        fingertips: per finger name, values that replace the fitted fingertip's.

    Raises:
        InvalidHand: malformed XML or URDF, bad mimic...; the message starts with the file name.

    The notes and warnings of the import are in ``hand.notes``.
    """
    robot, where, base_dir, stem = _read_robot(path_or_text)
    unit = float(length_unit)
    options = ImportOptions(name=name or robot.get("name") or stem, root=root, fingertips=dict(fingertips or {}))
    try:
        if not (math.isfinite(unit) and unit > 0):
            raise InvalidHand(f"length_unit must be a positive number (mm per URDF unit), got {unit}")
        return assemble(_raw_hand(robot, base_dir, where, unit), options)
    except InvalidHand as exc:
        raise InvalidHand(f"{where}: {exc}") from None


def load_urdf_hand(path_or_text, **kwargs) -> tuple[Hand, list[str]]:
    """As :func:`hand_from_urdf`, also returning the warnings among ``hand.notes``."""
    hand = hand_from_urdf(path_or_text, **kwargs)
    return hand, [n[len("warning: "):] for n in hand.notes if n.startswith("warning: ")]


def read_urdf(path_or_text, length_unit: float = 1000.0) -> RawHand:
    """The neutral description of a URDF (before merging, palm and fingers)."""
    robot, where, base_dir, _ = _read_robot(path_or_text)
    try:
        return _raw_hand(robot, base_dir, where, float(length_unit))
    except InvalidHand as exc:
        raise InvalidHand(f"{where}: {exc}") from None


# -- reading the XML ----------------------------------------------------------------------
def _read_robot(path_or_text) -> tuple[ET.Element, str, Path, str]:
    """(the <robot> element, a name for messages, the mesh base folder, a default name)."""
    is_text = isinstance(path_or_text, str) and path_or_text.lstrip().startswith("<")
    if is_text:
        where, base_dir, stem, data = "<URDF text>", Path.cwd(), "urdf_hand", path_or_text
    else:
        path = Path(os.fspath(path_or_text))
        where, base_dir, stem = str(path), path.parent, path.stem
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise InvalidHand(f"{where}: cannot read the URDF file ({exc.strerror or exc})") from None
    try:
        robot = ET.fromstring(data)
    except ET.ParseError as exc:
        raise InvalidHand(f"{where}: not a valid XML document ({exc})") from None
    if robot.tag != "robot":
        raise InvalidHand(f"{where}: not a URDF file: the root element is <{robot.tag}>, expected <robot>")
    return robot, where, base_dir, stem


def _floats(text: str | None, n: int, what: str, default: tuple[float, ...]) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    try:
        values = [float(x) for x in text.split()]
    except ValueError:
        values = []
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise InvalidHand(f"{what} must be {n} finite number(s), got {text!r}")
    return np.array(values)


def _attr_float(elem: ET.Element, key: str, what: str, default: float | None = None) -> float:
    text = elem.get(key)
    if text is None and default is not None:
        return default
    if text is None:
        raise InvalidHand(f"{what} has no {key!r} attribute")
    return float(_floats(text, 1, f"{what} {key}", ())[0])


def _rpy_matrix(rpy) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)``: the URDF rotation of ``rpy = (roll, pitch, yaw)``."""
    r, p, y = rpy
    return rotation_about(np.eye(3)[2], y) @ rotation_about(np.eye(3)[1], p) @ rotation_about(np.eye(3)[0], r)


def _origin(elem: ET.Element, unit: float, what: str) -> np.ndarray:
    """4x4 transform of ``elem``'s ``<origin>`` child (identity if absent), translation in mm."""
    o = elem.find("origin")
    T = np.eye(4)
    if o is not None:
        T[:3, :3] = _rpy_matrix(_floats(o.get("rpy"), 3, f"{what} origin rpy", (0, 0, 0)))
        T[:3, 3] = unit * _floats(o.get("xyz"), 3, f"{what} origin xyz", (0, 0, 0))
    return T


def _link_ref(elem: ET.Element, tag: str, what: str) -> str:
    ref = elem.find(tag)
    if ref is None or not ref.get("link"):
        raise InvalidHand(f"{what} has no <{tag} link=...>")
    return ref.get("link")


def _limits(elem: ET.Element, jtype: str, what: str) -> tuple[float, float]:
    if jtype == "continuous":
        return -math.pi, math.pi
    limit = elem.find("limit")
    if jtype != "revolute":
        return 0.0, 0.0
    if limit is None:
        raise InvalidHand(f"revolute {what} has no <limit lower=... upper=...> (URDF requires it)")
    return _attr_float(limit, "lower", f"{what} limit", 0.0), _attr_float(limit, "upper", f"{what} limit", 0.0)


def _mimic(elem: ET.Element, name: str, what: str) -> RawCoupling | None:
    mimic = elem.find("mimic")
    if mimic is None:
        return None
    if not mimic.get("joint"):
        raise InvalidHand(f"{what}: <mimic> has no joint attribute")
    m = _attr_float(mimic, "multiplier", f"{what} mimic", 1.0)
    return RawCoupling(name, mimic.get("joint"), m, _attr_float(mimic, "offset", f"{what} mimic", 0.0))


def _parse_joint(elem: ET.Element, unit: float) -> tuple[RawJoint, RawCoupling | None]:
    name = elem.get("name") or "(unnamed)"
    what = f"joint {name!r}"
    jtype = elem.get("type")
    if not jtype:
        raise InvalidHand(f"{what} has no type")
    axis_elem = elem.find("axis")
    axis = _floats(None if axis_elem is None else axis_elem.get("xyz"), 3, f"{what} axis", (1, 0, 0))
    if jtype in _MOVABLE and np.linalg.norm(axis) < 1e-12:
        raise InvalidHand(f"{what}: the axis is the zero vector")
    parent, child = _link_ref(elem, "parent", what), _link_ref(elem, "child", what)
    kind = "revolute" if jtype in _MOVABLE else jtype
    raw = RawJoint(name, kind, parent, child, _origin(elem, unit, what), np.eye(4), axis, _limits(elem, jtype, what))
    return raw, _mimic(elem, name, what)


# -- shapes -------------------------------------------------------------------------------
def _mesh_path(filename: str, base_dir: Path) -> Path | None:
    """The existing file a URDF mesh ``filename`` refers to, or ``None``."""
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    candidates = []
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://"):].partition("/")
        candidates.append(base_dir / rest)
        candidates += [folder / package / rest for folder in (base_dir, *base_dir.parents)]
    else:
        candidates.append(base_dir / filename)  # an absolute filename replaces base_dir
    return next((c for c in candidates if c.is_file()), None)


@functools.lru_cache(maxsize=256)
def _vertices_mm(path: str, scale: tuple[float, float, float], unit: float) -> np.ndarray:
    v = read_mesh_vertices(path) * np.asarray(scale) * unit
    v.setflags(write=False)
    return v


def _mesh_shape(geom: ET.Element, base_dir: Path, unit: float, what: str, role: str, T) -> RawShape:
    filename = geom.get("filename") or ""
    path = _mesh_path(filename, base_dir) if filename else None
    if path is None:
        raise ValueError(f"mesh file {filename!r} not found (searched from {base_dir})")
    scale = geom.get("scale", "1 1 1").split()
    scale = _floats(" ".join(scale * 3 if len(scale) == 1 else scale), 3, f"{what} mesh scale", ())
    check_mesh_suffix(path)  # an InvalidObject (a ValueError) naming the file and the formats read
    scale = tuple(float(s) for s in scale)
    loader = functools.partial(_vertices_mm, str(path), scale, unit)
    drawn = LinkMesh(str(path.resolve()), np.eye(4), tuple(unit * s for s in scale), role)
    return RawShape("mesh", role, T, (), loader, what, drawn)


def _shape(geom: ET.Element, base_dir: Path, unit: float, what: str, role: str, T) -> RawShape:
    """One ``<geometry>`` child as a RawShape [mm]; ValueError when it cannot be used."""
    if geom.tag == "sphere":
        return RawShape("sphere", role, T, (unit * _attr_float(geom, "radius", what),), None, what)
    if geom.tag == "cylinder":
        size = (unit * _attr_float(geom, "radius", what), unit * _attr_float(geom, "length", what))
        return RawShape("cylinder", role, T, size, None, what)
    if geom.tag == "box":
        size = unit * _floats(geom.get("size"), 3, f"{what} box size", ())
        if not np.all(size > 0):
            raise ValueError(f"box sizes must be positive, got {size.tolist()} mm")
        return RawShape("box", role, T, tuple(size), None, what)
    if geom.tag == "mesh":
        return _mesh_shape(geom, base_dir, unit, what, role, T)
    raise ValueError(f"unsupported geometry <{geom.tag}>")


def _link_shapes(elem: ET.Element, base_dir: Path, unit: float, warnings: list[str]) -> list[RawShape]:
    """The collision and visual shapes of one URDF link, in its frame [mm]."""
    out = []
    for role in ("collision", "visual"):
        for k, item in enumerate(elem.findall(role)):
            what = f"link {elem.get('name')!r} {role} {k}"
            geometry = item.find("geometry")
            shapes = list(geometry) if geometry is not None else []
            if not shapes:
                warnings.append(f"warning: {what}: no <geometry> shape; skipped")
                continue
            try:
                out.append(_shape(shapes[0], base_dir, unit, what, role, _origin(item, unit, what)))
            except ValueError as exc:  # InvalidHand is a ValueError: malformed numbers too
                warnings.append(f"warning: {what}: {exc}; skipped")
    return out


# -- the description -------------------------------------------------------------------------
def _raw_hand(robot: ET.Element, base_dir: Path, where: str, unit: float) -> RawHand:
    links: dict[str, ET.Element] = {}
    for elem in robot.findall("link"):
        lname = elem.get("name")
        if not lname:
            raise InvalidHand("a <link> has no name")
        if lname in links:
            raise InvalidHand(f"link {lname!r} is defined twice")
        links[lname] = elem
    if not links:
        raise InvalidHand("the robot has no <link>")
    joints, couplings = {}, []
    for elem in robot.findall("joint"):
        j, mimic = _parse_joint(elem, unit)
        if j.name in joints:
            raise InvalidHand(f"joint {j.name!r} is defined twice")
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise InvalidHand(f"joint {j.name!r}: its {role} link {link!r} is not defined (no such <link>)")
        joints[j.name] = j
        couplings += [mimic] if mimic is not None else []
    warnings: list[str] = []
    shapes = {name: _link_shapes(elem, base_dir, unit, warnings) for name, elem in links.items()}
    return RawHand(robot.get("name") or "", tuple(links), shapes, tuple(joints.values()), tuple(couplings),
                   tuple(warnings), where)  # fmt: skip
