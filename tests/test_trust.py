"""Trustworthy answers: `solve` and `check` never disagree, and `check` catches every
tampered claim of a result file."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK, main
from prehension.results import Status, result_to_dict, write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solve import SolveOptions, solve
from prehension.solvers.local import LocalOptions
from prehension.tasks.library import load_builtin_task
from prehension.tasks.yaml_io import dumps_task
from prehension.verification import verify_result
from tiny_tasks import FEASIBLE_UP_TO_MM, pincer_task


@pytest.fixture(scope="module")
def solved_lid():
    """A solved built-in task (a moving index and thumb, idle middle and ring fingers)."""
    result = solve(load_builtin_task("teapot-lid-lifting"), "local")
    assert result.success
    return result_to_dict(result, quality_entries(result), approach_entries_of(result))


# -- solve and check never disagree --------------------------------------------------------------
NEAR_THE_FRONTIER = [30.0, 46.0, FEASIBLE_UP_TO_MM - 0.2, FEASIBLE_UP_TO_MM + 0.3, FEASIBLE_UP_TO_MM + 1.0, 50.0, 60.0]


@pytest.mark.parametrize("approximate", [False, True])
@pytest.mark.parametrize("d", NEAR_THE_FRONTIER)
def test_solve_then_check_never_disagree(tmp_path, capsys, d, approximate):
    """Tasks on both sides of the reach frontier (0.3 mm past it, within the paper's d_min
    = 1.5 mm): whatever `solve` answers, `check` on its file gives the same exit code."""
    task_file = tmp_path / "t.yaml"
    task_file.write_text(dumps_task(pincer_task(d)))
    out = tmp_path / "r.json"
    argv = ["solve", str(task_file), "-o", str(out), "--quiet", "--time-limit", "20"] + (["--approximate"] if approximate else [])
    code = main(argv)
    data = json.loads(out.read_text())
    assert data["status"] != Status.SOLVED or d <= FEASIBLE_UP_TO_MM  # never "solved" out of reach
    if data["status"] == Status.SOLVED:
        assert data["solutions"][0]["tolerances"]["contact_mm"] == 1e-6
    assert main(["check", str(out), "--time-limit", "20"]) == code
    if not approximate:
        assert data["status"] != Status.APPROXIMATE


@pytest.mark.parametrize("name", ["teapot-lid-lifting", "scalpel-handling", "guitar-playing", "teapot-transportation"])
def test_solve_then_check_agree_on_built_in_tasks(tmp_path, name):
    out = tmp_path / "r.json"
    code = main(["solve", name, "--method", "local", "-o", str(out), "--quiet"])
    assert main(["check", str(out)]) == code


def test_an_approximate_answer_is_never_called_solved(tmp_path):
    """Just out of reach, the local solver alone finds only a d_min answer: returned under
    its own status when asked for, re-checked with the tolerances it states."""
    task = pincer_task(FEASIBLE_UP_TO_MM + 0.3)
    loose = solve(task, SolveOptions(method="local", local_options=LocalOptions(approximate=True)))
    strict = solve(task, "local")
    assert strict.status == Status.GAVE_UP and not strict.solutions
    assert loose.status == Status.APPROXIMATE and not loose.success and loose.solutions
    path = tmp_path / "a.json"
    write_result(loose, path, quality_entries(loose), approach_entries_of(loose))
    assert main(["check", str(path)]) == 6  # EXIT_APPROXIMATE: holds, but only within the stated tolerances
    data = json.loads(path.read_text())
    data["status"], data["success"] = "solved", True  # claiming "solved" for it is caught
    path.write_text(json.dumps(data))
    assert main(["check", str(path)]) == EXIT_CHECK_FAILED


def test_infeasible_is_re_proved_on_the_embedded_task(tmp_path, capsys):
    out = tmp_path / "r.json"
    task_file = tmp_path / "t.yaml"
    task_file.write_text(dumps_task(pincer_task(60.0)))
    assert main(["solve", str(task_file), "--method", "complete", "-o", str(out), "--quiet"]) == EXIT_INFEASIBLE
    capsys.readouterr()
    assert main(["check", str(out)]) == EXIT_INFEASIBLE
    assert "re-proved" in capsys.readouterr().out
    assert main(["check", str(out), "--no-reprove"]) == EXIT_GAVE_UP  # only restated, never "verified"
    data = json.loads(out.read_text())
    data["task"] = json.loads(json.dumps(_task_dict(pincer_task(30.0))))  # the proof does not fit this task
    out.write_text(json.dumps(data))
    assert main(["check", str(out)]) == EXIT_CHECK_FAILED


def _task_dict(task):
    from prehension.tasks.yaml_io import task_to_dict

    return task_to_dict(task)


# -- tampering ---------------------------------------------------------------------------------
def _first(data):
    return data["solutions"][0]


def _shift_deg(data):
    sol = _first(data)
    name = "index_mcp_flex"
    sol["joint_angles_deg"][name] += 1.0


def _shift_rad(data):
    _first(data)["joint_angles_rad"]["thumb_base"] += np.radians(1.0)


def _move_idle_finger(data):
    """Both units edited consistently: the link poses and the held angle still tell."""
    sol = _first(data)
    sol["joint_angles_rad"]["middle_mcp_flex"] = np.radians(20.0)
    sol["joint_angles_deg"]["middle_mcp_flex"] = 20.0


def _move_link(data):
    _first(data)["link_poses"]["index_distal"][0][3] += 1.0


def _drop_link(data):
    del _first(data)["link_poses"]["ring_distal"]


def _distance(data):
    _first(data)["contacts"][0]["distance_mm"] = 0.5


def _angle(data):
    _first(data)["contacts"][1]["normal_angle_deg"] += 0.01


def _hand_point(data):
    _first(data)["contacts"][0]["hand_point"][2] += 0.1


def _object_normal(data):
    n = np.array(_first(data)["contacts"][1]["object_normal"])
    _first(data)["contacts"][1]["object_normal"] = (n / np.linalg.norm(n) + [0, 0.01, 0]).tolist()


def _object_pose(data):
    _first(data)["T_palm_object"][1][3] += 1.0


def _worst(data):
    _first(data)["worst"]["contact_distance"] += 1e-3


def _tolerances(data):
    _first(data)["tolerances"]["contact_mm"] = 2.0


def _solved_without_solution(data):
    data["solutions"] = []


def _infeasible_with_solution(data):
    data["status"], data["success"], data["method"] = "infeasible", False, "complete"


def _success_flag(data):
    data["success"] = False


def _unknown_status(data):
    data["status"] = "great"


def _task_region_moved(data):
    if "mesh" in data["task"]["object"] or "shape" in data["task"]["object"]:
        data["task"]["object"]["surface_tolerance_mm"] = 5.0  # else the moved region is refused at load
    region = data["task"]["object"]["regions"]
    name = next(iter(region))
    spec = region[name]
    key = next(k for k in spec if k in ("bezier", "point", "sphere_cap"))
    if key == "bezier":
        spec[key][0][0][0] += 1.0
    elif key == "point":
        spec[key][0] += 1.0
    else:
        spec[key]["center"][0] += 1.0


def _geometry_digest(data):
    data["collision_geometry"]["digest"] = "sha256:0000000000000000"


def _geometry_stick_out(data):
    data["collision_geometry"]["links"]["palm"]["stick_out_mm"] += 1.0


def _capsule_grown_in_task(data):
    data["task"]["hand"]["links"][1]["collision"][0]["radius"] += 0.5  # the file's geometry is not what judged it


def _fit_changed_in_task(data):
    data["task"]["hand"]["links"][0]["fit"]["miss_mm"] = 0.0


TAMPERS = [
    _geometry_digest, _geometry_stick_out, _capsule_grown_in_task, _fit_changed_in_task, _shift_deg, _shift_rad, _move_idle_finger, _move_link, _drop_link, _distance, _angle, _hand_point,
    _object_normal, _object_pose, _worst, _tolerances, _solved_without_solution, _infeasible_with_solution,
    _success_flag, _unknown_status, _task_region_moved,
]  # fmt: skip


def test_an_untouched_result_holds(solved_lid):
    checked = verify_result(copy.deepcopy(solved_lid))
    assert checked.holds, [f for f in checked.failures]
    assert len(checked.findings) >= 10


@pytest.mark.parametrize("tamper", TAMPERS, ids=[t.__name__.strip("_") for t in TAMPERS])
def test_every_tampered_claim_is_caught(solved_lid, tamper, tmp_path, capsys):
    data = copy.deepcopy(solved_lid)
    tamper(data)
    checked = verify_result(data, reprove=False)
    assert not checked.holds
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    assert main(["check", str(path), "--no-reprove"]) == EXIT_CHECK_FAILED
    assert "DOES NOT HOLD" in capsys.readouterr().out


def test_a_file_without_its_task_is_a_clear_error(solved_lid, tmp_path, capsys):
    data = copy.deepcopy(solved_lid)
    del data["task"]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    assert main(["check", str(path)]) == EXIT_BAD_INPUT
    assert "has no 'task'" in capsys.readouterr().err


def test_malformed_solutions_are_findings_not_tracebacks(solved_lid):
    data = copy.deepcopy(solved_lid)
    del _first(data)["joint_angles_rad"]["thumb_base"]
    checked = verify_result(data)
    assert not checked.holds and "malformed" in checked.failures[0].detail


def test_a_gave_up_result_writes_strict_json(tmp_path):
    """No literal NaN in a result file: other programs' JSON readers refuse it."""
    far = pincer_task(80.0)
    result = solve(far, SolveOptions(method="local", local_options=LocalOptions(i_max=2, k_max=5)))
    assert result.status == Status.GAVE_UP
    path = tmp_path / "g.json"
    write_result(result, path, quality_entries(result), approach_entries_of(result))

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    json.loads(path.read_text(), parse_constant=refuse)


def test_a_solution_names_the_idle_angles_that_differ_from_the_task():
    import numpy as np

    from prehension.results import _solution
    from prehension.solvers.local import solve_local
    from prehension.tasks.library import load_builtin_task
    from prehension.tasks.model import Configuration

    task = load_builtin_task("teapot-lid-lifting")
    sol = solve_local(task).solutions[0]
    idle = [d for d, a in zip(task.hand.dof_names, task.active_mask) if not a]
    q = sol.q.copy()
    for d in idle[:2]:
        i = task.hand.dof_index(d)
        q[i] = 0.5 * (task.idle_vector[i] + task.hand.upper[i]) if task.idle_vector[i] < task.hand.upper[i] else task.hand.lower[i]
    config = Configuration(q, sol.T_palm_object, sol.configuration().contact_params)
    made = _solution(task, config, __import__("prehension").forward_kinematics(task.hand, q), sol.report, sol.tolerances)
    assert made.idle_moved == tuple(idle[:2]) and len(idle) > 2
    assert list(made.joint_angles) == list(task.hand.dof_names) and all(type(v) is float for v in made.joint_angles.values())
    np.testing.assert_array_equal(np.array(list(made.joint_angles.values())), q)
    assert list(made.link_poses) == list(task.hand.link_names)
