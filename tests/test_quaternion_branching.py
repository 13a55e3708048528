"""Quaternion branching (``ShrinkOptions(quaternions=...)``, :mod:`prehension.solvers.complete.branching`):
the quaternion variables and ``R = R(q)`` hold at every configuration, the default system
is unchanged, and a search splitting by the quaternion never loses a known solution."""

from __future__ import annotations

import numpy as np
import pytest
from fk_tasks import box_around, build_fk_case
from scipy.spatial.transform import Rotation
from tiny_tasks import FEASIBLE_UP_TO_MM, pincer_task

from prehension.errors import PrehensionError
from prehension.results import Status
from prehension.solvers.complete.branching import scaled_widths, shrink_variables, split_variable
from prehension.solvers.complete.checkpoint import _options_mapping
from prehension.solvers.complete.contract import contract
from prehension.solvers.complete.search import BranchAndPruneOptions, process_box, solve_complete
from prehension.solvers.complete.shrink import ShrinkOptions, shrink_box
from prehension.solvers.local.verifier import LocalVerifier
from prehension.system.embedding import embed, unit_quaternion
from prehension.system.formulation import build_system
from prehension.system.keys import QuaternionComponent
from prehension.verification.residuals import Tolerances

ANY_COLLISION = Tolerances(penetration_mm=float("inf"))


def r_of_q(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]])  # fmt: skip


def test_unit_quaternion_gives_back_every_rotation_with_w_at_least_0():
    rng = np.random.default_rng(4100)
    half_turns = [Rotation.from_rotvec(np.pi * a / np.linalg.norm(a)).as_matrix() for a in rng.normal(size=(20, 3))]
    near = [Rotation.from_rotvec((np.pi - 1e-9) * a / np.linalg.norm(a)).as_matrix() for a in rng.normal(size=(20, 3))]
    for R in [np.eye(3), *Rotation.random(300, random_state=4101).as_matrix(), *half_turns, *near]:
        q = unit_quaternion(R)
        assert q[0] >= 0.0 and abs(np.linalg.norm(q) - 1.0) < 1e-14
        assert np.abs(r_of_q(q) - R).max() < 1e-12
        # the scipy convention (x, y, z, w), up to the sign
        s = Rotation.from_matrix(R).as_quat()[[3, 0, 1, 2]]
        assert min(np.abs(q - s).max(), np.abs(q + s).max()) < 1e-9


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("mode", ["palm", "links"])
def test_forward_built_solutions_are_points_of_the_system_with_quaternions(sa_hand, seed, mode):
    """``|q|^2 = 1`` and ``R = R(q)`` hold at the embedded point of a known solution, which lies in
    the initial box; the variables before the quaternions are the default system's, unchanged."""
    case = build_fk_case(sa_hand, np.random.default_rng(4200 + seed))
    plain, form = build_system(case.task), build_system(case.task, mode)
    n = plain.system.n
    assert form.system.names[:n] == plain.system.names
    assert np.array_equal(form.system.lower[:n], plain.system.lower) and np.array_equal(form.system.upper[:n], plain.system.upper)
    assert set(form.quaternion_vars) == ({sa_hand.palm} if mode == "palm" else set(form.links))
    x = embed(form, case.config)
    assert np.array_equal(x[:n], embed(plain, case.config))
    system = form.system
    assert np.abs(system.residuals(x)).max() < 1e-9 and system.inequality_violation(x) < 1e-9
    assert np.all(x >= system.lower) and np.all(x <= system.upper)
    for link, q in form.quaternion_vars.items():
        assert np.abs(r_of_q(x[q]) - x[form.R_object_link[link]]).max() < 1e-12 and x[q[0]] >= 0.0
        assert [form.base_keys[int(i)] for i in q] == [QuaternionComponent(link, k) for k in range(4)]


