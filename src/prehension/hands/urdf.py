"""Read a :class:`~prehension.hands.model.Hand` from a URDF file.

Conventions
-----------
* **Units.** URDF lengths are metres, the hand model's millimetres: every length (joint
  and collision origins, shape sizes, mesh vertices) is multiplied by ``length_unit``
  (1000).  Angles stay radians.
* **Origins.** ``<origin xyz="x y z" rpy="r p y"/>`` is the transform
  ``[R(rpy), xyz]`` with ``R(rpy) = Rz(y) Ry(p) Rx(r)`` (roll, pitch, yaw about fixed axes).
* **Root.** The root link is ``root=`` if given, else the unique link that is no joint's
  child.  It becomes the palm (the first link, the frame of every pose).  With ``root=``
  everything not below the root is ignored (cut a hand mounted on an arm at its wrist).
* **Revolute and continuous joints.** A URDF joint's origin places the child (joint) frame
  in the parent frame at zero angle and its ``<axis>`` (default ``1 0 0``) is stated in that
  child frame: ``T_parent_child(q) = T_origin Rot(axis, q)``.  It becomes a revolute
  :class:`Joint` with ``P = xyz``, ``Q = 0``, ``R0 = R(rpy)`` and ``u = R0 axis`` (since
  ``Rot(R0 a, q) R0 = R0 Rot(a, q)``); its dof is named after the joint; limits come from
  ``<limit lower upper>``, ``[-pi, pi]`` for a continuous joint.  Joints are listed
  parent before child (breadth-first from the palm).
* **Fixed joints** are merged: the child's collision shapes and outgoing joints are
  re-expressed in the frame of the nearest non-merged ancestor, whose name is kept.  Every
  surviving link keeps its URDF frame, so link poses agree with any URDF tool.
* **Other joint types** (prismatic, planar, floating) below the root raise
  :class:`InvalidHand`.
* **Couplings.** ``<mimic joint="J" multiplier="m" offset="o"/>`` on joint K gives
  ``Coupling(K, J, m, o)`` (``q_K = m q_J + o``; defaults 1, 0).  A mimic of a mimic is
  resolved to the independent joint: ``q_K = m m' q_J' + (m o' + o)``.
* **Collision shapes -> capsules** (link frame, mm; the ``<collision><origin>`` and the
  mesh ``scale`` applied).  Primitive shapes give capsules *inside* the shape, so that
  self-collision checks do not report contacts the real shapes do not make:

  - sphere: the sphere itself (a capsule with ``a == b``);
  - cylinder (along its local z): the largest capsule about the axis that fits inside,
    radius ``min(r, L/2)``, segment half-length ``L/2 - radius`` (a flat disc becomes the
    inscribed sphere);
  - box with sides ``long >= mid >= short``: ``n = ceil(mid/short)`` (at most 8) parallel
    capsules of radius ``short/2`` along the long side (half-length ``long/2 - short/2``),
    spread evenly across the mid side; their union lies inside the box and fills it but
    for its rounded edges (and gaps in plates thinner than ``mid/8``);
  - mesh (``.obj`` ``v`` lines, or ascii/binary ``.stl``): one capsule along the principal
    axis (PCA) of the vertices, radius the 90th percentile of the vertices' distances to
    that axis, segment shortened by the radius at each end of the vertices' extent.  An
    approximation meant for self-collision checks only.  Mesh paths are relative to the
    URDF's folder (``package://pkg/`` is stripped; ``pkg/...`` is also searched in the
    folders above); for URDF text given as a string, relative to the working directory.
    A missing or unreadable mesh is skipped with a warning (see :func:`load_urdf_hand`).
* **Fingers.** Each child of the palm starts a finger that follows the serial chain
  outwards; a link with several children ends its finger (it is included), and each of
  its children starts a new finger.  A finger is named after the common stem of its link
  names when that says more than the stem shared by all links (``index_proximal``,
  ``index_distal`` -> ``index``), else after its URDF tip link (the leaf link merged into
  its last link by a fixed joint, e.g. ``fftip``), else after its last link.
* **Regions**: none; contact regions are added in the task file.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from collections import defaultdict, deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InvalidHand
from ..geometry.rotations import rotation_about
from .model import Capsule, Coupling, Finger, Hand, Joint, Link

__all__ = ["hand_from_urdf", "load_urdf_hand", "read_mesh_vertices", "mesh_capsule"]

_SUPPORTED = "prehension supports revolute, continuous and fixed joints"
_MOVABLE = ("revolute", "continuous")
_SEPARATORS = "_-. /:"
_MAX_BOX_CAPSULES = 8


# -- public API ---------------------------------------------------------------------------
def hand_from_urdf(
    path_or_text, *, name: str | None = None, root: str | None = None, length_unit: float = 1000.0
) -> Hand:
    """The hand described by a URDF file (a path) or URDF text (a string starting with ``<``).

    Args:
        path_or_text: path of a ``.urdf`` file, or the URDF XML itself.
        name: hand name (default: the ``<robot name>``, else the file stem).
        root: the link that becomes the palm (default: the unique link that is no joint's
            child); everything not below it is ignored.
        length_unit: millimetres per URDF length unit (1000: URDF is in metres).

    Raises:
        InvalidHand: malformed XML or URDF, unsupported joint, bad mimic...; the message
            starts with the file name.
    """
    return load_urdf_hand(path_or_text, name=name, root=root, length_unit=length_unit)[0]


def load_urdf_hand(
    path_or_text, *, name: str | None = None, root: str | None = None, length_unit: float = 1000.0
) -> tuple[Hand, list[str]]:
    """As :func:`hand_from_urdf`, also returning warnings (e.g. collision meshes skipped)."""
    robot, where, base_dir, stem = _read_robot(path_or_text)
    try:
        return _build_hand(robot, base_dir, name or robot.get("name") or stem, root, float(length_unit))
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


@dataclass
class _UJoint:
    """A URDF joint as read (origin translation already in mm)."""

    name: str
    type: str
    parent: str
    child: str
    T: np.ndarray
    axis: np.ndarray
    limits: tuple[float, float] | None
    mimic: tuple[str, float, float] | None


def _link_ref(elem: ET.Element, tag: str, what: str) -> str:
    ref = elem.find(tag)
    if ref is None or not ref.get("link"):
        raise InvalidHand(f"{what} has no <{tag} link=...>")
    return ref.get("link")


def _parse_joint(elem: ET.Element, unit: float) -> _UJoint:
    name = elem.get("name") or "(unnamed)"
    what = f"joint {name!r}"
    jtype = elem.get("type")
    if not jtype:
        raise InvalidHand(f"{what} has no type")
    axis_elem = elem.find("axis")
    axis = _floats(None if axis_elem is None else axis_elem.get("xyz"), 3, f"{what} axis", (1, 0, 0))
    limit = elem.find("limit")
    limits = None
    if limit is not None:
        limits = (_attr_float(limit, "lower", f"{what} limit", 0.0), _attr_float(limit, "upper", f"{what} limit", 0.0))
    mimic_elem = elem.find("mimic")
    mimic = None
    if mimic_elem is not None:
        if not mimic_elem.get("joint"):
            raise InvalidHand(f"{what}: <mimic> has no joint attribute")
        m = _attr_float(mimic_elem, "multiplier", f"{what} mimic", 1.0)
        mimic = (mimic_elem.get("joint"), m, _attr_float(mimic_elem, "offset", f"{what} mimic", 0.0))
    parent, child = _link_ref(elem, "parent", what), _link_ref(elem, "child", what)
    return _UJoint(name, jtype, parent, child, _origin(elem, unit, what), axis, limits, mimic)


def _parse_structure(robot: ET.Element, unit: float) -> tuple[dict[str, ET.Element], dict[str, _UJoint]]:
    """Links by name and joints by name, with names unique and every referenced link present."""
    links: dict[str, ET.Element] = {}
    for elem in robot.findall("link"):
        lname = elem.get("name")
        if not lname:
            raise InvalidHand("a <link> has no name")
        if lname in links:
            raise InvalidHand(f"link {lname!r} is defined twice")
        links[lname] = elem
    joints: dict[str, _UJoint] = {}
    for elem in robot.findall("joint"):
        j = _parse_joint(elem, unit)
        if j.name in joints:
            raise InvalidHand(f"joint {j.name!r} is defined twice")
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise InvalidHand(f"joint {j.name!r}: its {role} link {link!r} is not defined (no such <link>)")
        joints[j.name] = j
    if not links:
        raise InvalidHand("the robot has no <link>")
    return links, joints


# -- tree: root, order, types ---------------------------------------------------------------
def _parent_joints(joints: dict[str, _UJoint]) -> dict[str, _UJoint]:
    parent_of: dict[str, _UJoint] = {}
    for j in joints.values():
        if j.child in parent_of:
            raise InvalidHand(
                f"link {j.child!r} is the child of several joints ({parent_of[j.child].name!r}, {j.name!r}); "
                "a URDF is a tree"
            )
        parent_of[j.child] = j
    return parent_of


def _find_root(links, parent_of, root: str | None) -> str:
    if root is not None:
        if root not in links:
            raise InvalidHand(f"root link {root!r} not found; links are: {', '.join(links)}")
        return root
    roots = [name for name in links if name not in parent_of]
    if not roots:
        raise InvalidHand("no root link: every link is some joint's child, so the joints form a cycle")
    if len(roots) > 1:
        raise InvalidHand(
            f"several root links (links that are no joint's child): {', '.join(roots)}; "
            "connect them by joints or choose the palm with root="
        )
    return roots[0]


def _ordered_joints(joints, root: str, auto_root: bool, n_links: int) -> list[_UJoint]:
    """Joints below ``root``, breadth-first (parent before child); checks cycles and types."""
    by_parent: dict[str, list[_UJoint]] = defaultdict(list)
    for j in joints.values():
        by_parent[j.parent].append(j)
    seen, order, queue = {root}, [], deque([root])
    while queue:
        for j in by_parent[queue.popleft()]:
            if j.child in seen:
                raise InvalidHand(f"joint {j.name!r} closes a cycle: link {j.child!r} is already below {root!r}")
            if j.type not in _MOVABLE + ("fixed",):
                raise InvalidHand(
                    f"joint {j.name!r} is {j.type!r}; {_SUPPORTED} (a hand mounted on an arm should be cut "
                    "at the wrist with root=<the palm link>)"
                )
            seen.add(j.child)
            order.append(j)
            queue.append(j.child)
    if auto_root and len(seen) < n_links:
        raise InvalidHand(f"some links are not below the root {root!r}: the joints form a cycle")
    return order


# -- fixed-joint merging and joints -----------------------------------------------------------
def _merge_fixed(root: str, order: list[_UJoint]) -> dict[str, tuple[str, np.ndarray]]:
    """For every link below root: (the surviving link it belongs to, T_survivor_link)."""
    home = {root: (root, np.eye(4))}
    for j in order:
        survivor, T = home[j.parent]
        home[j.child] = (survivor, T @ j.T) if j.type == "fixed" else (j.child, np.eye(4))
    return home


def _make_joint(j: _UJoint, home) -> Joint:
    survivor, T_sp = home[j.parent]
    T = T_sp @ j.T
    if j.type == "continuous":
        lower, upper = -math.pi, math.pi
    elif j.limits is None:
        raise InvalidHand(f"revolute joint {j.name!r} has no <limit lower=... upper=...> (URDF requires it)")
    else:
        lower, upper = j.limits
    if np.linalg.norm(j.axis) < 1e-12:
        raise InvalidHand(f"joint {j.name!r}: the axis is the zero vector")
    return Joint(
        name=j.name,
        kind="revolute",
        parent=survivor,
        child=j.child,
        origin_in_parent=T[:3, 3],
        origin_in_child=np.zeros(3),
        axis_in_parent=T[:3, :3] @ (j.axis / np.linalg.norm(j.axis)),
        R_parent_child_zero=T[:3, :3],
        dof_names=(j.name,),
        lower=(lower,),
        upper=(upper,),
    )


def _resolve_mimic(name: str, joints: dict[str, _UJoint], movable: set[str]) -> tuple[str, float, float]:
    """(independent source, ratio, offset) of mimic joint ``name``, following mimic chains."""
    ratio, offset, current, seen = 1.0, 0.0, name, [name]
    while joints[current].mimic is not None:
        source, m, o = joints[current].mimic
        ratio, offset = ratio * m, ratio * o + offset
        if source not in joints:
            raise InvalidHand(f"joint {current!r} mimics joint {source!r}, which is not defined")
        if joints[source].type not in _MOVABLE:
            kind = joints[source].type
            raise InvalidHand(f"joint {current!r} mimics joint {source!r}, which is {kind}, not revolute")
        if source not in movable:
            raise InvalidHand(f"joint {current!r} mimics joint {source!r}, which is not below the root link")
        if source in seen:
            raise InvalidHand(f"mimic joints form a cycle: {' -> '.join(seen + [source])}")
        seen.append(source)
        current = source
    return current, ratio, offset


def _couplings(order: list[_UJoint], joints: dict[str, _UJoint]) -> list[Coupling]:
    movable = {j.name for j in order if j.type in _MOVABLE}
    out = []
    for j in order:
        if j.type in _MOVABLE and j.mimic is not None:
            source, ratio, offset = _resolve_mimic(j.name, joints, movable)
            out.append(Coupling(dof=j.name, source=source, ratio=ratio, offset=offset))
    return out


# -- collision shapes -> capsules -------------------------------------------------------------
def _move(cap: Capsule, T: np.ndarray) -> Capsule:
    R, t = T[:3, :3], T[:3, 3]
    return Capsule(R @ cap.a + t, R @ cap.b + t, cap.radius)


def _cylinder_capsule(radius: float, length: float) -> list[Capsule]:
    rho = min(radius, length / 2)
    h = length / 2 - rho
    return [Capsule((0, 0, -h), (0, 0, h), rho)]


def _box_capsules(size: np.ndarray) -> list[Capsule]:
    if not np.all(size > 0):
        raise ValueError(f"box sizes must be positive, got {size.tolist()} mm")
    long_ax, mid_ax, short_ax = np.argsort(-size, kind="stable")
    rho = float(size[short_ax]) / 2
    h = float(size[long_ax]) / 2 - rho
    n = min(_MAX_BOX_CAPSULES, max(1, math.ceil(size[mid_ax] / size[short_ax] - 1e-9)))
    w = float(size[mid_ax]) / 2 - rho
    offsets = np.linspace(-w, w, n) if n > 1 else np.zeros(1)
    e_long, e_mid = np.eye(3)[long_ax], np.eye(3)[mid_ax]
    return [Capsule(s * e_mid - h * e_long, s * e_mid + h * e_long, rho) for s in offsets]


def mesh_capsule(points) -> Capsule:
    """A capsule along the principal axis of ``points (n, 3)``: radius = 90th percentile of
    the distances to the axis, ends pulled in by the radius from the points' extent."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 3), axis=0)
    if len(pts) < 2:
        raise ValueError("the mesh has fewer than 2 distinct vertices")
    centre = pts.mean(axis=0)
    X = pts - centre
    axis = np.linalg.svd(X, full_matrices=False)[2][0]
    t = X @ axis
    rho = float(np.percentile(np.linalg.norm(X - t[:, None] * axis, axis=1), 90))
    if not rho > 0:
        raise ValueError("the mesh vertices are collinear (zero radius)")
    lo, hi = t.min() + rho, t.max() - rho
    if lo > hi:
        lo = hi = (t.min() + t.max()) / 2
    return Capsule(centre + lo * axis, centre + hi * axis, rho)


