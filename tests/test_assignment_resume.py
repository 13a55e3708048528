"""Going on from an earlier run's undecided assignments (``--retry-undecided``,
:mod:`prehension.assignment.resume`): the poses it tried are not tried again, and every
answer -- verdict, grasp, the local solver's statistics -- is the one a run from the first
pose gives."""

from __future__ import annotations

import json

import numpy as np
import pytest

import prehension.assignment.solving as solving
from prehension.assignment import AssignmentOptions, assignment_seed, concrete_task, enumerate_assignments, search_assignments
from prehension.assignment.resume import Earlier, earlier_runs
from prehension.cli import EXIT_GAVE_UP, main
from prehension.solvers.local import LocalOptions
from prehension.tasks.yaml_io import dumps_task
from test_assignment_files import open_pincer
from test_assignment_rounds import _open_case, _stats

I_MAX = 20


def _verdicts(report) -> dict:
    out = {o.assignment.label: ("solved", o.result.solutions[0].q.tobytes(), _stats(o.result)) for o in report.feasible}
    out |= {a.label: ("infeasible", None, None) for a, _ in report.infeasible}
    out |= {u.assignment.label: ("undecided", None, _stats(u.result)) for u in report.undecided}
    return out


def _stopped_after(task, seed: int, poses: int, i_max: int = I_MAX) -> dict:
    """What a run of ``i_max`` poses stopped after its first ``poses`` leaves (as a time
    limit leaves it): ``{label: Earlier}`` of the assignments those poses did not solve."""
    options = AssignmentOptions(seed=seed, local_options=LocalOptions(i_max=i_max), complete_time_s=0)
    assignments = enumerate_assignments(task)
    tasks = [concrete_task(task, a) for a in assignments]
    seeds = [assignment_seed(seed, a) for a in assignments]
    answers = solving.local_round(tasks, seeds, options, None, (0, poses))
    return {a.label: Earlier(s, i_max, result.stats, result.seconds)
            for a, s, (result, _) in zip(assignments, seeds, answers) if not result.success}  # fmt: skip


@pytest.fixture
def pose_calls(monkeypatch):
    """The pose ranges every call of the local solver's rounds asked for."""
    calls = []
    real = solving.local_round

    def spy(tasks, seeds, options, deadline=None, poses=None, earlier=None):
        calls.extend([poses] * len(tasks))
        return real(tasks, seeds, options, deadline, poses, earlier)

    monkeypatch.setattr(solving, "local_round", spy)
    return calls


@pytest.mark.parametrize("seed", [11, 23])
def test_going_on_after_2_poses_gives_the_answers_of_a_run_from_the_first(seed, pose_calls):
    task = _open_case(seed)
    options = AssignmentOptions(seed=seed, local_options=LocalOptions(i_max=I_MAX), complete_time_s=0, round_poses=2)
    expected = _verdicts(search_assignments(task, options))
    earlier = _stopped_after(task, seed, 2)
    assert any(v[0] == "solved" and v[2]["solved_with_pose"] > 2 for v in expected.values())
    skip = [label for label in expected if label not in earlier]
    pose_calls.clear()
    resumed = search_assignments(task, options, skip=skip, earlier=earlier)
    assert _verdicts(resumed) == {label: expected[label] for label in earlier}  # grasps and stats bit for bit
    assert pose_calls and all(poses is not None and poses[0] >= 2 for poses in pose_calls)  # no pose 1-2 again
    assert all("resumed_at_pose" not in u.result.stats for u in resumed.undecided)  # the record covered its poses


def test_a_round_cut_by_the_time_limit_starts_again_and_says_so(pose_calls):
    """3 poses tried: the round of poses 3-4 runs again; the iterations per pose are those of
    a run from the first pose, and stats["resumed_at_pose"] says the rest was not seen."""
    task = _open_case(11)
    options = AssignmentOptions(seed=11, local_options=LocalOptions(i_max=I_MAX), complete_time_s=0, round_poses=2)
    expected = _verdicts(search_assignments(task, options))
    earlier = _stopped_after(task, 11, 3)
    pose_calls.clear()
    resumed = search_assignments(task, options, skip=[label for label in expected if label not in earlier], earlier=earlier)
    assert min(poses[0] for poses in pose_calls) == 2
    for label, (status, q, stats) in _verdicts(resumed).items():
        want = expected[label]
        assert (status, q) == want[:2]
        assert stats["per_pose_iterations"] == want[2]["per_pose_iterations"] and stats["iterations"] == want[2]["iterations"]
    assert resumed.undecided and all(u.result.stats["resumed_at_pose"] == 3 for u in resumed.undecided)


