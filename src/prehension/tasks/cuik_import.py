"""Turn a CuikSuite ``.world`` grasp problem into a :class:`~prehension.tasks.model.Task`
(or a world without contacts into a :class:`~prehension.hands.model.Hand`).

The parser (:mod:`prehension.tasks.cuik_parser`) reads the syntax; this module gives
the joints their meaning, as the IJRR 2011 files use them (``shared/cuik-ijrr/README.md``):

* ``revolute: L1 (p)+(d) L2 (q)+(e) range [lo,hi] +(a) +(b)``: points p (in L1) and q
  (in L2) coincide, axes d and e coincide; the angle is the right-handed angle about
  the axis from a (L1) to b (L2).  So ``R0`` maps (e, b) onto (d, a).
* ``universal: L1 (p)+(d1) L2 (q)+(d2) range [lo1,hi1] +(a1) [lo2,hi2] +(a2)``: angle 1
  is measured about d1 from a1 to the second axis; angle 2 about d2, by default in the
  2011 reading: from L2's reference a2 to the first axis (``angle2="2011"``); the current
  CuikSuite release measures it the other way (``angle2="current"``).  ``R0`` maps
  (d2, a2) onto (a1, d1); in the 2011 reading our second axis is ``-d2``.
* ``SPHERICAL: L (c) X (0,0,-rho) range [beta] +(m) +(0,0,1)`` followed by
  ``in_patch: X (0,0,0) (0,0,1) object (P0) (P1) (P2) (P3)``: a fingertip (or palm)
  sphere of radius rho centred at c on hand link L, whose contact normal may deviate from
  m by at most beta, touching the bilinear patch with corners b00=P0, b01=P1, b10=P2,
  b11=P3.  The files orient ``p_u x p_v`` *into* the object; our regions carry outward
  normals, so the imported patch is the file's with u and v swapped.
* ``in_patch: L (p) (d) object (...)`` with L a hand link: the point p of L, with outward
  normal d, touches the patch.
* A joint without ``range`` is unlimited ([-180, 180] deg; its zero is then arbitrary).
  ``avoid limits`` only biases CuikSuite's search and is ignored.

* ``crevolute`` is a revolute joint whose angle equals the previous revolute joint's
  (a coupling); ``fix: L1 L2 T`` folds L2 into L1; a revolute joint written from the
  outer link to the inner one is turned round; a range of a whole turn or more is
  [-180, 180] deg.  :mod:`prehension.tasks.cuik_scope` does these, and refuses what
  prehension cannot model (prismatic joints, bars/legs/springs/cables, ``[EQUATIONS]``,
  obstacles a ``[COLLISIONS]`` check asks to avoid) naming the construct, line and why.

``couplings`` adds ``(angle, source)`` pairs (equal angles) to the file's crevolute
ones, and ``couple_distal=True`` couples the last two revolute joints of every finger,
as the SA hand does.  Fingers are the chains that leave the ground link, named after
their tip link; the fingers taking part are those that carry a contact.  Anything else
(a closed kinematic loop, a spherical joint that is not a contact, several free bodies)
is refused with an error naming the line.  A world without contacts is a mechanism:
:func:`hand_from_world` reads it as a hand (no regions).

The object's body file (``body "file.off"`` of the object link), when it is a closed mesh
that the contact regions lie on, is its collision solid (mm): the hand may not pass
through it.  Otherwise (an open mesh, such as the IJRR teapot's, or regions off its
surface) it is display only, and the task's description says so and why.  The hand's
link bodies are display shapes, not read as collision shapes: a hand that moves as the
built-in SA hand (every link at an SA link's pose, at zero and at random angles; the
IJRR files) gets the SA hand's collision capsules, any other hand none.  The hand's
notes and the task's description say which geometry judged collisions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import InvalidObject, PrehensionError, WorldFileError
from ..geometry.bezier import BezierPatch
from ..geometry.regions import BezierRegion, PointRegion, SphereCap
from ..hands.kinematics import forward_kinematics
from ..hands.model import Coupling, Finger, Hand, HandRegion, Joint, Link
from ..hands.sa_hand import schunk_sa_hand
from ..objects.model import GraspObject
from ..objects.solid import MeshFileSolid
from .cuik_parser import WorldFile, WorldJoint, read_world
from .cuik_scope import prepare_world
from .model import Contact, Task

__all__ = ["task_from_world", "hand_from_world", "import_world"]

_ORTHO_TOL = 1e-3  # the files round reference vectors to 5 digits


@dataclass(frozen=True)
class _Ctx:
    world: WorldFile

    def fail(self, message: str, joint: WorldJoint | None = None) -> WorldFileError:
        return WorldFileError(message, path=self.world.path, line=None if joint is None else joint.line)


def _unit(v, what: str, ctx: _Ctx, joint: WorldJoint) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ctx.fail(f"{what} is a zero vector", joint)
    return v / n


def _frame_map(axis_p, ref_p, axis_c, ref_c, ctx, joint) -> np.ndarray:
    """R0 with R0 axis_c = axis_p and R0 ref_c = ref_p (references made orthogonal)."""
    cols = []
    for axis, ref, side in ((axis_p, ref_p, "first"), (axis_c, ref_c, "second")):
        if abs(float(axis @ ref)) > _ORTHO_TOL:
            raise ctx.fail(
                f"{joint.kind} joint: the {side} reference vector must be orthogonal to its axis "
                f"(cosine {float(axis @ ref):.3g})",
                joint,
            )
        ref = ref - axis * float(axis @ ref)
        ref = ref / np.linalg.norm(ref)
        cols.append(np.column_stack([axis, ref, np.cross(axis, ref)]))
    return cols[0] @ cols[1].T


def _any_perpendicular(axis: np.ndarray) -> np.ndarray:
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    v = np.cross(axis, helper)
    return v / np.linalg.norm(v)


def _limits(joint: WorldJoint, n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The ranges as limits; none, or a range of a whole turn or more (every angle
    reachable, as CuikSuite allows), is [-pi, pi]."""
    if not joint.ranges:
        return (-np.pi,) * n, (np.pi,) * n
    whole = [hi - lo >= 2 * np.pi for lo, hi in joint.ranges]
    lower = tuple(-np.pi if w else float(lo) for w, (lo, _) in zip(whole, joint.ranges))
    upper = tuple(np.pi if w else float(hi) for w, (_, hi) in zip(whole, joint.ranges))
    return lower, upper


