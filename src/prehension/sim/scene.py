"""The MuJoCo scene of a grasp, as MJCF text (SI units: m, kg, s).

The palm frame is the world frame.  Each link is a body nested in its parent's, placed
as the hand model places it (:mod:`prehension.hands.model`): a joint of the model becomes
one hinge (revolute) or two hinges in sequence (universal) about the joint centre ``Q``,
with axes ``R0^T u`` and ``v`` in the child frame, so that MuJoCo's
``R = R_parent R0 Rot(R0^T u, q1) Rot(v, q2)`` is the model's ``Rot(u, q1) R0 Rot(v, q2)``.
Each link carries its collision capsules and the hand regions the task's contacts use
(a sphere cap as its whole sphere, a point as a 1 mm ball behind it, a patch as the hull
of the patch and its copy 2 mm inside the link), each dof a position actuator.

The object is a free body at the solved pose, made of the convex pieces of its solid
(:func:`prehension.quality.object_solid`; a piece that is not convex is decomposed by
CoACD, the ``sim`` extra), with mass and inertia stated explicitly (uniform density,
:func:`prehension.quality.mass_properties`).  Hand geoms collide with the object only
(self-collision is the residual function's job); contacts use elliptic friction cones
with torsional friction (``condim`` 4) and the stiff contact parameters of DexGraspBench.
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from ..objects.meshes import Mesh
from ..quality.solid import mass_properties, object_solid
from ..tasks.model import Task
from ..tessellation import region_solid
from .options import SimOptions

ARENA_MB = 256  # MuJoCo's arena per model: its default (~14 MB) overflows at ~1300 constraint rows (teapot-service's start probe: 325 contacts within the 3 mm margin); untouched pages cost nothing

__all__ = ["SimScene", "build_scene_xml", "MM"]

MM = 1e-3  # metres per millimetre
_HAND = 'contype="1" conaffinity="2" solimp="0.5 0.99 0.0001" solref="0.005 1"'
_OBJECT = 'contype="2" conaffinity="1"'


@dataclass(frozen=True, eq=False)
class SimScene:
    """A grasp's MuJoCo scene.

    Attributes:
        xml: the MJCF text.
        dof_names: the hand's dofs; joint ``"dof:<name>"`` and actuator ``"act:<name>"`` each.
        object_pieces: convex pieces of the object (object frame, mm).
        T_palm_object: (4, 4) the object's starting pose [mm] (jittered when asked).
        approximation_mm: how far the pieces stand out of the solver's mesh next to the
            hand [mm] (:mod:`.start`; 0 when not measured).
    """

    xml: str
    dof_names: tuple[str, ...]
    object_pieces: tuple[Mesh, ...]
    T_palm_object: np.ndarray
    approximation_mm: float = 0.0


def _num(x) -> str:
    return " ".join(format(float(v), ".12g") for v in np.ravel(x))


def _frame(R: np.ndarray) -> str:
    return f'xyaxes="{_num(np.concatenate([R[:, 0], R[:, 1]]))}"'


class _Mjcf:
    """Collects mesh assets while the bodies are written."""

    def __init__(self, options: SimOptions):
        self.options = options
        self.assets: list[str] = []

    def mesh(self, prefix: str, mesh: Mesh, shell: bool = False) -> str:
        """Register ``mesh`` (mm) as an asset; its name.  ``shell``: MuJoCo computes its
        inertia as a shell's (for a body whose inertia is stated, so the mesh's is never
        used: a sliver piece whose volume MuJoCo finds too small is then accepted)."""
        name = f"{prefix}_{len(self.assets)}"
        faces = " ".join(str(int(i)) for i in mesh.faces.ravel())
        extra = ' inertia="shell"' if shell else ""
        self.assets.append(f'    <mesh name={quoteattr(name)} vertex="{_num(mesh.vertices * MM)}" face="{faces}"{extra}/>')
        return name


def build_scene_xml(task: Task, T_palm_object: np.ndarray, pieces, options: SimOptions, margin_mm: float = 0.0) -> SimScene:
    """The scene of ``task`` with the object at ``T_palm_object (4, 4)`` [mm], made of the
    convex ``pieces`` (object frame, mm).  Joint angles are set on the model, not here.
    With ``margin_mm``, contacts are reported up to that gap (the probe of
    :mod:`.run` that finds where the pieces stray from the solver's mesh; never simulated)."""
    hand = task.hand
    used: dict[str, list] = {}
    for c in task.contacts:
        hr = hand.region(c.hand_region)
        if hr.region not in used.setdefault(hr.link, []):
            used[hr.link].append(hr.region)
    children: dict[str, list] = {}
    for joint in hand.joints:
        children.setdefault(joint.parent, []).append(joint)
    mjcf = _Mjcf(options)
    body = _body(mjcf, hand, hand.palm, None, children, used, "    ")
    object_body = _object(mjcf, task, T_palm_object, pieces)
    actuators = "\n".join(
        f'    <position name={quoteattr("act:" + d)} joint={quoteattr("dof:" + d)} kp="{_num(options.kp)}" '
        f'ctrlrange="{_num([lo, hi])}"/>'
        for d, lo, hi in zip(hand.dof_names, hand.lower, hand.upper)
    )  # fmt: skip
    friction = _num([options.friction, options.torsion_mm * MM, 1e-4])
    assets = "\n".join(mjcf.assets)
    xml = f"""<mujoco model={quoteattr("prehension: " + task.name)}>
  <compiler angle="radian" autolimits="true"/>
  <size memory="{ARENA_MB}M"/>
  <option timestep="{_num(options.timestep_s)}" integrator="implicitfast" cone="elliptic" impratio="10" noslip_iterations="2">
    <flag gravity="disable"/>
  </option>
  <default>
    <geom condim="4" friction="{friction}" margin="{_num(margin_mm * MM)}"/>
  </default>
  <asset>
{assets}
  </asset>
  <worldbody>
{body}
{object_body}
  </worldbody>
  <actuator>
{actuators}
  </actuator>
</mujoco>
"""
    return SimScene(xml, hand.dof_names, tuple(pieces), np.asarray(T_palm_object, float))


def _body(mjcf: _Mjcf, hand, link: str, joint, children, used, indent: str) -> str:
    if joint is None:
        lines = [f"{indent}<body name={quoteattr('link:' + link)}>"]
    else:
        R0 = joint.R_parent_child_zero
        pos = (joint.origin_in_parent - R0 @ joint.origin_in_child) * MM
        lines = [f"{indent}<body name={quoteattr('link:' + link)} pos=\"{_num(pos)}\" {_frame(R0)}>"]
        lines += _joints(joint, mjcf.options, indent + "  ")
    geoms = _link_geoms(mjcf, hand, link, used.get(link, ()), indent + "  ")
    if not geoms and joint is not None:  # a moving body needs a mass
        geoms = [f'{indent}  <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>']
    lines += geoms
    for child_joint in children.get(link, ()):
        lines.append(_body(mjcf, hand, child_joint.child, child_joint, children, used, indent + "  "))
    lines.append(f"{indent}</body>")
    return "\n".join(lines)


def _joints(joint, options: SimOptions, indent: str) -> list[str]:
    """One hinge per dof of ``joint``, about its centre in the child frame."""
    axes = [joint.R_parent_child_zero.T @ joint.axis_in_parent]
    if joint.kind == "universal":
        axes.append(joint.axis_in_child)
    return [
        f"{indent}<joint name={quoteattr('dof:' + dof)} type=\"hinge\" pos=\"{_num(joint.origin_in_child * MM)}\" "
        f"axis=\"{_num(axis)}\" range=\"{_num([lo, hi])}\" damping=\"{_num(options.damping)}\" armature=\"0.0001\"/>"
        for dof, axis, lo, hi in zip(joint.dof_names, axes, joint.lower, joint.upper)
    ]  # fmt: skip


def _link_geoms(mjcf: _Mjcf, hand, link: str, regions, indent: str) -> list[str]:
    out = []
    for capsule in hand.links[hand.link_index(link)].collision:
        size = f'size="{_num(capsule.radius * MM)}"'
        if np.allclose(capsule.a, capsule.b):
            out.append(f'{indent}<geom type="sphere" pos="{_num(capsule.a * MM)}" {size} {_HAND}/>')
        else:
            out.append(f'{indent}<geom type="capsule" fromto="{_num(np.r_[capsule.a, capsule.b] * MM)}" {size} {_HAND}/>')
    return out + [_region_geom(mjcf, region, indent) for region in regions]


def _region_geom(mjcf: _Mjcf, region, indent: str) -> str:
    """The solid a hand region is the surface of (see the module docstring)."""
    solid = region_solid(region)
    if isinstance(solid, Mesh):
        return f'{indent}<geom type="mesh" mesh={quoteattr(mjcf.mesh("hand_region", solid))} {_HAND}/>'
    centre, radius = solid
    return f'{indent}<geom type="sphere" pos="{_num(centre * MM)}" size="{_num(radius * MM)}" {_HAND}/>'


def _object(mjcf: _Mjcf, task: Task, T: np.ndarray, pieces) -> str:
    """The object's free body: its convex pieces, with its mass and inertia stated."""
    options = mjcf.options
    props = mass_properties(object_solid(task.object))
    density = options.mass_kg / (props.volume_mm3 * MM**3)
    inertia = props.inertia_mm5 * MM**5 * density  # (3, 3) [kg m^2] about the centroid, object frame
    full = _num([inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]])
    geoms = [f'      <geom name="object_{k}" type="mesh" mesh={quoteattr(mjcf.mesh("object", piece, shell=True))} {_OBJECT}/>'
             for k, piece in enumerate(pieces)]  # fmt: skip
    return "\n".join([
        f'    <body name="object" pos="{_num(T[:3, 3] * MM)}" {_frame(T[:3, :3])}>',
        '      <freejoint name="object"/>',
        f'      <inertial pos="{_num(props.centroid_mm * MM)}" mass="{_num(options.mass_kg)}" fullinertia="{full}"/>',
        *geoms,
        "    </body>",
    ])  # fmt: skip
