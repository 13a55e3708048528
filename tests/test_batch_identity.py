"""A batch changes nothing but speed: a problem solved in a batch of the local solver gets
bit for bit the answer it gets alone (per-problem scales and seeds, issue 16)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from prehension.geometry.regions import BezierRegion
from prehension.objects.model import GraspObject
from prehension.solvers.local import LocalOptions, random_point_problems, solve_local, solve_local_batch
from prehension.tasks.library import load_builtin_task
from tiny_tasks import pincer_task


def scaled(task, factor: float):
    """``task`` with every Bézier region of its object scaled by ``factor`` about the
    object's origin: the same structure, other region sizes and another object extent."""
    regions = {
        name: BezierRegion(r.patch.transformed(factor * np.eye(3), np.zeros(3))) if isinstance(r, BezierRegion) else r
        for name, r in task.object.regions.items()
    }
    obj = GraspObject(task.object.name, regions, task.object.primitives)
    return replace(task, name=f"{task.name} x{factor:g}", object=obj)


def assert_same_record(mine, alone):
    """Every field of two LocalRecords equal, arrays bit for bit (the index aside)."""
    for field in ("success", "tolerance", "solved_with_pose", "initial_poses_tried", "iterations",
                  "per_pose_iterations", "polish_iterations", "collision_rejections", "i_max"):  # fmt: skip
        assert getattr(mine, field) == getattr(alone, field), field
    np.testing.assert_array_equal([mine.max_distance_mm, mine.max_normal_deg], [alone.max_distance_mm, alone.max_normal_deg])
    for field in ("joint_angles", "T_palm_object"):
        a, b = getattr(mine, field), getattr(alone, field)
        assert (a is None) == (b is None), field
        if a is not None:
            np.testing.assert_array_equal(a, b)
    if alone.contact_params is not None:
        for (h1, o1), (h2, o2) in zip(mine.contact_params, alone.contact_params):
            np.testing.assert_array_equal(h1, h2)
            np.testing.assert_array_equal(o1, o2)


@pytest.fixture(scope="module")
def mixed_tasks():
    """Tasks that share structures but not sizes: pincers of several widths (object
    extent), a built-in task and its object scaled (Bézier sizes and extent), and point
    problems of the SA hand (every one its own extent)."""
    lid = load_builtin_task("teapot-lid-lifting")
    points = random_point_problems(6, seed=3)
    return (
        [pincer_task(d) for d in (30.0, 38.0, 44.0, 60.0)]
        + [lid, scaled(lid, 1.15), scaled(lid, 0.9)]
        + [points.task(i) for i in range(len(points))]
    )


def test_tasks_solved_in_a_batch_are_bit_identical_to_alone(mixed_tasks):
    seeds = list(range(100, 100 + len(mixed_tasks)))
    batch = solve_local_batch(mixed_tasks, LocalOptions(), rng=seeds)
    assert sum(r.success for r in batch) >= len(mixed_tasks) - 2  # mostly solved: the comparison means something
    for task, seed, record in zip(mixed_tasks, seeds, batch):
        assert_same_record(record, solve_local_batch([task], LocalOptions(), rng=[seed])[0])
    reordered = solve_local_batch(mixed_tasks[::-1], LocalOptions(), rng=seeds[::-1])
    for a, b in zip(batch, reordered.records[::-1]):
        assert_same_record(a, b)


def test_random_initial_poses_draw_from_each_problems_own_seed(mixed_tasks):
    """With random initial poses, a task in a batch draws what it draws alone with its seed."""
    options = LocalOptions(initial="random", i_max=4)
    tasks = mixed_tasks[:7]
    seeds = [7, 8, 9, 10, 11, 12, 13]
    batch = solve_local_batch(tasks, options, rng=seeds)
    for task, seed, record in zip(tasks, seeds, batch):
        alone = solve_local(task, options, seed=seed)
        assert alone.status == record.status
        if record.joint_angles is not None:
            np.testing.assert_array_equal(alone.solutions[0].q, record.joint_angles)
        assert alone.stats["per_pose_iterations"] == list(record.per_pose_iterations)
    other = solve_local_batch(tasks, options, rng=[7, 8, 9, 10, 11, 12, 99])
    for a, b in zip(batch.records[:6], other.records[:6]):  # a neighbour's seed changes nothing
        assert_same_record(a, b)


def test_point_problems_in_a_batch_are_bit_identical_to_alone():
    base = random_point_problems(12, seed=5)
    batch = solve_local_batch(base.subset(np.arange(12)), LocalOptions(), rng=0)  # normals normalised as in subset([i])
    assert batch.success.sum() >= 9
    for i in range(12):
        assert_same_record(batch[i], solve_local_batch(base.subset([i]), LocalOptions(), rng=0)[0])


def test_one_seed_per_problem_is_checked():
    with pytest.raises(Exception, match="rng holds 2 seeds for 3 problems"):
        solve_local_batch([pincer_task(d) for d in (30.0, 35.0, 40.0)], LocalOptions(), rng=[1, 2])


# -- what the identity rests on, and the shortcuts that keep one task cheap -----------------
def test_forward_kinematics_gives_each_row_the_same_bits_whatever_the_batch(sa_hand):
    from prehension.hands.kinematics import forward_kinematics

    q = np.random.default_rng(2).uniform(sa_hand.lower, sa_hand.upper, (33, sa_hand.n_dof))
    many = forward_kinematics(sa_hand, q)
    for b in (0, 17, 32):
        one = forward_kinematics(sa_hand, q[b])
        for name in ("R_palm_link", "r_palm_link", "axis_palm", "origin_palm"):
            np.testing.assert_array_equal(getattr(one, name)[0], getattr(many, name)[b])


def test_a_tasks_masks_are_computed_once_and_read_only():
    task = load_builtin_task("guitar-tuning")
    assert task.active_mask is task.active_mask and task.idle_vector is task.idle_vector
    with pytest.raises(ValueError, match="read-only"):
        task.idle_vector[0] = 1.0
    assert task.fingers == ("index", "thumb")
    more = replace(task, fingers=("thumb", "index", "middle", "ring"))  # a new task computes its own
    assert more.active_mask.sum() > task.active_mask.sum()


def test_cross3_is_numpys_cross_bit_for_bit():
    from prehension.geometry.vectors import cross3

    rng = np.random.default_rng(4)
    for a_shape, b_shape in (((50, 3), (50, 3)), ((3,), (50, 3)), ((7, 4, 3), (7, 4, 3)), ((3,), (3,))):
        a, b = rng.normal(size=a_shape) * 1e3, rng.normal(size=b_shape)
        np.testing.assert_array_equal(cross3(a, b), np.cross(a, b))