def _axes_and_references(joint: WorldJoint, ctx: _Ctx):
    """The joint's two unit axes and two unit reference vectors (any perpendiculars
    when the joint has no range: its zero is then arbitrary)."""
    kind = joint.kind
    first = _unit(joint.axis1, f"{kind} joint: first axis", ctx, joint)
    second = _unit(joint.axis2, f"{kind} joint: second axis", ctx, joint)
    if not joint.range_vectors:
        return first, second, _any_perpendicular(first), _any_perpendicular(second)
    ref1 = _unit(joint.range_vectors[0], f"{kind} joint: first reference", ctx, joint)
    ref2 = _unit(joint.range_vectors[1], f"{kind} joint: second reference", ctx, joint)
    return first, second, ref1, ref2


def _revolute(joint: WorldJoint, ctx: _Ctx) -> Joint:
    d, e, a, b = _axes_and_references(joint, ctx)
    R0 = _frame_map(d, a, e, b, ctx, joint)
    lo, hi = _limits(joint, 1)
    name = joint.link2
    return Joint(name, "revolute", joint.link1, joint.link2, joint.point1, joint.point2, d, R0, (name,), lo, hi)


def _universal(joint: WorldJoint, ctx: _Ctx, angle2: str) -> Joint:
    u, v, a1, a2 = _axes_and_references(joint, ctx)
    R0 = _frame_map(a1, u, v, a2, ctx, joint)  # R0 v = a1, R0 a2 = u
    lo, hi = _limits(joint, 2)
    name = joint.link2
    v_model = -v if angle2 == "2011" else v
    return Joint(
        name, "universal", joint.link1, joint.link2, joint.point1, joint.point2, u, R0,
        (f"{name}_1", f"{name}_2"), lo, hi, axis_in_child=v_model,
    )  # fmt: skip