def test_every_pose_tried_goes_straight_to_the_complete_solver(pose_calls):
    task = _open_case(23)
    earlier = _stopped_after(task, 23, 8, i_max=8)
    label = next(iter(earlier))
    skip = [a.label for a in enumerate_assignments(task) if a.label != label]
    pose_calls.clear()
    report = search_assignments(task, AssignmentOptions(seed=23, local_options=LocalOptions(i_max=8), complete_time_s=0.5),
                                skip=skip, earlier={label: earlier[label]})  # fmt: skip
    assert pose_calls == []  # no initial pose again
    (verdict,) = report.feasible + report.infeasible + report.undecided
    result = verdict.proof if hasattr(verdict, "proof") else verdict.result
    assert result.method == "complete" and result.stats["local"]["initial_poses_tried"] == 8


@pytest.mark.parametrize("seed, i_max", [(12, I_MAX), (11, 32)])
def test_another_seed_or_pose_count_starts_again_from_the_first_pose(seed, i_max, pose_calls):
    """Pose k beyond the sequence is drawn for the number of poses: pose 16 of 20 is not
    pose 16 of 32, so a record of another --initial-poses is not gone on from."""
    task = _open_case(11)
    earlier = _stopped_after(task, 11, 16)
    pose_calls.clear()
    options = AssignmentOptions(seed=seed, local_options=LocalOptions(i_max=i_max), complete_time_s=0, round_poses=4)
    search_assignments(task, options, skip=[a.label for a in enumerate_assignments(task) if a.label not in earlier],
                       earlier=earlier)  # fmt: skip
    assert (0, 4) in pose_calls and all(poses[0] in (0, 4) or poses[0] >= 8 for poses in pose_calls)


def test_retry_undecided_on_the_command_line_goes_on_from_the_journal(tmp_path, capsys, pose_calls):
    path = tmp_path / "open.yaml"
    path.write_text(dumps_task(open_pincer(60.0)))
    out = tmp_path / "out.jsonl"
    assert main(["solve", str(path), "--method", "local", "--quiet", "-o", str(out), "--initial-poses", "24"]) == EXIT_GAVE_UP
    records = [json.loads(line) for line in out.read_text().splitlines()]
    runs = earlier_runs(records)
    assert set(runs) == {"pad->A, tip->B", "tip->A, pad->B"} and {r.i_max for r in runs.values()} == {24}
    pose_calls.clear()
    main(["solve", str(path), "--quiet", "-o", str(out), "--initial-poses", "24", "--retry-undecided", "--assignment-time", "1"])
    assert pose_calls == []  # every pose was tried: straight to the complete solver
    results = {r["id"]: r for r in map(json.loads, out.read_text().splitlines()) if r.get("prehension") == "batch/1"}
    assert set(results) == set(runs)
    for record in results.values():
        assert record["method"] == "complete" and record["result"]["stats"]["local"]["initial_poses_tried"] == 24
    assert main(["check", str(out)]) == 0


def test_unreadable_earlier_records_are_left_out():
    good = {"initial_poses_tried": 2, "per_pose_iterations": [3, 4]}
    named = {"hand_regions": ["a"], "object_regions": ["b"], "initial_poses": 8}

    def record(id_, status="gave_up", method="local", seed=1, stats=good, assignment=named):
        return {"id": id_, "status": status, "method": method, "seed": seed, "assignment": assignment,
                "result": {"stats": stats, "seconds": 0.1}}  # fmt: skip

    records = [
        record("a"), record("b", method="complete", stats={"local": good}), record("c", status="solved"),
        record("d", stats={"initial_poses_tried": 3, "per_pose_iterations": [1]}), record("e", seed="x"),
        record("f", method="complete", stats={}), record("g", assignment={"hand_regions": ["a"], "object_regions": ["b"]}),
    ]  # fmt: skip
    runs = earlier_runs(records)
    assert set(runs) == {"a", "b"} and runs["a"].poses_tried == 2 and runs["a"].i_max == 8
    assert runs["a"].seconds == pytest.approx(0.1)
    np.testing.assert_array_equal(runs["b"].local_stats["per_pose_iterations"], [3, 4])
