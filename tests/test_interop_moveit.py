"""``export --format moveit``: moveit_msgs/Grasp messages (ROS 2 layout) in YAML or JSON; the
fields are the message's, the grasp pose and postures give the result's configuration back."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from prehension.cli import main
from prehension.cli.codes import EXIT_BAD_INPUT, EXIT_OK
from prehension.results import read_result

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "quality" / "box-four-fingers.result.json"

# the fields of each message, as moveit_msgs / trajectory_msgs / geometry_msgs define them
GRASP = ["id", "pre_grasp_posture", "grasp_posture", "grasp_pose", "grasp_quality", "pre_grasp_approach",
         "post_grasp_retreat", "post_place_retreat", "max_contact_force", "allowed_touch_objects"]  # fmt: skip
TRAJECTORY, POINT = ["header", "joint_names", "points"], ["positions", "velocities", "accelerations", "effort", "time_from_start"]
TRANSLATION = ["direction", "desired_distance", "min_distance"]


def _transform(pose: dict) -> np.ndarray:
    """The 4x4 [mm] of a geometry_msgs/Pose (metres, x, y, z, w)."""
    o, p = pose["orientation"], pose["position"]
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([o["x"], o["y"], o["z"], o["w"]]).as_matrix()
    T[:3, 3] = [1000.0 * p["x"], 1000.0 * p["y"], 1000.0 * p["z"]]
    return T


def _export(tmp_path, name: str, *argv) -> list:
    out = tmp_path / name
    assert main(["export", str(EXAMPLE), "--format", "moveit", "-o", str(out), *argv]) == EXIT_OK
    text = out.read_text()
    return yaml.safe_load(text) if out.suffix == ".yaml" else json.loads(text)


def test_the_grasp_messages_hold_the_results_configuration(tmp_path):
    task, data = read_result(EXAMPLE)
    grasps = _export(tmp_path, "g.yaml")
    assert len(grasps) == len(data["solutions"])
    for k, (g, sol) in enumerate(zip(grasps, data["solutions"])):
        assert list(g) == GRASP and g["id"] == f"{task.name}/{k}"
        for posture in (g["pre_grasp_posture"], g["grasp_posture"]):
            assert list(posture) == TRAJECTORY and posture["joint_names"] == list(task.hand.dof_names)
            assert all(list(p) == POINT for p in posture["points"])
        assert [p["time_from_start"] for p in g["grasp_posture"]["points"]] == [{"sec": 0, "nanosec": 500000000}, {"sec": 1, "nanosec": 0}]
        stages = [(g["grasp_posture"]["points"][0], sol["joint_angles_rad"]), (g["grasp_posture"]["points"][1], sol["squeeze"]["joint_angles_rad"]),
                  (g["pre_grasp_posture"]["points"][0], sol["pregrasp"]["joint_angles_rad"])]  # fmt: skip
        for point, angles in stages:
            assert point["positions"] == [angles[d] for d in task.hand.dof_names]  # exact
        assert g["grasp_pose"]["header"]["frame_id"] == task.object.name
        T_palm_object = np.linalg.inv(_transform(g["grasp_pose"]["pose"]))  # the palm in the object frame
        np.testing.assert_allclose(T_palm_object, sol["T_palm_object"], atol=1e-9)
        assert g["grasp_pose"]["pose"]["orientation"]["w"] >= 0
        assert g["grasp_quality"] == sol["quality"]["epsilon"]
        approach = g["pre_grasp_approach"]
        assert list(approach) == TRANSLATION and approach["direction"]["header"]["frame_id"] == task.hand.palm
        assert approach["desired_distance"] == pytest.approx(sol["pregrasp"]["back_off_mm"] / 1000.0)
        v = approach["direction"]["vector"]
        centre = np.mean([c["hand_point"] for c in sol["contacts"]], axis=0)
        np.testing.assert_allclose([v["x"], v["y"], v["z"]], centre / np.linalg.norm(centre), atol=1e-12)
        assert g["allowed_touch_objects"] == [task.object.name] and g["max_contact_force"] == 0.0


def test_the_palm_frame_holds_the_object_pose_and_json_equals_yaml(tmp_path):
    _, data = read_result(EXAMPLE)
    as_yaml = _export(tmp_path, "g.yaml", "--solution", "0", "--frame", "palm")
    as_json = _export(tmp_path, "g.json", "--solution", "0", "--frame", "palm")
    assert as_yaml == as_json and len(as_json) == 1
    g = as_json[0]
    assert g["grasp_pose"]["header"]["frame_id"] == "palm"
    np.testing.assert_allclose(_transform(g["grasp_pose"]["pose"]), data["solutions"][0]["T_palm_object"], atol=1e-9)


def test_a_solution_without_pregrasp_has_an_empty_pre_grasp(tmp_path):
    data = json.loads(EXAMPLE.read_text())
    for sol in data["solutions"]:
        sol.pop("pregrasp")
        sol.pop("squeeze")
    bare = tmp_path / "bare.result.json"
    bare.write_text(json.dumps(data))
    out = tmp_path / "g.json"
    assert main(["export", str(bare), "--format", "moveit", "-o", str(out)]) == EXIT_OK
    g = json.loads(out.read_text())[0]
    assert g["pre_grasp_posture"]["joint_names"] == [] and g["pre_grasp_posture"]["points"] == []
    assert len(g["grasp_posture"]["points"]) == 1 and g["pre_grasp_approach"]["desired_distance"] == 0.0


def test_moveit_options_are_checked(tmp_path, capsys):
    cases = {("--format", "moveit", "-o", str(tmp_path / "g.txt")): "must end in .yaml or .yml or .json",
             ("--format", "glb", "-o", str(tmp_path / "g.glb"), "--frame", "palm"): "--frame: for --format moveit only",
             ("--format", "json-m", "-o", str(tmp_path / "g.json"), "--frame", "palm"): "--frame: for --format moveit only"}  # fmt: skip
    for argv, message in cases.items():
        capsys.readouterr()
        assert main(["export", str(EXAMPLE), *argv]) == EXIT_BAD_INPUT
        assert message in " ".join(capsys.readouterr().err.split())
