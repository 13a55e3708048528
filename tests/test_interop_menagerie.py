"""A MuJoCo Menagerie-layout MJCF hand under ``solve``, ``simulate`` and ``export`` (issue 31
item 2): ``<compiler meshdir>``, ``<default>`` classes (nested, ``childclass``), visual meshes
in an ``assets/`` subfolder (OBJ and a GLB scene, a mesh ``scale``), collision boxes,
actuators and contact exclusions, as Menagerie hands are written.  The test writes the hand
(a two-finger gripper), solves a pinch of a cube, simulates it, and draws it with its meshes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
trimesh = pytest.importorskip("trimesh")

from prehension.cli import main  # noqa: E402
from prehension.cli.codes import EXIT_OK  # noqa: E402
from prehension.cli.simulate import EXIT_DROPPED  # noqa: E402
from prehension.hands.files import load_hand_file  # noqa: E402
from prehension.hands.link_meshes import link_mesh_triangles  # noqa: E402
from prehension.hands.mjcf import compile_mjcf  # noqa: E402
from prehension.interop.scene import OBJECT_NODE  # noqa: E402

MJCF_TEMPLATE = """<mujoco model="toy_gripper">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>
  <option integrator="implicitfast"/>
  <default>
    <default class="toy">
      <joint axis="0 1 0" damping="0.1" armature="0.001"/>
      <position kp="2" forcerange="-2 2"/>
      <default class="visual">
        <geom type="mesh" contype="0" conaffinity="0" group="2" material="grey"/>
      </default>
      <default class="collision">
        <geom group="3" type="box"/>
      </default>
      <default class="left"><joint range="0 0.9"/></default>
      <default class="right"><joint range="-0.9 0"/></default>
    </default>
  </default>
  <asset>
    <material name="grey" rgba="0.6 0.6 0.6 1"/>
    <mesh class="toy" file="palm.obj"/>
    <mesh class="toy" file="link.obj"/>
    <mesh class="toy" name="tip" file="tip.glb" scale="1.2 1 0.9"/>
  </asset>
  <worldbody>
    <body name="hand" childclass="toy" pos="0 0 0.1" quat="1 0 0 0">
      <geom class="visual" mesh="palm"/>
      <geom class="collision" size="0.045 0.02 0.01"/>
{fingers}    </body>
  </worldbody>
  <contact><exclude body1="hand" body2="left_base"/><exclude body1="hand" body2="right_base"/></contact>
  <actuator>
    <position name="left_a1" joint="left_j1" class="toy" ctrlrange="0 0.9"/>
    <position name="right_a1" joint="right_j1" class="toy" ctrlrange="-0.9 0"/>
  </actuator>
</mujoco>
"""
FINGER = """      <body name="{side}_base" pos="{x} 0 0.01">
        <joint name="{side}_j1" class="{side}"/>
        <geom class="visual" mesh="link"/>
        <geom class="collision" pos="0 0 0.025" size="0.006 0.006 0.025"/>
        <body name="{side}_tip" pos="0 0 0.05">
          <joint name="{side}_j2" class="{side}"/>
          <geom class="visual" mesh="tip"/>
          <geom class="collision" pos="0 0 0.015" size="0.006 0.006 0.015"/>
        </body>
      </body>
"""
MJCF = MJCF_TEMPLATE.replace("{fingers}", FINGER.format(side="left", x=-0.03) + FINGER.format(side="right", x=0.03))

TASK = """prehension: task/1
name: toy-pinch
hand: {mjcf: hand.xml}
object:
  name: cube
  shape: [{box: {center: [0, 0, 0], size: [30, 30, 30]}}]
  regions:
    A: {point: [-15, 0, 0], normal: [-1, 0, 0]}
    B: {point: [15, 0, 0], normal: [1, 0, 0]}
contacts:
  - {hand: left_tip, object: A}
  - {hand: right_tip, object: B}
