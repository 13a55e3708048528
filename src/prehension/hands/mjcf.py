"""Read a :class:`~prehension.hands.model.Hand` from an MJCF (MuJoCo XML) file.

MuJoCo itself compiles the file (``pip install "prehension[mjcf]"``): includes, defaults,
classes, ``fromto`` shapes and mesh scaling are resolved by the same code that simulates
the model.  This module reads the compiled model into the neutral
:class:`~prehension.hands.description.RawHand`; :mod:`prehension.hands.assemble` makes
the hand (see there for the palm, fingers and fingertips).

Conventions
-----------
* **Units.** MJCF lengths are metres (``length_unit = 1000`` mm per unit); angles are
  read from the compiled model, so always radians.
* **Bodies** are links; a body's pose relative to its parent (``pos``, ``quat``) is its
  pose at the joints' reference angles ``ref`` (``qpos0``).
* **Hinge joints** are revolute: a hinge at ``pos`` (body frame) about ``axis`` turns the
  body by ``q - ref``, so ``T_parent_child(q) = T_body Trans(pos) Rot(axis, q) Rot(axis,
  -ref) Trans(-pos)``; the hand's angle is MuJoCo's ``qpos``.  A body with several joints
  gets an intermediate link per extra joint, named ``"<body>:<joint>"``, as MuJoCo composes
  them (each about the body-frame axis, after the previous ones).  Limits are the
  joint's ``range`` (``[-pi, pi]`` when unlimited).
* **Slide, ball and free joints** are not modelled: held at their reference position
  with a warning (a free joint on the hand's top body is simply dropped with a note).
* **Bodies without joints** are welded to their parent: merged into it, kept as named
  frames; so are **sites** (named frames, whose one per fingertip tells the fingertip fit
  where the tip is).
* **Couplings**: an active ``<equality><joint joint1="y" joint2="x" polycoef="c0 c1 ..."/>``
  states ``y - y0 = c0 + c1 (x - x0) + c2 (x - x0)^2 + ...`` (``y0``, ``x0`` the reference
  angles).  A linear one (``c2 = c3 = c4 = 0``) becomes ``q_y = c1 q_x + (y0 + c0 - c1 x0)``;
  a polynomial one is refused (:class:`~prehension.errors.InvalidHand`: the hand model
  couples angles linearly); one without ``joint2`` holds ``y`` at ``y0 + c0`` (its limits
  become that value).  Inactive constraints and other equality types (connect, weld,
  tendon...) are ignored with a note.
* **Geoms**: those that collide (``contype`` or ``conaffinity`` non-zero) are collision
  shapes, the others visual; spheres, capsules, cylinders, boxes, ellipsoids and meshes
  (the compiled vertices).  Planes, height fields and SDFs are skipped with a warning.
* **Mesh files**: MuJoCo reads OBJ, STL and MSH itself; a ``<mesh file>`` of another format
  (PLY, OFF, GLB, GLTF; DAE with pycollada) is read through trimesh
  (:func:`~prehension.objects.mesh_io.read_triangles`, a scene flattened with its node
  transforms applied) and given to MuJoCo as the mesh's vertices and faces, so that its
  ``scale`` (and a default class's) applies as to any mesh.  Such a file that cannot be read,
  or one of a format neither reads, is an error naming the mesh, the file and the formats
  read (MuJoCo refuses a model whose mesh it cannot load, and so does prehension).
  ``<contact><exclude>`` pairs are kept as collision exclusions.
* **Drawing**: a mesh geom's file is kept as a reference (:class:`~prehension.hands.model.LinkMesh`)
  in the file's own frame (MuJoCo's re-centring, ``mesh_pos`` / ``mesh_quat``, undone)
  with its scale, for scenes only.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..errors import InvalidHand, InvalidObject, PrehensionError
from ..mujoco_log import import_mujoco
from ..objects.mesh_io import read_triangles
from .assemble import ImportOptions, assemble
from .description import RawCoupling, RawHand, RawJoint, RawShape
from .fingertips import TipOverride
from .model import Hand, LinkMesh

__all__ = [
    "hand_from_mjcf", "read_mjcf", "compile_mjcf", "require_mujoco", "urdf_to_mjcf", "INSTALL_HINT", "MUJOCO_MESH_SUFFIXES",
]  # fmt: skip

INSTALL_HINT = 'pip install "prehension[mjcf]"'
MUJOCO_MESH_SUFFIXES = (".obj", ".stl", ".msh")  # the mesh files MuJoCo reads itself
_WORLD = 0


def require_mujoco():
    """The ``mujoco`` module, or a :class:`PrehensionError` that says how to install it."""
    try:
        return import_mujoco()
    except ImportError:
        raise PrehensionError(f"reading MJCF files needs the mujoco package; install it with: {INSTALL_HINT}") from None


# -- public API ---------------------------------------------------------------------------
def hand_from_mjcf(
    path, *, name: str | None = None, root: str | None = None, length_unit: float = 1000.0,
    fingertips: dict[str, TipOverride] | None = None,
) -> Hand:  # fmt: skip
    """The hand of an MJCF file (see the module docstring).

    Args:
        path: the ``.xml`` file (MuJoCo resolves its includes and assets from its folder).
        name: hand name (default: the ``<mujoco model>``, else the file stem).
        root: the body that becomes the palm (default: where the fingers branch).
        length_unit: millimetres per MJCF length unit (1000: metres).
        fingertips: per finger name, values that replace the fitted fingertip's.

    Raises:
        InvalidHand: MuJoCo cannot compile the file, a polynomial coupling...; the
            message starts with the file name.
        PrehensionError: the ``mujoco`` package is not installed.
    """
    raw = read_mjcf(path, length_unit, root=root)
    options = ImportOptions(name=name or raw.name or Path(path).stem, root=root, fingertips=dict(fingertips or {}))
    try:
        return assemble(raw, options)
    except InvalidHand as exc:
        raise InvalidHand(f"{raw.where}: {exc}") from None


def read_mjcf(path, length_unit: float = 1000.0, root: str | None = None) -> RawHand:
    """The neutral description of an MJCF file (before merging, palm and fingers).

    Without ``root``, the top bodies (children of the world) that hold no hinge joint
    (a table, a free object) are left out with a note, and several that do are an error.
    """
    mujoco = require_mujoco()
    where = str(path)
    model, files = _compile(path)
    unit = float(length_unit)
    try:
        if not (math.isfinite(unit) and unit > 0):
            raise InvalidHand(f"length_unit must be a positive number (mm per MJCF unit), got {unit}")
        return _Reader(mujoco, model, unit, where, files).raw(root)
    except InvalidHand as exc:
        raise InvalidHand(f"{where}: {exc}") from None


def compile_mjcf(path):
    """The compiled ``mujoco.MjModel`` of the MJCF file ``path``, its meshes in formats
    MuJoCo does not read (PLY, OFF, GLB, GLTF, DAE) read through trimesh and handed to MuJoCo
    as vertices and faces (which MuJoCo then scales, centres and uses as if it had read the
    file).  Raises :class:`InvalidHand` naming the file (and the mesh) when it cannot."""
    return _compile(path)[0]


def _compile(path):
    """``(compile_mjcf(path), the absolute path of each mesh's file, None for a mesh given
    by its vertices)``, the meshes in the model's order."""
    mujoco = require_mujoco()
    path = Path(os.fspath(path))
    try:
        spec = mujoco.MjSpec.from_file(os.fspath(path))
    except (ValueError, OSError) as exc:  # mujoco raises ValueError with the parser's message
        raise InvalidHand(f"{path}: MuJoCo cannot read the file: {str(exc).strip()}") from None
    mesh_dir = path.parent / spec.meshdir
    files = [str((mesh_dir / (Path(m.file).name if spec.strippath else m.file)).resolve()) if m.file else None
             for m in spec.meshes]  # fmt: skip
    for mesh in spec.meshes:
        _read_other_mesh(mesh, mesh_dir, spec.strippath, path)
    try:
        return spec.compile(), files
    except (ValueError, OSError) as exc:  # mujoco raises ValueError with the compiler's message
        raise InvalidHand(f"{path}: MuJoCo cannot compile the file: {str(exc).strip()}") from None