def test_the_default_system_has_no_quaternion_and_bad_modes_are_refused(sa_hand):
    case = build_fk_case(sa_hand, np.random.default_rng(4300))
    assert build_system(case.task).quaternion_vars == {}
    assert build_system(case.task, "none").system.names == build_system(case.task).system.names
    with pytest.raises(ValueError, match="quaternions must be one of 'none', 'palm', 'links', got 'wrist'"):
        build_system(case.task, "wrist")
    for bad in ({"quaternions": "all"}, {"branch_width": 0.0}, {"branch_width": 1.5}):
        with pytest.raises(ValueError, match="ShrinkOptions.(quaternions|branch_width)"):
            ShrinkOptions(**bad)


@pytest.mark.parametrize("seed", [0, 1, 2, 4] + [pytest.param(s, marks=pytest.mark.slow) for s in (3, 5, 6, 7)])  # 10-30 s each
def test_contraction_and_lps_keep_a_known_solution_in_random_boxes(sa_hand, seed):
    """The enclosure holds what it bounds: seeded random boxes around a known solution's
    point, shrunk by contraction and a pass of LPs over the system with quaternions, keep it."""
    rng = np.random.default_rng(4400 + seed)
    case = build_fk_case(sa_hand, rng)
    form = build_system(case.task, "links" if seed % 2 else "palm", angles=seed % 2 == 0)
    x = embed(form, case.config)
    for _ in range(3):
        lower, upper = box_around(rng, form, x[None], 10.0 ** rng.uniform(-4, -0.3))
        lo, hi, empty = contract(form.system, lower, upper)
        assert not empty and np.all(lo <= x + 1e-9) and np.all(x <= hi + 1e-9)
    shrunk = shrink_box(form.system, lower, upper, ShrinkOptions(variables=shrink_variables(form), max_passes=1))
    assert not shrunk.empty and np.all(shrunk.lower <= x + 1e-9) and np.all(x <= shrunk.upper + 1e-9)


def test_the_split_takes_the_quaternion_then_the_angles_above_the_threshold(sa_hand):
    form = build_system(build_fk_case(sa_hand, np.random.default_rng(4500)).task, "palm", angles=True)
    q, angles = form.quaternion_vars[sa_hand.palm], sorted(form.angle_vars.values())
    lower, upper = form.system.lower.copy(), form.system.upper.copy()
    upper[q[0]] = 0.5  # w in [0, 0.5]: scaled width 0.5; x, y, z: 1
    on = ShrinkOptions(quaternions="palm", angles=True, branch_width=0.25)
    assert split_variable(form, lower, upper, on) == q[1]  # the first widest component
    lower[q[1:]], upper[q[1:]] = -0.1, 0.1  # x, y, z: 0.05; w 0.5 > 0.25
    assert split_variable(form, lower, upper, on) == q[0]
    upper[q[0]] = 0.2  # the quaternion below the threshold: the widest angle
    assert split_variable(form, lower, upper, on) == angles[0]
    upper[angles[0]] = lower[angles[0]]
    assert split_variable(form, lower, upper, on) == angles[1]
    lower[angles], upper[angles] = 0.0, 0.0  # all below the threshold: the widest base variable
    default = int(form.base_indices[int(np.argmax(scaled_widths(form, lower, upper)))])
    assert default not in q and split_variable(form, lower, upper, on) == default
    assert split_variable(form, lower, upper, ShrinkOptions()) == default


@pytest.mark.parametrize("seed", range(6))
def test_angle_offsets_hold_at_forward_built_solutions_and_halve_the_range(sa_hand, seed):
    """``sin(theta - mid)`` at a known solution is the sine of its angle's offset from the
    middle of its range, inside its bounds; only angles of half range below 90 deg have one."""
    case = build_fk_case(sa_hand, np.random.default_rng(4700 + seed))
    form = build_system(case.task, angles=True)
    x = embed(form, case.config)
    assert np.abs(form.system.residuals(x)).max() < 1e-9
    assert np.all(x >= form.system.lower) and np.all(x <= form.system.upper)
    assert form.angle_vars and set(form.angle_vars) <= set(form.dof_vars)
    hand = case.task.hand
    for dof, i in form.angle_vars.items():
        lo, hi = hand.lower[hand.dof_index(dof)], hand.upper[hand.dof_index(dof)]
        assert hi - lo < np.pi
        theta = case.config.joint_angles[hand.dof_index(dof)]
        assert abs(x[i] - np.sin(theta - 0.5 * (lo + hi))) < 1e-9
        assert form.system.upper[i] == pytest.approx(np.sin(0.5 * (hi - lo)), abs=1e-11)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