def _hand_tree(ctx: _Ctx, angle2: str) -> tuple[list[Joint], str]:
    ground = ctx.world.ground
    if ground is None:
        raise ctx.fail("the file has no [LINKS]; its first link is the palm")
    joints, lines = [], {}
    for j in ctx.world.joints:
        if j.kind in ("revolute", "crevolute"):
            joints.append(_revolute(j, ctx))
        elif j.kind == "universal":
            joints.append(_universal(j, ctx, angle2))
        else:
            continue
        lines[id(joints[-1])] = j
    return _order_from(ground, joints, ctx, lines), ground


def _order_from(ground: str, joints: list[Joint], ctx: _Ctx, lines: dict) -> list[Joint]:
    """Joints ordered palm-outwards; refuses loops and links with two parents."""
    children: dict[str, list[Joint]] = {}
    seen_child: dict[str, Joint] = {}
    for j in joints:
        if j.child in seen_child or j.child == ground:
            first = lines[id(seen_child[j.child])].line if j.child in seen_child else None
            before = f" (the joint at line {first} already reaches it)" if first else " (the ground link)"
            raise ctx.fail(f"{lines[id(j)].kind} joint to {j.child!r} closes a kinematic loop: {j.child!r} is "
                           f"already placed{before}; prehension reads hands that are trees", lines[id(j)])
        seen_child[j.child] = j
        children.setdefault(j.parent, []).append(j)
    ordered, stack = [], [ground]
    while stack:
        link = stack.pop(0)
        for j in children.get(link, []):
            ordered.append(j)
            stack.append(j.child)
    loose = [j for j in joints if j not in ordered]
    if loose:
        raise ctx.fail(f"joint to {loose[0].child!r} is not connected to the ground link {ground!r}",
                       lines[id(loose[0])])
    return ordered


def _contacts(ctx: _Ctx, hand_links: set[str]):
    """Hand regions, object regions and contacts from SPHERICAL + in_patch pairs."""
    spheres = {j.link2: j for j in ctx.world.joints if j.kind == "spherical"}
    hand_regions, object_regions, contacts, objects = {}, {}, [], set()
    for j in ctx.world.joints:
        if j.kind == "spherical" and j.link1 not in hand_links:
            raise ctx.fail(f"spherical joint: {j.link1!r} is not a hand link; only fingertip contacts are supported", j)
        if j.kind != "in_patch":
            continue
        if j.link2 in hand_links:
            raise ctx.fail("in_patch: the patch must lie on the object, not on a hand link", j)
        objects.add(j.link2)
        if j.link1 in spheres:
            link, region = _sphere_region(spheres[j.link1], j, ctx)
        elif j.link1 in hand_links:
            link, region = j.link1, PointRegion(j.point1, j.axis1)
        else:
            raise ctx.fail(f"in_patch: {j.link1!r} is neither a hand link nor a contact frame of a SPHERICAL joint", j)
        name = j.link1
        hand_regions[name] = HandRegion(link, region)
        object_regions[name] = _object_patch(j, ctx)
        contacts.append(Contact(name, name, name))
    unused = set(spheres) - set(hand_regions)
    if unused:
        raise ctx.fail(f"SPHERICAL joint to {sorted(unused)[0]!r} has no in_patch: a contact needs both", spheres[sorted(unused)[0]])
    if not objects:
        raise ctx.fail("the file states no contact (no in_patch joint); a grasp task needs at least one (a world "
                       "without contacts is a mechanism: prehension.tasks.cuik_import.hand_from_world reads it "
                       "as a hand)")
    if len(objects) != 1:
        raise ctx.fail(f"expected exactly one object carrying the contact patches, found {sorted(objects) or 'none'}")
    return hand_regions, object_regions, contacts, objects.pop()