def _read_other_mesh(mesh, mesh_dir: Path, strip: bool, where: Path) -> None:
    """Give MuJoCo the vertices and faces of ``mesh``'s file if MuJoCo does not read its
    format (``mesh_dir``: the model's folder joined with ``<compiler meshdir>``)."""
    if not mesh.file or Path(mesh.file).suffix.lower() in MUJOCO_MESH_SUFFIXES:
        return
    file = Path(mesh.file).name if strip else mesh.file
    try:
        vertices, faces = read_triangles(mesh_dir / file)  # an absolute ``file`` replaces mesh_dir
    except InvalidObject as exc:  # names the file and, for a format it does not read, the formats read
        itself = ", ".join(MUJOCO_MESH_SUFFIXES)
        raise InvalidHand(f"{where}: mesh {mesh.name or mesh.file!r}: {exc} (MuJoCo itself reads {itself})") from None
    mesh.file = ""
    mesh.uservert = vertices.ravel().tolist()
    mesh.userface = faces.ravel().tolist()


def urdf_to_mjcf(urdf_path, mjcf_path) -> Path:
    """Let MuJoCo compile a URDF and save it as MJCF (``mj_saveLastXML``).

    The URDF gets a ``<mujoco><compiler>`` element (mesh folder = the URDF's folder, visual
    geoms and links without inertia kept, inertias balanced) so that nothing of the hand is
    lost.  Mesh paths in the saved file are absolute.  Returns ``mjcf_path``.
    """
    import xml.etree.ElementTree as ET

    mujoco = require_mujoco()
    urdf_path = Path(urdf_path).resolve()
    robot = ET.parse(urdf_path).getroot()
    for old in robot.findall("mujoco"):
        robot.remove(old)
    ext = ET.SubElement(robot, "mujoco")
    ET.SubElement(ext, "compiler", meshdir=str(urdf_path.parent), balanceinertia="true", discardvisual="false",
                  fusestatic="false", strippath="false")  # fmt: skip
    try:
        model = mujoco.MjModel.from_xml_string(ET.tostring(robot, encoding="unicode"))
    except ValueError as exc:
        raise InvalidHand(f"{urdf_path}: MuJoCo cannot compile the URDF: {str(exc).strip()}") from None
    mjcf_path = Path(mjcf_path)
    mujoco.mj_saveLastXML(str(mjcf_path), model)
    return mjcf_path