def _obj_vertices(text: str) -> np.ndarray:
    rows = [line.split()[1:4] for line in text.splitlines() if line.startswith("v ")]
    return np.array(rows, dtype=float).reshape(-1, 3)


def _stl_vertices(data: bytes) -> np.ndarray:
    if len(data) >= 84:
        n = int.from_bytes(data[80:84], "little")
        if len(data) == 84 + 50 * n:  # binary STL
            tri = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dtype=tri, count=n, offset=84)["v"].reshape(-1, 3).astype(float)
    number = r"([-+0-9.eE]+)"
    rows = re.findall(rf"vertex\s+{number}\s+{number}\s+{number}", data.decode("ascii", errors="replace"))
    return np.array(rows, dtype=float).reshape(-1, 3)


def read_mesh_vertices(path) -> np.ndarray:
    """Vertices ``(n, 3)`` of an ``.obj`` (``v`` lines) or ``.stl`` (ascii or binary) mesh,
    in the file's units.  Raises ``OSError``/``ValueError`` if it cannot be read."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".obj":
        pts = _obj_vertices(path.read_text(errors="replace"))
    elif suffix == ".stl":
        pts = _stl_vertices(path.read_bytes())
    else:
        raise ValueError(f"unsupported mesh format {suffix!r} (only .obj and .stl are read)")
    if len(pts) == 0 or not np.all(np.isfinite(pts)):
        raise ValueError("no finite vertices found")
    return pts


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


def _mesh_capsules(geom: ET.Element, base_dir: Path, unit: float, what: str) -> list[Capsule]:
    filename = geom.get("filename") or ""
    path = _mesh_path(filename, base_dir) if filename else None
    if path is None:
        raise ValueError(f"mesh file {filename!r} not found (searched from {base_dir})")
    scale = geom.get("scale", "1 1 1").split()
    scale = _floats(" ".join(scale * 3 if len(scale) == 1 else scale), 3, f"{what} mesh scale", ())
    return [mesh_capsule(read_mesh_vertices(path) * scale * unit)]


def _shape_capsules(geom: ET.Element, base_dir: Path, unit: float, what: str) -> list[Capsule]:
    """Capsules of one ``<geometry>`` child in its own frame [mm]; ValueError if skipped."""
    if geom.tag == "sphere":
        r = unit * _attr_float(geom, "radius", what)
        return [Capsule((0, 0, 0), (0, 0, 0), r)]
    if geom.tag == "cylinder":
        return _cylinder_capsule(unit * _attr_float(geom, "radius", what), unit * _attr_float(geom, "length", what))
    if geom.tag == "box":
        return _box_capsules(unit * _floats(geom.get("size"), 3, f"{what} box size", ()))
    if geom.tag == "mesh":
        return _mesh_capsules(geom, base_dir, unit, what)
    raise ValueError(f"unsupported geometry <{geom.tag}>")


def _link_capsules(elem: ET.Element, base_dir: Path, unit: float, warnings: list[str]) -> list[Capsule]:
    """All collision capsules of one URDF link, in its frame [mm]."""
    out = []
    for k, col in enumerate(elem.findall("collision")):
        what = f"link {elem.get('name')!r} collision {k}"
        geometry = col.find("geometry")
        shapes = list(geometry) if geometry is not None else []
        if not shapes:
            warnings.append(f"{what}: no <geometry> shape; skipped")
            continue
        try:
            T = _origin(col, unit, what)
            out += [_move(c, T) for c in _shape_capsules(shapes[0], base_dir, unit, what)]
        except (ValueError, OSError) as exc:  # InvalidHand is a ValueError: malformed numbers too
            warnings.append(f"{what}: {exc}; skipped")
    return out


# -- fingers --------------------------------------------------------------------------------
def _chains(palm: str, joints: list[Joint]) -> list[list[str]]:
    """Serial chains: one from each palm child, and one from each child of a branching link."""
    children: dict[str, list[str]] = defaultdict(list)
    for j in joints:
        children[j.parent].append(j.child)
    chains, starts = [], deque(children[palm])
    while starts:
        chain = [starts.popleft()]
        while len(children[chain[-1]]) == 1:
            chain.append(children[chain[-1]][0])
        chains.append(chain)
        starts.extend(children[chain[-1]])
    return chains


def _stem(names: list[str]) -> str:
    """Common prefix of ``names`` cut at a separator, without trailing separators."""
    prefix = os.path.commonprefix(names)
    if not all(len(n) == len(prefix) or n[len(prefix)] in _SEPARATORS for n in names):
        prefix = prefix[: max(prefix.rfind(c) for c in _SEPARATORS) + 1]
    return prefix.rstrip(_SEPARATORS)


def _urdf_tip(last: str, home, urdf_joints: list[_UJoint]) -> str:
    """The URDF leaf link merged into ``last`` by fixed joints, if exactly one; else ``last``."""
    parents = {j.parent for j in urdf_joints}
    leaves = [link for link, (survivor, _) in home.items() if survivor == last and link not in parents]
    return leaves[0] if len(leaves) == 1 else last


def _unique(candidates: list[list[str]]) -> list[str]:
    """First candidate of each finger, moving clashing ones down their lists, then suffixing."""
    level = [0] * len(candidates)
    while True:
        names = [c[k] for c, k in zip(candidates, level)]
        clash = [i for i, n in enumerate(names) if names.count(n) > 1 and level[i] < len(candidates[i]) - 1]
        if not clash:
            break
        for i in clash:
            level[i] += 1
    for i, n in enumerate(names):
        k = 2
        while names.count(names[i]) > 1:
            names[i] = f"{n}_{k}"
            k += 1
    return names


def _fingers(palm: str, joints: list[Joint], home, urdf_order: list[_UJoint]) -> list[Finger]:
    chains = _chains(palm, joints)
    hand_stem = _stem([link for chain in chains for link in chain]) if chains else ""
    candidates = []
    for chain in chains:
        stem = _stem(chain) if len(chain) > 1 else ""
        first = [stem] if stem and stem != hand_stem else []
        candidates.append(first + [_urdf_tip(chain[-1], home, urdf_order), chain[-1]])
    return [Finger(n, tuple(chain)) for n, chain in zip(_unique(candidates), chains)]


# -- assembling the hand --------------------------------------------------------------------
def _build_hand(robot: ET.Element, base_dir: Path, name: str, root: str | None, unit: float) -> tuple[Hand, list[str]]:
    if not (math.isfinite(unit) and unit > 0):
        raise InvalidHand(f"length_unit must be a positive number (mm per URDF unit), got {unit}")
    links, joints = _parse_structure(robot, unit)
    palm = _find_root(links, _parent_joints(joints), root)
    order = _ordered_joints(joints, palm, root is None, len(links))
    home = _merge_fixed(palm, order)
    warnings: list[str] = []
    capsules: dict[str, list[Capsule]] = defaultdict(list)
    for link, (survivor, T) in home.items():
        capsules[survivor] += [_move(c, T) for c in _link_capsules(links[link], base_dir, unit, warnings)]
    our_joints = [_make_joint(j, home) for j in order if j.type in _MOVABLE]
    link_names = [palm] + [j.child for j in our_joints]
    hand = Hand(
        name=name,
        links=tuple(Link(n, tuple(capsules[n])) for n in link_names),
        joints=tuple(our_joints),
        couplings=tuple(_couplings(order, joints)),
        fingers=tuple(_fingers(palm, our_joints, home, order)),
    )
    return hand, warnings