def _sphere_region(sph: WorldJoint, patch: WorldJoint, ctx: _Ctx) -> tuple[str, SphereCap]:
    """The fingertip sphere cap of a SPHERICAL joint whose contact frame touches a patch."""
    if sph.cone_angle is None or len(sph.range_vectors) != 2:
        raise ctx.fail("SPHERICAL contact: give 'range [beta] +(m) +(n)' (the cap axis and the frame normal)", sph)
    q, n = np.asarray(sph.point2, float), _unit(sph.range_vectors[1], "SPHERICAL: frame normal", ctx, sph)
    rho = float(np.linalg.norm(q))
    if rho < 1e-9 or np.linalg.norm(q + rho * n) > 1e-9 * max(rho, 1.0):
        raise ctx.fail("SPHERICAL contact: the contact-frame point must be (0,0,-rho) along minus the frame normal", sph)
    surface = np.asarray(patch.point1, float)
    direction = _unit(patch.axis1, "in_patch: direction", ctx, patch)
    if np.linalg.norm(surface) > 1e-9 or np.linalg.norm(direction - n) > 1e-9:
        raise ctx.fail("in_patch: on a contact frame, the point must be its origin and the direction its normal", patch)
    cap = SphereCap(sph.point1, rho, sph.range_vectors[0], min(float(sph.cone_angle), np.pi))
    return sph.link1, cap


def _object_patch(j: WorldJoint, ctx: _Ctx) -> BezierRegion:
    P0, P1, P2, P3 = (np.asarray(p, float) for p in j.patch)
    file_patch = BezierPatch(np.array([[P0, P1], [P2, P3]]))
    try:
        return BezierRegion(file_patch.reversed_orientation())  # outward = -(file's p_u x p_v)
    except PrehensionError as exc:
        raise ctx.fail(f"in_patch: {exc}", j) from None


def _fingers(ground: str, joints: list[Joint]) -> list[Finger]:
    children: dict[str, list[str]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j.child)
    fingers = []
    for start in children.get(ground, []):
        chain = [start]
        while len(children.get(chain[-1], [])) == 1:
            chain.append(children[chain[-1]][0])
        fingers.append(Finger(chain[-1], tuple(chain)))
    return fingers


def _distal_couplings(fingers, joints) -> list[Coupling]:
    by_child = {j.child: j for j in joints}
    out = []
    for f in fingers:
        revs = [by_child[l] for l in f.links if by_child[l].kind == "revolute"]
        if len(revs) >= 2:
            out.append(Coupling(revs[-1].dof_names[0], revs[-2].dof_names[0]))
    return out


def _file_couplings(crevolute, couplings, couple_distal, fingers, joints) -> list[Coupling]:
    """The file's crevolute couplings, then the ones asked for (``(angle, source)``), then
    (``couple_distal``) the distal ones not yet coupled."""
    cpl = [Coupling(a, b, ratio) for a, b, ratio in crevolute]
    cpl += [Coupling(a, b) for a, b in couplings if a not in {x.dof for x in cpl}]
    if couple_distal:
        cpl += [c for c in _distal_couplings(fingers, joints) if c.dof not in {x.dof for x in cpl}]
    return cpl


def _hand_of(ctx: _Ctx, angle2: str, crevolute, couplings, couple_distal, regions) -> tuple[Hand, list[Joint], str]:
    joints, ground = _hand_tree(ctx, angle2)
    fingers = _fingers(ground, joints)
    cpl = _file_couplings(crevolute, couplings, couple_distal, fingers, joints)
    links = [Link(ground)] + [Link(j.child) for j in joints]
    stem = Path(ctx.world.path).stem if ctx.world.path else "world"
    hand = _with_sa_geometry(Hand(stem, tuple(links), tuple(joints), tuple(cpl), tuple(fingers), regions))
    return hand, joints, ground


def task_from_world(
    world: WorldFile,
    *,
    name: str | None = None,
    angle2: str = "2011",
    couplings: tuple[tuple[str, str], ...] = (),
    couple_distal: bool = False,
) -> Task:
    """The task a parsed world file states (see the module docstring)."""
    if angle2 not in ("2011", "current"):
        raise ValueError("angle2 must be '2011' or 'current'")
    world, crevolute = prepare_world(world, task=True)
    ctx = _Ctx(world)
    joints, ground = _hand_tree(ctx, angle2)
    hand_links = {ground} | {j.child for j in joints}
    hand_regions, object_regions, contacts, obj_name = _contacts(ctx, hand_links)
    _check_all_links_used(ctx, hand_links, set(hand_regions), obj_name)
    try:
        hand, _, _ = _hand_of(ctx, angle2, crevolute, couplings, couple_distal, hand_regions)
        _check_body_files(world)
        obj, judged = _object(obj_name, object_regions, _object_mesh(world, obj_name))
        used = sorted({hand.finger_of_link(r.link) for r in hand_regions.values()} - {None})
        task_name = name or (Path(world.path).resolve().parent.name if world.path else hand.name) or hand.name
        about = f"imported from {world.path}; {judged}; {hand.notes[-1]}{_unread(world)}"
        return Task(task_name, hand, obj, tuple(contacts), tuple(used), description=about)
    except WorldFileError:
        raise
    except PrehensionError as exc:
        raise WorldFileError(str(exc), path=world.path) from None