# -- the compiled model -> RawHand ----------------------------------------------------------------
def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _transform(R=None, t=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = t
    return T


def _rotation(axis, angle: float) -> np.ndarray:
    from ..geometry.rotations import rotation_about

    return _transform(rotation_about(np.asarray(axis, dtype=float), angle))


class _Reader:
    """Reads one compiled ``MjModel`` (a small class: the model and its name tables)."""

    def __init__(self, mujoco, model, unit: float, where: str, files=()):
        self.mj, self.m, self.unit, self.where = mujoco, model, unit, where
        self.files = list(files) + [None] * (model.nmesh - len(files))  # each mesh's file (None: not known)
        self.warnings: list[str] = []
        obj = mujoco.mjtObj
        self.body = [self._name(obj.mjOBJ_BODY, i) or f"body{i}" for i in range(model.nbody)]
        self.joint = [self._name(obj.mjOBJ_JOINT, i) or f"joint{i}" for i in range(model.njnt)]

    def _name(self, kind, i: int) -> str:
        return self.mj.mj_id2name(self.m, kind, i) or ""

    def _ancestor(self, a: int, k: int) -> bool:
        """Whether body ``a`` is an ancestor of body ``k``."""
        while k != _WORLD:
            k = int(self.m.body_parentid[k])
            if k == a:
                return True
        return False

    def _hinged(self, b: int) -> bool:
        """Whether body ``b`` or a body below it holds a hinge joint."""
        m, hinge = self.m, self.mj.mjtJoint.mjJNT_HINGE
        return any(m.jnt_type[j] == hinge and (m.jnt_bodyid[j] == b or self._ancestor(b, m.jnt_bodyid[j]))
                   for j in range(m.njnt))  # fmt: skip

    def _tops(self, root: str | None) -> list[int]:
        tops = [b for b in range(1, self.m.nbody) if self.m.body_parentid[b] == _WORLD]
        if not tops:
            raise InvalidHand("the model has no body below the world")
        if root is not None or len(tops) == 1:
            return tops
        hinged = [b for b in tops if self._hinged(b)]
        for b in tops:
            if b not in hinged:
                self.warnings.append(f"top body {self.body[b]!r} holds no hinge joint: not part of the hand")
        if len(hinged) > 1:
            names = ", ".join(self.body[b] for b in hinged)
            raise InvalidHand(f"several top bodies hold hinge joints: {names}; choose the hand with root=")
        return hinged or tops[:1]

    def raw(self, root: str | None = None) -> RawHand:
        m = self.m
        tops = self._tops(root)
        links, joints = [], []
        for b in range(1, m.nbody):
            if not any(b == t or self._ancestor(t, b) for t in tops):
                continue
            links.append(self.body[b])
            joints += self._body_joints(b, tops)
        links += [n for j in joints for n in [j.child] if n not in links]
        shapes = {k: v for k, v in self._shapes().items() if k in links}
        sites, site_joints = self._sites(set(links))
        couplings, joints = self._couplings(joints)
        if any(j.parent == "world" for j in joints):
            links.insert(0, "world")
        name = bytes(m.names).split(b"\0", 1)[0].decode(errors="replace")  # the model's name comes first
        return RawHand(name, tuple(links + sites), shapes, tuple(joints + site_joints), tuple(couplings),
                       tuple(self.warnings), self.where, self._exclusions())  # fmt: skip

    def _exclusions(self) -> tuple[tuple[str, str], ...]:
        """``<contact><exclude body1 body2>`` pairs (MuJoCo stores ``body1 << 16 | body2``)."""
        sig = [int(s) for s in self.m.exclude_signature]
        return tuple((self.body[s >> 16], self.body[s & 0xFFFF]) for s in sig)

    # -- joints ---------------------------------------------------------------------------
    def _body_pose(self, b: int) -> np.ndarray:
        return _transform(_quat_matrix(self.m.body_quat[b]), self.unit * self.m.body_pos[b])

    def _body_joints(self, b: int, tops: list[int]) -> list[RawJoint]:
        m = self.m
        parent = "world" if m.body_parentid[b] == _WORLD else self.body[m.body_parentid[b]]
        n, adr = int(m.body_jntnum[b]), int(m.body_jntadr[b])
        T_body = self._body_pose(b)
        if n == 0:
            return [] if parent == "world" and len(tops) == 1 else [RawJoint(f"{self.body[b]}:weld", "fixed", parent, self.body[b], T_body)]
        out, prev = [], parent
        for k in range(n):
            j = adr + k
            child = self.body[b] if k == n - 1 else f"{self.body[b]}:{self.joint[j]}"
            joint = self._joint(j, prev, child, T_body if k == 0 else np.eye(4))
            if joint.type == "free" and parent == "world" and len(tops) == 1:
                self.warnings.append(f"the free joint {joint.name!r} of the top body {self.body[b]!r} is dropped")
                return []
            out.append(joint)
            prev = child
        return out

    def _joint(self, j: int, parent: str, child: str, T_before: np.ndarray) -> RawJoint:
        m, mj = self.m, self.mj
        kind = mj.mjtJoint(int(m.jnt_type[j]))
        name = self.joint[j]
        if kind != mj.mjtJoint.mjJNT_HINGE:
            label = {mj.mjtJoint.mjJNT_SLIDE: "slide", mj.mjtJoint.mjJNT_BALL: "ball", mj.mjtJoint.mjJNT_FREE: "free"}
            return RawJoint(name, label.get(kind, str(kind)), parent, child, T_before)
        pos = self.unit * np.asarray(m.jnt_pos[j], dtype=float)
        axis = np.asarray(m.jnt_axis[j], dtype=float)
        ref = float(m.qpos0[m.jnt_qposadr[j]])
        limits = (float(m.jnt_range[j][0]), float(m.jnt_range[j][1])) if m.jnt_limited[j] else (-math.pi, math.pi)
        T_pj = T_before @ _transform(t=pos)
        T_jc = _rotation(axis, -ref) @ _transform(t=-pos)
        return RawJoint(name, "revolute", parent, child, T_pj, T_jc, axis, limits)

    # -- couplings ------------------------------------------------------------------------
    def _couplings(self, joints: list[RawJoint]) -> tuple[list[RawCoupling], list[RawJoint]]:
        m, mj = self.m, self.mj
        out, held = [], {}
        for e in range(m.neq):
            kind = mj.mjtEq(int(m.eq_type[e]))
            label = self._name(mj.mjtObj.mjOBJ_EQUALITY, e) or f"equality {e}"
            if kind != mj.mjtEq.mjEQ_JOINT:
                self.warnings.append(f"{label} ({kind.name[len('mjEQ_'):].lower()}) is ignored: only joint couplings are modelled")
                continue
            if not m.eq_active0[e]:
                self.warnings.append(f"{label} is inactive: ignored")
                continue
            coupling = self._coupling(e, label, held)
            out += [coupling] if coupling is not None else []
        joints = [j if j.name not in held else _held(j, held[j.name]) for j in joints]
        return out, joints

    def _coupling(self, e: int, label: str, held: dict) -> RawCoupling | None:
        m = self.m
        c = [float(x) for x in m.eq_data[e][:5]]
        y, x = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        y0 = float(m.qpos0[m.jnt_qposadr[y]])
        if any(abs(v) > 0 for v in c[2:]):
            raise InvalidHand(
                f"{label}: joint {self.joint[y]!r} follows joint {self.joint[x] if x >= 0 else '?'!r} by the polynomial "
                f"{c} (polycoef); the hand model couples angles linearly only (c2 = c3 = c4 = 0)"
            )
        if x < 0:
            held[self.joint[y]] = y0 + c[0]
            self.warnings.append(f"{label}: joint {self.joint[y]!r} is held at {math.degrees(y0 + c[0]):.6g} deg")
            return None
        x0 = float(m.qpos0[m.jnt_qposadr[x]])
        return RawCoupling(self.joint[y], self.joint[x], c[1], y0 + c[0] - c[1] * x0)

    # -- shapes and sites -------------------------------------------------------------------
    def _geom(self, g: int) -> RawShape | None:
        m, mj = self.m, self.mj
        kind = mj.mjtGeom(int(m.geom_type[g]))
        role = "collision" if (m.geom_contype[g] or m.geom_conaffinity[g]) else "visual"
        body = self.body[m.geom_bodyid[g]]
        what = f"body {body!r} geom {self._name(mj.mjtObj.mjOBJ_GEOM, g) or g} ({role})"
        T = _transform(_quat_matrix(m.geom_quat[g]), self.unit * m.geom_pos[g])
        s = self.unit * np.asarray(m.geom_size[g], dtype=float)
        G = mj.mjtGeom
        simple = {G.mjGEOM_SPHERE: ("sphere", (s[0],)), G.mjGEOM_CAPSULE: ("capsule", (s[0], 2 * s[1])),
                  G.mjGEOM_CYLINDER: ("cylinder", (s[0], 2 * s[1])), G.mjGEOM_BOX: ("box", tuple(2 * s)),
                  G.mjGEOM_ELLIPSOID: ("ellipsoid", tuple(s))}  # fmt: skip
        if kind in simple:
            return RawShape(simple[kind][0], role, T, tuple(float(v) for v in simple[kind][1]), None, what)
        if kind == G.mjGEOM_MESH:
            mesh = int(m.geom_dataid[g])
            adr, n = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            vertices = self.unit * np.array(m.mesh_vert[adr : adr + n], dtype=float)
            return RawShape("mesh", role, T, (), lambda v=vertices: v, what, self._mesh_file(mesh, role))
        self.warnings.append(f"warning: {what}: a {kind.name[len('mjGEOM_'):].lower()} is not a hand shape; skipped")
        return None

    def _mesh_file(self, mesh: int, role: str) -> LinkMesh | None:
        """The file that draws ``mesh``: MuJoCo stores a mesh scaled and moved to its own
        frame (``v = R^T (s * v_file - p)``, ``p, R`` = ``mesh_pos, mesh_quat``), which is
        the geom's, so the file's frame in the geom's is ``[R | p]^-1``."""
        m, file = self.m, self.files[mesh]
        if file is None:
            return None
        T_mesh = _transform(_quat_matrix(m.mesh_quat[mesh]), self.unit * np.asarray(m.mesh_pos[mesh], dtype=float))
        T_geom_file = np.linalg.inv(T_mesh)
        return LinkMesh(file, T_geom_file, tuple(self.unit * float(x) for x in m.mesh_scale[mesh]), role)

    def _shapes(self) -> dict[str, list[RawShape]]:
        out: dict[str, list[RawShape]] = {}
        for g in range(self.m.ngeom):
            b = int(self.m.geom_bodyid[g])
            shape = self._geom(g) if b != _WORLD else None
            if shape is not None:
                out.setdefault(self.body[b], []).append(shape)
        return out

    def _sites(self, taken: set[str]) -> tuple[list[str], list[RawJoint]]:
        """Sites as links welded to their bodies (they become named frames)."""
        m, names, joints = self.m, [], []
        for s in range(m.nsite):
            name, b = self._name(self.mj.mjtObj.mjOBJ_SITE, s), int(m.site_bodyid[s])
            if not name or name in taken or b == _WORLD:
                continue
            T = _transform(_quat_matrix(m.site_quat[s]), self.unit * m.site_pos[s])
            names.append(name)
            taken.add(name)
            joints.append(RawJoint(f"{name}:site", "fixed", self.body[b], name, T))
        return names, joints


def _held(j: RawJoint, value: float) -> RawJoint:
    from dataclasses import replace

    return replace(j, limits=(value, value))
