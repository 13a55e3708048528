"""The assignment search in rounds of initial poses: the local solver's pose ranges give,
merged, exactly what one call from the first pose gives; the search's verdicts and grasps
do not depend on the round size; a time limit names the poses tried."""

from __future__ import annotations

import numpy as np
import pytest

from fk_tasks import build_fk_case
from prehension.assignment import AssignmentOptions, OpenContact, OpenTask, assignment_seed, concrete_task, search_assignments
from prehension.assignment import enumerate_assignments
from prehension.assignment.rounds import round_ranges
from prehension.errors import InvalidTask, PrehensionError
from prehension.hands.sa_hand import schunk_sa_hand
from prehension.solvers.local import LocalOptions, solve_local_batch

def _open_case(seed: int) -> OpenTask:
    """A forward-built three-fingertip task, every contact open to the SA hand's five
    regions: 60 assignments, about half of them solvable."""
    case = build_fk_case(schunk_sa_hand(), np.random.default_rng(seed), fingers=("thumb", "index", "middle"), palm=False)
    t = case.task
    return OpenTask(t.name, t.hand, t.object, tuple(OpenContact(c.object_region, None) for c in t.contacts), None)


def test_round_ranges():
    assert round_ranges(64, 8) == [(0, 8), (8, 16), (16, 32), (32, 64)]
    assert round_ranges(20, 8) == [(0, 8), (8, 16), (16, 20)]
    assert round_ranges(20, 3) == [(0, 3), (3, 6), (6, 12), (12, 20)]
    assert round_ranges(12, 12) == [None] and round_ranges(12, None) == [None]


@pytest.mark.parametrize("seed", [21, 22])
def test_pose_ranges_merged_give_the_whole_call(seed):
    """60 assignments (half not solvable), i_max 20 beyond a short sequence's reach: the
    records of rounds of 6 poses, merged, equal the records of one call -- answers bit for
    bit, poses, iterations, rejections, closest misses, messages."""
    task = _open_case(seed)
    assignments = enumerate_assignments(task)
    tasks = [concrete_task(task, a) for a in assignments]
    seeds = [assignment_seed(seed, a) for a in assignments]
    options = LocalOptions(i_max=20)
    whole = list(solve_local_batch(tasks, options, None, seeds))
    merged: list = [None] * len(tasks)
    todo = list(range(len(tasks)))
    for start in range(0, 20, 6):
        stop = min(start + 6, 20)
        part = solve_local_batch([tasks[i] for i in todo], options, None, [seeds[i] for i in todo], poses=(start, stop))
        for i, record in zip(todo, part):
            merged[i] = record if merged[i] is None else merged[i].followed_by(record)
        todo = [i for i in todo if merged[i].joint_angles is None]
    assert any(r.success for r in whole) and any(not r.success for r in whole)
    for a, b in zip(whole, merged):
        assert a.stats == b.stats and a.message == b.message
        if a.success:
            np.testing.assert_array_equal(a.joint_angles, b.joint_angles)
            np.testing.assert_array_equal(a.T_palm_object, b.T_palm_object)


def test_bad_pose_ranges_are_refused():
    task = _open_case(21)
    t = concrete_task(task, enumerate_assignments(task)[0])
    for poses in [(0, 0), (-1, 3), (3, 2), (0, 13), (1.0, 3), (1,)]:
        with pytest.raises(InvalidTask, match="poses must be"):
            solve_local_batch([t], LocalOptions(i_max=12), None, [0], poses=poses)
    for options in [LocalOptions(initial="random"), LocalOptions(approximate=True)]:
        with pytest.raises(InvalidTask, match="initial='sequence'"):
            solve_local_batch([t], options, None, [0], poses=(4, 8))
    with pytest.raises(PrehensionError, match="round_poses"):
        AssignmentOptions(round_poses=0)


@pytest.mark.parametrize("seed", [11, 23])
def test_rounds_do_not_change_an_answer(seed):
    """The search in rounds of 3 and 8 poses, here and on an executor, against one round
    of every pose: the same verdicts, grasps and local stats per assignment."""
    from concurrent.futures import ThreadPoolExecutor

    task = _open_case(seed)
    local = LocalOptions(i_max=20)
    base = AssignmentOptions(seed=seed, local_options=local, complete_time_s=0, round_poses=None, chunk_size=5)

    def verdicts(report):
        out = {o.assignment.label: ("solved", o.result.solutions[0].q.tobytes(), _stats(o.result)) for o in report.feasible}
        out |= {a.label: ("infeasible", None, None) for a, _ in report.infeasible}
        out |= {u.assignment.label: ("undecided", None, _stats(u.result)) for u in report.undecided}
        return out

    expected = verdicts(search_assignments(task, base))
    assert len(expected) == 60 and any(v[0] == "solved" for v in expected.values())
    with ThreadPoolExecutor(2) as pool:
        for options in (AssignmentOptions(seed=seed, local_options=local, complete_time_s=0, round_poses=3, chunk_size=4),
                        AssignmentOptions(seed=seed, local_options=local, complete_time_s=0, round_poses=8, executor=pool)):
            assert verdicts(search_assignments(task, options)) == expected


def _stats(result) -> dict:
    return {k: v for k, v in result.stats.items() if k in ("initial_poses_tried", "iterations", "per_pose_iterations",
                                                           "collision_rejections", "solved_with_pose")}  # fmt: skip


def test_a_time_limit_names_the_poses_tried():
    """Stopped by its time limit, the search names each undecided assignment with the
    initial poses it had tried; feasible ones found in the first rounds stay found."""
    task = _open_case(11)
    report = search_assignments(task, AssignmentOptions(seed=11, complete_time_s=0, time_limit_s=0.05, chunk_size=4))
    assert len(report.feasible) + len(report.infeasible) + len(report.undecided) == 60
    reasons = [reason for _, reason in report.undecided if "time limit" in reason]
    assert reasons and all("initial poses tried" in r and " of 64 " in r for r in reasons)