def hand_from_world(world: WorldFile, *, angle2: str = "2011", couple_distal: bool = False) -> Hand:
    """The hand (or any tree mechanism) a world without contacts states: its first link the
    palm, its revolute, crevolute and universal joints (``fix`` joints folded) the
    fingers; no regions.  Links no joint names (a scene's objects) are left out, as the
    hand's last note says.  A world with ``in_patch`` contacts is a task
    (:func:`task_from_world`); a spherical (ball) joint is refused."""
    if angle2 not in ("2011", "current"):
        raise ValueError("angle2 must be '2011' or 'current'")
    world, crevolute = prepare_world(world, task=False)
    joined = {name for j in world.joints for name in (j.link1, j.link2)}
    loose = [link.name for link in world.links[1:] if link.name not in joined]
    world = replace(world, links=tuple(link for link in world.links if link.name not in loose))
    ctx = _Ctx(world)
    for joint in sorted(world.joints, key=lambda j: j.kind != "in_patch"):
        if joint.kind == "in_patch":
            raise ctx.fail("the file states contacts (in_patch): it is a grasp task; import it as a task", joint)
        if joint.kind == "spherical":
            raise ctx.fail(f"spherical joint between {joint.link1!r} and {joint.link2!r} that is no fingertip "
                           "contact (a ball joint): prehension's hands have revolute and universal joints only", joint)
    try:
        hand, joints, ground = _hand_of(ctx, angle2, crevolute, (), couple_distal, {})
    except WorldFileError:
        raise
    except PrehensionError as exc:
        raise WorldFileError(str(exc), path=world.path) from None
    _check_all_links_used(ctx, {ground} | {j.child for j in joints}, set(), None)
    if loose:
        hand = replace(hand, notes=hand.notes + (f"left out: link(s) {', '.join(loose)} (no joint connects them: "
                                                 "bodies of the scene, not of the hand)",))
    return hand


def _unread(world: WorldFile) -> str:
    """What of the file the task leaves aside, in words (empty when nothing)."""
    parts = []
    if world.obstacles:
        parts.append(f"{len(world.obstacles)} obstacle(s) display only (no [COLLISIONS] check names them)")
    if world.collisions:
        parts.append("the [COLLISIONS] statements are not read (collisions are judged as said above)")
    return "".join(f"; {p}" for p in parts)


SA_GEOMETRY = "hand collisions: the built-in SA hand's capsules (this world's hand moves as the SA hand)"
NO_HAND_GEOMETRY = ("hand collisions: none (the .world's link bodies are display shapes; prehension does not read "
                    "them as collision shapes)")  # fmt: skip
_SAME_POSE_MM = 1e-3  # the files round some axes to 5 digits


def _with_sa_geometry(hand: Hand) -> Hand:
    """``hand`` with the built-in SA hand's collision capsules on its links when it is the
    SA hand: every link at the pose of one SA link, at zero angles and at four seeded random
    ones (the dofs matched through the joints' child links); else ``hand`` as it is.  Its
    notes say which (:data:`SA_GEOMETRY`, :data:`NO_HAND_GEOMETRY`)."""
    match = _sa_links(hand)
    if match is None:
        return replace(hand, notes=hand.notes + (NO_HAND_GEOMETRY,))
    sa = schunk_sa_hand()
    links = tuple(Link(link.name, sa.links[sa.link_index(match[link.name])].collision) for link in hand.links)
    return replace(hand, links=links, notes=hand.notes + (SA_GEOMETRY,))