fingers: [left, right]
"""


def write_gripper(folder: Path) -> Path:
    """The gripper's MJCF, its meshes under ``assets/`` (metres), and a pinch task beside it."""
    (folder / "assets").mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(extents=(0.09, 0.04, 0.02)).export(folder / "assets" / "palm.obj")
    link = trimesh.creation.box(extents=(0.012, 0.012, 0.05))
    link.apply_translation((0.0, 0.0, 0.025))
    link.export(folder / "assets" / "link.obj")
    tip = trimesh.creation.capsule(height=0.024, radius=0.006)
    tip.apply_translation((0.0, 0.0, 0.012))
    trimesh.Scene(tip).export(folder / "assets" / "tip.glb")
    (folder / "hand.xml").write_text(MJCF)
    (folder / "task.yaml").write_text(TASK)
    return folder / "hand.xml"


@pytest.fixture(scope="module")
def gripper(tmp_path_factory):
    folder = tmp_path_factory.mktemp("menagerie")
    path = write_gripper(folder)
    result = folder / "r.json"
    assert main(["solve", str(folder / "task.yaml"), "-o", str(result), "--quiet"]) == EXIT_OK
    assert json.loads(result.read_text())["status"] == "solved"
    return path, result


def test_the_menagerie_layout_hand_imports_with_its_classes(gripper):
    hand = load_hand_file(gripper[0])
    assert not [n for n in hand.notes if n.startswith("warning: ")], hand.notes
    assert hand.dof_names == ("left_j1", "left_j2", "right_j1", "right_j2")
    assert hand.lower.tolist() == [0.0, 0.0, -0.9, -0.9] and hand.upper.tolist() == [0.9, 0.9, 0.0, 0.0]  # classes
    assert {"left_tip", "right_tip"} <= set(hand.regions)
    box = hand.links[hand.link_index("left_tip")].collision  # the collision box, not the visual capsule
    assert len(box) >= 1
    drawn = {link.name: [Path(m.path).name for m in link.meshes] for link in hand.links}
    assert drawn == {"hand": ["palm.obj"], "left_base": ["link.obj"], "left_tip": ["tip.glb"],
                     "right_base": ["link.obj"], "right_tip": ["tip.glb"]}  # fmt: skip


def test_each_link_mesh_lies_where_mujoco_puts_its_geom(gripper):
    """The mesh files, read and placed by the LinkMesh (scale, MuJoCo's re-centring undone),
    give the vertices MuJoCo compiled, at the geom's pose in its body [mm]."""
    hand = load_hand_file(gripper[0])
    m = compile_mjcf(gripper[0])
    for g in range(m.ngeom):
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g]))
        mesh = int(m.geom_dataid[g])
        v = np.asarray(m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]], dtype=float)
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, m.geom_quat[g])
        want = 1000.0 * (v @ R.reshape(3, 3).T + m.geom_pos[g])
        file = Path(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, mesh) or "")
        (ref,) = [r for r in hand.links[hand.link_index(body)].meshes if Path(r.path).stem == file.stem]
        got = np.unique(link_mesh_triangles(ref)[0].round(9), axis=0)
        assert got.shape == np.unique(want.round(3), axis=0).shape
        d = np.linalg.norm(got[:, None, :] - want[None, :, :], axis=2)
        assert d.min(axis=1).max() < 1e-4 and d.min(axis=0).max() < 1e-4  # mm: MuJoCo keeps float32


def test_the_pinch_is_simulated_and_drawn(gripper, tmp_path, capsys):
    _, result = gripper
    out = tmp_path / "physics.json"
    capsys.readouterr()
    assert main(["simulate", str(result), "-o", str(out)]) in (EXIT_OK, EXIT_DROPPED)
    data = json.loads(out.read_text())
    (grasp,) = data["grasps"]
    assert len(grasp["pushes"]) == 6 and grasp["initial_penetration_mm"] <= 0.5
    glb = tmp_path / "pinch.glb"
    assert main(["export", str(result), "--format", "glb", "-o", str(glb)]) == EXIT_OK
    assert "5 link(s) drawn as their meshes" in " ".join(capsys.readouterr().out.split())
    scene = trimesh.load(glb, file_type="glb")
    assert set(scene.graph.nodes_geometry) == {"hand", "left_base", "left_tip", "right_base", "right_tip", OBJECT_NODE}