@pytest.mark.parametrize("mode", ["palm", "links", "palm+angles"])
def test_the_search_path_to_a_known_solution_is_never_cut(sa_hand, seed, mode):
    """Down the boxes a quaternion-splitting search processes (contraction, LPs, prunes; no
    verification, so every box is split), the child holding a known solution is never
    emptied, and the first splits are the quaternion's."""
    case = build_fk_case(sa_hand, np.random.default_rng(4600 + seed), palm=False)
    quaternions, angles = mode.split("+")[0], mode.endswith("angles")
    form = build_system(case.task, quaternions, angles)
    x = embed(form, case.config)
    options = BranchAndPruneOptions(verifier=None, sigma=0.01, tolerances=ANY_COLLISION,
                                    shrink=ShrinkOptions(quaternions=quaternions, angles=angles))  # fmt: skip
    quaternion = set(np.concatenate(list(form.quaternion_vars.values())).tolist())
    lower, upper = form.system.lower.copy(), form.system.upper.copy()
    for depth in range(6 if angles else 4):
        out = process_box(form, lower, upper, depth, options)
        assert out.kind == "split", (depth, out.kind)
        assert np.all(out.lower <= x + 1e-9) and np.all(x <= out.upper + 1e-9)
        (lo, left_hi), (right_lo, hi) = out.children
        k = int(np.flatnonzero(left_hi != hi)[0])
        assert depth > 0 or k in quaternion
        lower, upper = next((a, b) for a, b in out.children if np.all(a <= x + 1e-9) and np.all(x <= b + 1e-9))


@pytest.mark.parametrize("mode", [{"quaternions": "palm"}, {"quaternions": "links"}, {"quaternions": "palm", "angles": True}])
def test_the_pincer_is_decided_alike_and_checkpoints_tell_the_searches_apart(tmp_path, mode):
    options = BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=120, shrink=ShrinkOptions(**mode))
    assert solve_complete(pincer_task(FEASIBLE_UP_TO_MM - 1.0), options).status == Status.SOLVED
    assert solve_complete(pincer_task(FEASIBLE_UP_TO_MM + 1.0), options).status == Status.INFEASIBLE
    # box by box (no pair test) the quaternion search proves the pincer too, and resumes from its checkpoint
    task, ckpt = pincer_task(50.0), tmp_path / "q.json"
    slow = BranchAndPruneOptions(verifier=LocalVerifier(), pair_test_boxes=0, shrink=ShrinkOptions(**mode))
    first = solve_complete(task, BranchAndPruneOptions(**{**slow.__dict__, "max_boxes": 2}), checkpoint=ckpt)
    assert first.status == Status.GAVE_UP and ckpt.is_file()
    with pytest.raises(PrehensionError, match="another task|other search options"):
        solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), pair_test_boxes=0), checkpoint=ckpt, resume=True)
    resumed = solve_complete(task, slow, checkpoint=ckpt, resume=True)
    assert resumed.status == Status.INFEASIBLE and resumed.stats["boxes"] > 2


def test_the_fingerprint_leaves_the_quaternions_out_when_off():
    old = _options_mapping(BranchAndPruneOptions())
    assert not {"shrink.quaternions", "shrink.angles", "shrink.branch_width"} & set(old)
    assert _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(branch_width=0.5))) == old  # meaningless when off
    angles = _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(angles=True)))
    assert angles["shrink.angles"] is True and angles["shrink.branch_width"] == 0.25 and "shrink.quaternions" not in angles
    on = _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(quaternions="palm")))
    assert on["shrink.quaternions"] == "palm" and on["shrink.branch_width"] == 0.25
    assert _options_mapping(BranchAndPruneOptions(shrink=ShrinkOptions(quaternions="palm", branch_width=0.5))) != on