def _sa_links(hand: Hand) -> dict[str, str] | None:
    """Link name -> the SA hand's link at the same pose, if ``hand`` moves as the SA hand."""
    sa = schunk_sa_hand()
    if len(hand.links) != len(sa.links) or hand.n_dof != sa.n_dof:
        return None
    ours = forward_kinematics(hand, np.zeros(hand.n_dof)).T_palm_link.reshape(-1, 4, 4)
    theirs = forward_kinematics(sa, np.zeros(sa.n_dof)).T_palm_link.reshape(-1, 4, 4)
    gap = np.abs(ours[:, None] - theirs[None]).max(axis=(2, 3))  # (L, L)
    best = gap.argmin(axis=1)
    if gap[np.arange(len(best)), best].max() > _SAME_POSE_MM or len(set(best)) != len(best):
        return None
    match = {link.name: sa.links[j].name for link, j in zip(hand.links, best)}
    by_child = {j.child: j for j in sa.joints}
    order = []  # for each of our dofs, the SA dof
    for joint in hand.joints:
        twin = by_child[match[joint.child]]
        if match.get(joint.parent) != twin.parent or len(twin.dof_names) != len(joint.dof_names):
            return None
        order += [sa.dof_index(d) for d in twin.dof_names]
    q_sa = np.random.default_rng(0).uniform(-1.0, 1.0, size=(4, sa.n_dof))
    q_ours = np.zeros((4, hand.n_dof))
    q_ours[:, [hand.dof_index(d) for joint in hand.joints for d in joint.dof_names]] = q_sa[:, order]
    ours = forward_kinematics(hand, q_ours).T_palm_link
    theirs = forward_kinematics(sa, q_sa).T_palm_link[:, best]
    return match if np.abs(ours - theirs).max() <= _SAME_POSE_MM else None


def _object(name: str, regions, mesh: str | None) -> tuple[GraspObject, str]:
    """The object, with its body file as its collision solid when that is a closed mesh
    the regions lie on; else display only.  Also what judged collisions, in words."""
    if mesh is None:
        return GraspObject(name, regions), "object collisions: none (the object has no body file)"
    try:
        obj = GraspObject(name, regions, solid=MeshFileSolid(mesh, 1.0))
        return obj, f"object collisions: its body file {Path(mesh).name} (a closed mesh, mm)"
    except InvalidObject as exc:
        reason = str(exc).split(": ", 1)[-1].split("; ")[0]
        obj = GraspObject(name, regions, mesh_file=mesh)
        return obj, (f"object collisions: none -- its body file {Path(mesh).name} is display only, not a collision solid, "
                     f"because {reason}")  # fmt: skip


def _check_all_links_used(ctx: _Ctx, hand_links, frames, obj_name) -> None:
    for link in ctx.world.links:
        if link.name not in hand_links and link.name not in frames and link.name != obj_name:
            raise WorldFileError(
                f"link {link.name!r} is connected to nothing prehension reads (hand joints, contacts, the object)",
                path=ctx.world.path, line=link.line,
            )  # fmt: skip


def _body_file(world: WorldFile, relative: str) -> Path | None:
    """Where a ``body "file.off"`` of the world file is: its folder or up to three above it
    (CuikSuite examples keep ``bodies/`` a level or two up)."""
    folder = Path(world.path).resolve().parent
    for base in (folder, *list(folder.parents)[:3]):
        if (base / relative).is_file():
            return base / relative
    return None


def _check_body_files(world: WorldFile) -> None:
    """Every body file the world names exists (CuikSuite reads them all): else an error
    naming the link, its line and where the file was looked for."""
    if world.path is None:
        return
    for link in world.links:
        for body in link.bodies:
            if body.kind == "off" and body.path and _body_file(world, body.path) is None:
                raise WorldFileError(
                    f"link {link.name!r}: body file {body.path!r} not found (looked in the world file's folder "
                    "and up to three folders above it)", path=world.path, line=link.line,
                )  # fmt: skip


def _object_mesh(world: WorldFile, obj_name: str) -> str | None:
    if world.path is None:
        return None
    for body in world.link(obj_name).bodies:
        if body.kind == "off" and body.path:
            return str(_body_file(world, body.path))
    return None


def import_world(path, **options) -> Task:
    """Read and import a ``.world`` file (options as :func:`task_from_world`)."""
    return task_from_world(read_world(path), **options)
