"""The MuJoCo qpos of a grasp (prehension.hands.qpos): frames, units, joint order, round trips."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import random_angles
from prehension.errors import InvalidConfiguration
from prehension.hands.kinematics import forward_kinematics
from prehension.interop import qpos_configuration, qpos_joint_order, solution_qpos, transform_from_base
from prehension.hands.qpos import base_from_transform, grasp_qpos
from prehension.results import read_result

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "quality" / "box-four-fingers.result.json"


def random_pose(rng) -> np.ndarray:
    """A rigid ``T_palm_object`` [mm]: a uniform rotation, a translation within 300 mm."""
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
    T[:3, 3] = rng.uniform(-300.0, 300.0, 3)
    return T


class _Grasp:  # what solution_qpos reads of a Solution
    def __init__(self, hand, q, T):
        self.joint_angles = dict(zip(hand.dof_names, q.tolist()))
        self.T_palm_object = T


def test_qpos_round_trip_over_random_configurations(sa_hand, rng):
    """qpos -> configuration gives the angles back exactly and the pose within 1e-9 mm."""
    for q in random_angles(sa_hand, rng, 200):
        T = random_pose(rng)
        v = solution_qpos(_Grasp(sa_hand, q, T), sa_hand)
        assert v.shape == (7 + sa_hand.n_dof,)
        assert np.linalg.norm(v[3:7]) == pytest.approx(1.0, abs=1e-12) and v[3] >= 0.0
        q2, T2 = qpos_configuration(v, sa_hand)
        assert np.max(np.abs(q2 - q)) <= 1e-9
        assert np.max(np.abs(T2[:3, 3] - T[:3, 3])) <= 1e-9  # the issue asks 1e-9 mm; the brief 1e-6
        assert np.max(np.abs(T2[:3, :3] - T[:3, :3])) <= 1e-12


def test_the_base_is_the_palm_in_the_object_frame_in_metres():
    """A palm 100 mm along the object's x, turned 90 deg about z: base (0.1, 0, 0), w-x-y-z."""
    T_object_palm = np.eye(4)
    T_object_palm[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    T_object_palm[:3, 3] = [100.0, 0.0, 0.0]
    base = base_from_transform(np.linalg.inv(T_object_palm))
    np.testing.assert_allclose(base, [0.1, 0, 0, np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-15)
    np.testing.assert_allclose(transform_from_base(base), np.linalg.inv(T_object_palm), atol=1e-12)


def test_the_solution_of_a_result_file_round_trips():
    task, data = read_result(EXAMPLE)
    entry = data["solutions"][0]
    T = np.array(entry["T_palm_object"])
    v = grasp_qpos(task.hand, T, entry["joint_angles_rad"])
    q, T2 = qpos_configuration(v, task)
    assert np.max(np.abs(q - [entry["joint_angles_rad"][d] for d in task.hand.dof_names])) <= 1e-9
    assert np.max(np.abs(T2 - T)) <= 1e-6


def test_a_qpos_set_on_the_exported_mujoco_hand_places_every_link_where_the_result_says(tmp_path):
    """export-hand's MJCF with a free joint on its palm, at an exported qpos: every body
    where T_object_palm @ T_palm_link puts it, within 0.01 mm (MuJoCo's world = the object frame)."""
    mujoco = pytest.importorskip("mujoco")
    from prehension.hands.export import hand_to_mjcf

    task, data = read_result(EXAMPLE)
    entry = data["solutions"][0]
    root = ET.fromstring(hand_to_mjcf(task.hand))
    palm = root.find("worldbody/body")
    palm.insert(0, ET.Element("freejoint", name="base"))
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    mj = mujoco.MjData(model)
    mj.qpos[:] = grasp_qpos(task.hand, np.array(entry["T_palm_object"]), entry["joint_angles_rad"])
    mujoco.mj_kinematics(model, mj)
    T_object_palm = np.linalg.inv(np.array(entry["T_palm_object"]))
    for name, T_palm_link in entry["link_poses"].items():
        want = (T_object_palm @ np.array(T_palm_link))[:3, 3] / 1000.0
        assert np.linalg.norm(mj.body(name).xpos - want) * 1000.0 < 0.01, name


def test_an_mjcf_hand_takes_the_files_joint_order(sa_hand, tmp_path):
    pytest.importorskip("mujoco")
    from prehension.hands.export import hand_to_mjcf
    from prehension.hands.mjcf import hand_from_mjcf

    path = tmp_path / "sa.xml"
    path.write_text(hand_to_mjcf(sa_hand))
    hand = hand_from_mjcf(path)
    written = [j.get("name") for j in ET.parse(path).getroot().find("worldbody").iter("joint")]
    assert qpos_joint_order(hand) == tuple(written)
    assert qpos_joint_order(sa_hand) == sa_hand.dof_names  # a built-in hand: its own order


def test_bad_qpos_are_refused_by_name(sa_hand, rng):
    v = solution_qpos(_Grasp(sa_hand, random_angles(sa_hand, rng, 1)[0], random_pose(rng)), sa_hand)
    with pytest.raises(InvalidConfiguration, match=r"takes 7 .* \+ 17 joint angles = 24.*another hand"):
        qpos_configuration(v[:-1], sa_hand)
    bad = v.copy()
    bad[3:7] *= 1.01
    with pytest.raises(InvalidConfiguration, match="not unit"):
        qpos_configuration(bad, sa_hand)
    bad = v.copy()
    bad[9] = np.nan
    with pytest.raises(InvalidConfiguration, match="non-finite"):
        qpos_configuration(bad, sa_hand)
    with pytest.raises(InvalidConfiguration, match="lack"):
        grasp_qpos(sa_hand, np.eye(4), {})


def test_forward_kinematics_agrees_with_the_base(sa_hand, rng):
    """A fingertip's position in the object frame from the qpos equals the one from T_palm_object."""
    q = random_angles(sa_hand, rng, 1)[0]
    T = random_pose(rng)
    v = solution_qpos(_Grasp(sa_hand, q, T), sa_hand)
    T_object_palm = np.linalg.inv(transform_from_base(v[:7]))
    tip = forward_kinematics(sa_hand, q).T_palm_link[0, -1]
    np.testing.assert_allclose((T_object_palm @ tip)[:3, 3], (np.linalg.inv(T) @ tip)[:3, 3], atol=1e-9)


def test_the_package_names_the_qpos_functions_and_the_cli_lists_the_readers_formats():
    import prehension
    from prehension.cli.import_grasps import IMPORT_FORMATS as CLI_FORMATS
    from prehension.interop.readers import IMPORT_FORMATS

    assert prehension.solution_qpos is solution_qpos and prehension.qpos_configuration is qpos_configuration
    assert CLI_FORMATS == IMPORT_FORMATS


def test_solution_qpos_is_the_method_of_the_solution():
    """``Solution.qpos(model)`` (the issue's Python side) is ``solution_qpos``, and its inverse
    gives back the solution's angles and pose."""
    from prehension import load_builtin_task, solve
    from prehension.hands.qpos import qpos_configuration, solution_qpos

    task = load_builtin_task("scalpel-handling")
    (solution, *_) = solve(task, "local").solutions
    qpos = solution.qpos(task)
    assert np.array_equal(qpos, solution_qpos(solution, task.hand))
    q, T = qpos_configuration(qpos, task)
    assert np.allclose(q, solution.q, atol=1e-12, rtol=0) and np.allclose(T, solution.T_palm_object, atol=1e-9, rtol=0)
